//! The zenoh bus's settings: the session's mode, endpoints, congestion,
//! liveness and certificates, and the zenoh configuration they make.
//!
//! Why a file of their own: the bus (`zenoh.rs`) and its ports
//! (`ports.rs`) both read them, and the ports must not use the file that
//! uses them (no file cycles).

use super::{certs, text};
use crate::bus::{BusError, Limits};
use std::path::{Path, PathBuf};

/// Largest zenoh config file read, bytes: an ACL naming a thousand robots
/// is far smaller. Read through the one capped reader, so a config that is
/// `/dev/zero` is refused one byte past it.
const MAX_CONFIG_FILE_LEN: u64 = 4 << 20;

/// The role of the session in the zenoh network.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// Routes for others: the orchestrator's session, the rendezvous.
    Router,
    /// Talks to routers and other peers directly.
    #[default]
    Peer,
    /// Talks only through one router (fails at open if it cannot reach it).
    Client,
}

impl Mode {
    pub(super) fn as_str(self) -> &'static str {
        match self {
            Self::Router => "router",
            Self::Peer => "peer",
            Self::Client => "client",
        }
    }
}

/// What a publisher does when the link cannot take more messages.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Congestion {
    /// Drop the message: the publisher never blocks (the bus contract).
    #[default]
    Drop,
    /// Wait for room: nothing is dropped, the publisher may block.
    Block,
}

/// How fast a silent link is declared dead and a lost connection retried.
///
/// zenoh closes a link when nothing arrived for the *peer's* lease, and
/// each side sends `keep_alive` keep-alives per lease of its own, so both
/// ends of a link need the same setting. A killed process is seen at once
/// (its socket closes); a cut link after ¾..1 lease.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Liveness {
    /// The lease announced to peers (`transport/link/tx/lease`).
    pub lease: core::time::Duration,
    /// Keep-alives per lease (`transport/link/tx/keep_alive`).
    pub keep_alive: u32,
    /// First wait before reconnecting a configured endpoint
    /// (`connect/retry/period_init_ms`).
    pub retry_first: core::time::Duration,
    /// Longest wait between reconnection attempts
    /// (`connect/retry/period_max_ms`).
    pub retry_max: core::time::Duration,
}

impl Liveness {
    /// A cut link is noticed within 400 ms (one keep-alive every 100 ms)
    /// and a restored one reconnected within 500 ms: the swarm's setting.
    pub const FAST: Self = Self {
        lease: core::time::Duration::from_millis(400),
        keep_alive: 4,
        retry_first: core::time::Duration::from_millis(50),
        retry_max: core::time::Duration::from_millis(500),
    };
}

/// How a [`ZenohBus`] opens its session.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ZenohConfig {
    /// Payload and buffer sizes (every process on a topic should agree).
    pub limits: Limits,
    /// Router, peer or client.
    pub mode: Mode,
    /// Endpoints to listen on, e.g. `tcp/0.0.0.0:7447`.
    pub listen: Vec<String>,
    /// Endpoints to connect to, e.g. `tcp/10.0.0.5:7447`.
    pub connect: Vec<String>,
    /// Publishers' congestion control.
    pub congestion: Congestion,
    /// Send each message at once instead of batching (lower latency).
    pub express: bool,
    /// A zenoh JSON5 config file read first (TLS, access control, ...).
    pub base_config: Option<PathBuf>,
    /// Lease and reconnection timing; `None` keeps zenoh's (10 s lease,
    /// reconnect after 1..4 s) or the base file's.
    pub liveness: Option<Liveness>,
    /// Offer zenoh's low-latency transport (`transport/unicast/lowlatency`,
    /// QoS off): no transmission queue and batching task between `put`
    /// and the socket. Negotiated per link: used when both ends offer it,
    /// the standard transport otherwise (e.g. a default Python client).
    /// On by default: the swarm's messages are small and few, so batching
    /// buys nothing and costs latency (`benches/zenoh_hop.rs`).
    pub low_latency: bool,
    /// The common name this process's own certificate must carry (a
    /// swarm member's, [`certs::common_name`]); `None`: any. Checked with
    /// the rest of the certificates the config names before the session
    /// opens ([`certs::check`]).
    pub identity: Option<String>,
}

impl Default for ZenohConfig {
    fn default() -> Self {
        Self {
            limits: Limits::default(),
            mode: Mode::default(),
            listen: Vec::new(),
            connect: Vec::new(),
            congestion: Congestion::default(),
            express: true,
            base_config: None,
            liveness: None,
            low_latency: true,
            identity: None,
        }
    }
}

impl ZenohConfig {
    /// Checks the certificates `zenoh` (this configuration's, from
    /// [`Self::to_zenoh`]) names, as [`ZenohBus::open`] does first: a
    /// caller that retries opening checks once, since a bad certificate
    /// stays bad ([`certs`]).
    pub fn check_certificates(&self, zenoh: &::zenoh::Config) -> Result<(), BusError> {
        certs::check(zenoh, self.identity.as_deref(), std::time::SystemTime::now())
            .map_err(|e| BusError::Backend { op: "open zenoh session", topic: None, detail: e.to_string() })
    }

    /// The zenoh configuration this describes.
    pub fn to_zenoh(&self) -> Result<::zenoh::Config, BusError> {
        let mut config = match &self.base_config {
            Some(path) => read_config(path)?,
            None => ::zenoh::Config::default(),
        };
        let mut set = |key: &'static str, value: String| {
            config.insert_json5(key, &value).map_err(|e| {
                text::backend("configure zenoh", None, Some(&format_args!("{key} = {value}")), &e)
            })
        };
        set("mode", format!("{:?}", self.mode.as_str()))?;
        // Without a base file, an empty list means "none" (zenoh's default
        // would make a router listen on port 7447 of every interface). A
        // client listens only where it is told: the orchestrator's own file,
        // read by `orchestrator status --connect` on its host, must not make
        // the asker listen on the launch's port.
        let own = self.base_config.is_none();
        if own || !self.listen.is_empty() || self.mode == Mode::Client {
            set("listen/endpoints", json_strings(&self.listen))?;
        }
        if own || !self.connect.is_empty() {
            set("connect/endpoints", json_strings(&self.connect))?;
        }
        set("scouting/multicast/enabled", "false".into())?;
        set("scouting/delay", "0".into())?;
        if let Some(l) = self.liveness {
            set("transport/link/tx/lease", l.lease.as_millis().to_string())?;
            set("transport/link/tx/keep_alive", l.keep_alive.to_string())?;
            let (first, max) = (l.retry_first.as_millis(), l.retry_max.as_millis());
            let retry = format!("{{period_init_ms:{first},period_max_ms:{max},period_increase_factor:2}}");
            set("connect/retry", retry)?;
        }
        if self.low_latency {
            set("transport/unicast/lowlatency", "true".into())?;
            set("transport/unicast/qos/enabled", "false".into())?;
        }
        Ok(config)
    }
}

/// The zenoh config file `path` (JSON5), read capped: zenoh's own
/// `Config::from_file` reads without a cap. Its errors name the file and
/// say what is wrong with it, never a network cause.
fn read_config(path: &Path) -> Result<::zenoh::Config, BusError> {
    let bad = |detail: String| BusError::Backend {
        op: "read zenoh config",
        topic: None,
        detail: format!("{}: {detail}", path.display()),
    };
    let text = crate::capped::read_capped_file(path, MAX_CONFIG_FILE_LEN).map_err(|e| bad(e.to_string()))?;
    ::zenoh::Config::from_json5(&text).map_err(|e| bad(format!("not a zenoh JSON5 config ({e})")))
}

/// A JSON list of strings (endpoints never contain quotes or backslashes
/// that need more than Rust's `Debug` escaping, which JSON5 accepts).
fn json_strings(items: &[String]) -> String {
    let quoted: Vec<String> = items.iter().map(|s| format!("{s:?}")).collect();
    format!("[{}]", quoted.join(","))
}
