//! The core's calls, as a launch made them: what `replay` feeds the same
//! core.
//!
//! Why a log of calls and not of messages: the core is deterministic, so
//! its decisions follow from the inputs it was handed *and* from when the
//! shell asked it to decide (`advance`): a shell hands in everything that
//! arrived together (a tick's answers and its poses) before the core acts,
//! and a replay that advanced after every input could decide earlier than
//! the launch did. So the driver records every [`Call`] with its launch
//! time — [`Call::Handle`] and [`Call::Advance`] — and the setup the core
//! was made with; [`replay`] makes a new core from that setup, makes the
//! same calls in the same order, and hands back the gate events it
//! publishes, which `orchestrator replay` compares with the recorded ones.
//! A recording made before this log existed is re-judged from its poses
//! (`replay::judge`), with the launch's own referee.
//!
//! The log is postcard (the bus's own encoding), one recording message per
//! pass of the driver's loop, on `bycoms/<swarm>/core/calls`; the setup is
//! one message on `bycoms/<swarm>/core/setup`.
//!
//! Why a versioned schema ([`Version`]): a recording outlives the core that
//! made it, and postcard is positional, so a type that changes no longer
//! reads the bytes of its older self. Before versions, every addition was
//! appended and every retired rule kept in the core for old logs (timers
//! that could be off, an input no shell made). Now the current version is
//! the core's own types, pinned byte for byte by a golden test
//! (`harness/tests/log.rs`), so a change of them that would change the
//! bytes fails there; it then becomes a new version: the old one's types
//! frozen in a file of their own (as `log/v1.rs`), with an explicit upgrade
//! to the new, and the core keeps no mode for it.

mod call;
pub mod v1;

pub use call::Call;

use super::{Ending, Input, LaunchCore, Output, Setup};
use bycoms_protocol::msg::{GateEvent, Pose};

// Their schema names in a recording are `record::schema::{CORE_SETUP,
// CORE_CALLS}` (postcard of [`Setup`], of `Vec<Call>`), the one list of a
// recording's schema names.

/// A 32-bit fingerprint of a pose's every bit (FNV-1a over its fields):
/// enough to tell the pose the core was handed from any other on the
/// record, in 4 bytes instead of the pose's 30 or so. Written here (ten
/// lines) rather than pulled in as a hashing crate: it must never change,
/// and it hashes six numbers.
pub fn fingerprint(pose: &Pose) -> u32 {
    let words = [
        u64::from(pose.robot.0),
        pose.step,
        pose.time_us,
        pose.x.to_bits(),
        pose.y.to_bits(),
        pose.heading.to_bits(),
    ];
    words
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .fold(0x811c_9dc5, |h, b| (h ^ u32::from(b)).wrapping_mul(0x0100_0193))
}

/// The calls of a log with every recorded pose they name put back
/// ([`Call::HandleRecordedPose`] → [`Call::Handle`] of an
/// [`Input::Pose`]), `pose(robot, n)` being the `n`-th message recorded on
/// robot's pose topic; the first pose the recording does not hold as it
/// was handed (missing, or not the fingerprinted one), if any, as (robot,
/// number): the log is no evidence then, and the calls up to it are
/// returned.
pub fn resolve<'a>(
    calls: impl IntoIterator<Item = &'a Call>,
    mut pose: impl FnMut(u32, u32) -> Option<Pose>,
) -> (Vec<Call>, Option<(u32, u32)>) {
    let mut out = Vec::new();
    for call in calls {
        match call {
            Call::HandleRecordedPose { at, topic, number, fingerprint: f } => {
                match pose(*topic, *number).filter(|p| fingerprint(p) == *f) {
                    Some(pose) => out.push(Call::Handle(*at, Input::Pose { topic: *topic, pose })),
                    None => return (out, Some((*topic, *number))),
                }
            }
            other => out.push(other.clone()),
        }
    }
    (out, None)
}

/// The version of the log's schema a recording holds. Each is named in
/// the recording by its channels' schema names
/// (`record::schema::{CORE_SETUP, CORE_CALLS}` and the older ones beside
/// them), so a reader knows which it reads before it decodes a byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Version {
    /// Recordings made before the schema had versions: the core's types,
    /// postcard, positionally, each later addition appended (`log/v1.rs`).
    V1,
    /// The current schema: [`Setup`] and [`Call`], postcard.
    V2,
}

impl Version {
    /// The version a launch records.
    pub const CURRENT: Version = Version::V2;

    /// The version numbered `n` (none: one this build does not know, as a
    /// recording made by a newer build).
    pub fn of(n: u32) -> Option<Version> {
        match n {
            1 => Some(Version::V1),
            2 => Some(Version::V2),
            _ => None,
        }
    }

    /// Its number.
    pub fn number(self) -> u32 {
        match self {
            Version::V1 => 1,
            Version::V2 => 2,
        }
    }
}

/// Why a recorded log does not decode.
#[derive(Debug, thiserror::Error)]
#[error("the launch core's log (schema version {version:?}) does not decode: {source}")]
pub struct LogError {
    /// The version it was read as.
    pub version: Version,
    /// What postcard said.
    #[source]
    pub source: postcard::Error,
}

/// The setup's bytes in a recording, of the current version.
pub fn encode_setup(setup: &Setup) -> Vec<u8> {
    postcard::to_allocvec(setup).unwrap_or_default()
}

/// A recorded setup of `version`, upgraded to the current one.
pub fn decode_setup(version: Version, bytes: &[u8]) -> Result<Setup, LogError> {
    let setup = match version {
        Version::V1 => v1::decode_setup(bytes).map(v1::upgrade_setup),
        Version::V2 => postcard::from_bytes(bytes),
    };
    setup.map_err(|source| LogError { version, source })
}

/// A batch of calls' bytes in a recording, of the current version.
pub fn encode_calls(calls: &[Call]) -> Vec<u8> {
    postcard::to_allocvec(calls).unwrap_or_default()
}

/// A recorded batch of calls of `version`, upgraded to the current one.
pub fn decode_calls(version: Version, bytes: &[u8]) -> Result<Vec<Call>, LogError> {
    let calls = match version {
        Version::V1 => postcard::from_bytes::<Vec<v1::Call>>(bytes).map(v1::upgrade_calls),
        Version::V2 => postcard::from_bytes(bytes),
    };
    calls.map_err(|source| LogError { version, source })
}

/// A core whose calls are logged: the driver's core.
pub struct Logged {
    core: LaunchCore,
    calls: Vec<Call>,
    on: bool,
}

impl Logged {
    /// A new core for `setup`; calls are kept only when `on` (a recording).
    pub fn new(setup: Setup, on: bool) -> Self {
        Self { core: LaunchCore::new(setup), calls: Vec::new(), on }
    }

    /// [`LaunchCore::handle`], logged.
    pub fn handle(&mut self, now: u64, input: Input) {
        if self.on {
            self.calls.push(Call::Handle(now, input.clone()));
        }
        self.core.handle(now, input);
    }

    /// [`LaunchCore::handle`] of robot `topic`'s pose, logged by reference
    /// when the recording holds it as the `recorded`-th message of the
    /// robot's pose topic ([`Call::HandleRecordedPose`]).
    pub fn handle_pose(&mut self, now: u64, topic: u32, pose: Pose, recorded: Option<u32>) {
        match recorded {
            Some(number) if self.on => {
                let fingerprint = fingerprint(&pose);
                self.calls.push(Call::HandleRecordedPose { at: now, topic, number, fingerprint });
                self.core.handle(now, Input::Pose { topic, pose });
            }
            _ => self.handle(now, Input::Pose { topic, pose }),
        }
    }

    /// [`LaunchCore::advance`], logged.
    pub fn advance(&mut self, now: u64) {
        if self.on {
            self.calls.push(Call::Advance(now));
        }
        self.core.advance(now);
    }

    /// [`LaunchCore::poll`].
    pub fn poll(&mut self) -> Option<Output> {
        self.core.poll()
    }

    /// The calls made since the last time they were taken.
    pub fn take_calls(&mut self) -> Vec<Call> {
        std::mem::take(&mut self.calls)
    }
}

impl std::ops::Deref for Logged {
    type Target = LaunchCore;
    fn deref(&self) -> &LaunchCore {
        &self.core
    }
}

/// What a core made from `setup` does when given `calls`: the gate events
/// it publishes, in order, and how it ends (none: the calls end first, as
/// in a recording cut short).
pub fn replay<'a>(
    setup: Setup,
    calls: impl IntoIterator<Item = &'a Call>,
) -> (Vec<GateEvent>, Option<Ending>) {
    let mut core = LaunchCore::new(setup);
    let mut gates = Vec::new();
    let mut drain = |core: &mut LaunchCore| {
        while let Some(out) = core.poll() {
            if let Output::Gate(event) = out {
                gates.push(event);
            }
        }
    };
    for call in calls {
        match call {
            Call::Handle(now, input) => core.handle(*now, input.clone()),
            Call::Advance(now) => core.advance(*now),
            // Resolved first ([`resolve`]); one that is not names no pose.
            Call::HandleRecordedPose { .. } => continue,
        }
        drain(&mut core);
    }
    (gates, core.ending().cloned())
}
