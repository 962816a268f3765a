//! The NatNet server's configuration: bodies, rate, fault knobs.
//!
//! Why a file of its own: the same config drives the library server in
//! tests and the `natnet-serve` binary (TOML, `deny_unknown_fields`, every
//! key documented here and in `deploy/natnet-serve.toml`).

use serde::Deserialize;

/// The largest config file `natnet-serve` reads (a few bodies and fault
/// knobs fit in far less; the cap is a lab scenario's).
pub const MAX_FILE_BYTES: u64 = 64 * 1024;

/// Everything the server needs.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ServerConfig {
    /// Frames per second streamed (Motive's default is 120).
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// Application name announced in the server info.
    #[serde(default = "default_app_name")]
    pub app_name: String,
    /// Also send every frame to this multicast group (e.g.
    /// "239.255.42.99:1511"); unicast to connected clients always.
    #[serde(default)]
    pub multicast: Option<std::net::SocketAddrV4>,
    /// The rigid bodies served, as Motive would define them.
    pub bodies: Vec<BodyConfig>,
    /// Seeded faults (none by default).
    #[serde(default)]
    pub faults: Faults,
}

fn default_rate() -> f64 {
    120.0
}

fn default_app_name() -> String {
    "bycoms lab (NatNet emulator)".into()
}

/// One rigid body: a robot with five markers, as in the paper's lab.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodyConfig {
    /// Name in the model definitions (what the orchestrator maps to a robot).
    pub name: String,
    /// Streaming id.
    pub id: i32,
    /// Initial position in Motive's frame (Y up), metres.
    pub position: [f32; 3],
    /// Initial yaw about Motive's up axis (Y), degrees.
    #[serde(default)]
    pub yaw_deg: f32,
}

/// Fault knobs, all driven by one seed so a run repeats exactly.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Faults {
    /// Seed of every random choice below.
    #[serde(default)]
    pub seed: u64,
    /// Probability that a whole frame is not sent (0..1).
    #[serde(default)]
    pub frame_loss: f64,
    /// Standard deviation of the noise added to each marker and to the
    /// body position, metres.
    #[serde(default)]
    pub marker_noise_m: f32,
    /// Windows in which a body is not tracked.
    #[serde(default)]
    pub occlusions: Vec<Occlusion>,
    /// Windows in which two bodies' ids are exchanged (the paper's
    /// 3-robot run mistook robot 1 for robot 3).
    #[serde(default)]
    pub swaps: Vec<Swap>,
}

/// A body not tracked from `from_s` (inclusive) to `to_s` (exclusive),
/// stream time.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Occlusion {
    /// The body's streaming id.
    pub id: i32,
    /// Start, seconds of stream time.
    pub from_s: f64,
    /// End, seconds of stream time.
    pub to_s: f64,
    /// How the loss shows.
    #[serde(default)]
    pub mode: OcclusionMode,
}

/// How an occluded body appears in frames.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum OcclusionMode {
    /// Sent with the tracking-valid bit off and a zero pose (as Motive does).
    #[default]
    Invalid,
    /// Left out of the frame.
    Missing,
}

/// Bodies `a` and `b` stream under each other's id during the window.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Swap {
    /// One body's id.
    pub a: i32,
    /// The other body's id.
    pub b: i32,
    /// Start, seconds of stream time.
    pub from_s: f64,
    /// End, seconds of stream time.
    pub to_s: f64,
}

/// The frame rates a server streams at, Hz: at least one frame a second (a
/// frame period is a span of seconds too: `rate_hz = 1e-300` made one of
/// 1e300 s, a panic), at most 10 000 (shared with `sim-agent lab
/// --natnet-rate`).
pub const RATE_HZ: std::ops::RangeInclusive<f64> = 1.0..=10_000.0;

impl ServerConfig {
    /// Checks what serde cannot: a rate in [`RATE_HZ`], unique ids and names,
    /// probabilities in range.
    pub fn validate(&self) -> Result<(), String> {
        if !RATE_HZ.contains(&self.rate_hz) {
            return Err(format!(
                "rate_hz must be a number of Hz in [{}, {}], got {:?}",
                RATE_HZ.start(),
                RATE_HZ.end(),
                self.rate_hz
            ));
        }
        if !(0.0..=1.0).contains(&self.faults.frame_loss) {
            return Err(format!("faults.frame_loss must be in [0, 1], got {}", self.faults.frame_loss));
        }
        if !(self.faults.marker_noise_m.is_finite() && self.faults.marker_noise_m >= 0.0) {
            return Err("faults.marker_noise_m must be finite and ≥ 0".into());
        }
        for (i, b) in self.bodies.iter().enumerate() {
            if self.bodies[..i].iter().any(|o| o.id == b.id || o.name == b.name) {
                return Err(format!("body {} (id {}) is defined twice", b.name, b.id));
            }
            if b.name.is_empty() || b.name.contains('\0') {
                return Err(format!("body id {} needs a non-empty name without NUL", b.id));
            }
        }
        Ok(())
    }
}
