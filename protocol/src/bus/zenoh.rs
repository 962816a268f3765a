//! zenoh backend: the bus across machines (tcp, quic or tls links).
//!
//! Why zenoh: a lab runs the orchestrator, robot gateways and monitors on
//! different hosts, over WiFi or a cluster network that blocks multicast.
//! zenoh routes publish-subscribe over explicit endpoints (`tcp/HOST:PORT`,
//! `quic/HOST:PORT`, `tls/HOST:PORT`), its key expressions give a watcher the whole swarm with
//! one subscription (`bycoms/<swarm>/**`, see [`Swarm::everything`]), and a
//! session in router mode is the rendezvous, so no separate `zenohd` has to
//! run.
//!
//! How the session is configured ([`ZenohConfig`]): multicast scouting is
//! off (explicit endpoints only) and the peer scouting delay is 0, so
//! opening a session costs a TCP (and TLS) handshake, not zenoh's default
//! 500 ms of scouting; `benches/bus_hop.rs` measures open + first message.
//! A `base_config` file (e.g. `deploy/zenoh/*.json5`, for TLS and access
//! control) is read first and the fields of [`ZenohConfig`] override it.
//!
//! Why the sync API and our own inbox: the bus traits are synchronous (the
//! orchestrator's and agents' loops are plain threads with deadlines).
//! zenoh runs its own tokio runtime inside the session; its builders
//! resolve synchronously with [`Wait`], which blocks only the calling
//! thread, so no runtime is needed here and none leaks into the callers. A
//! subscriber's samples arrive on zenoh's network task through a callback
//! that only copies the payload into the subscriber's [`Inbox`] (a short
//! mutex section, never a wait), so a slow subscriber never stalls zenoh's
//! task. zenoh's own FIFO channel would block that task when full and its
//! ring channel counts all publishers together; the inbox keeps the bus
//! contract instead: [`Limits::buffer`] unread messages *per publisher*,
//! the oldest overwritten. To tell publishers apart every message carries
//! the publisher's id as an 8-byte attachment (little-endian `u64`;
//! PROTOCOL.md); messages without one (foreign clients) share one queue.
//!
//! Mapping of the rest of the contract: reliable links, and zenoh keeps one
//! publisher's order; congestion control `Drop` by default (a publisher
//! never blocks on a slow link — [`Congestion::Block`] trades that for no
//! drops under congestion); no history (no storage, no late-joiner cache);
//! a subscriber matches publishers declared before or after it.
//! Deliveries inside one session are local (zenoh calls the subscriber's
//! callback from within `put`).
//!
//! [`Inbox`]: super::inbox::Inbox
//! [`Wait`]: ::zenoh::Wait

pub mod certs;
pub mod clock;
mod liveliness;
mod ports;
pub mod settings;
mod text;

pub use liveliness::{AliveToken, AliveWatch, Presence, PresenceEvent};
pub use ports::{SwarmMessage, SwarmSubscriber, ZenohPublisher, ZenohSubscriber};
pub use text::{check_endpoint, zenoh_error, zenoh_words, EndpointError, LINKS};

use super::{Bus, BusError, Limits};
use crate::naming::{Swarm, TopicName};
use ::zenoh::Wait as _;
use core::sync::atomic::{AtomicU64, Ordering};
use std::path::PathBuf;
use std::sync::Arc;

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
    fn as_str(self) -> &'static str {
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
            Some(path) => ::zenoh::Config::from_file(path)
                .map_err(|e| text::backend("read zenoh config", None, Some(&path.display()), &e))?,
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

/// The zenoh runtime our processes use unless `ZENOH_RUNTIME` says
/// otherwise: one receive worker instead of zenoh's two.
pub const RUNTIME: &str = "(rx: (worker_threads: 1))";

/// Sets `ZENOH_RUNTIME` to [`RUNTIME`] unless the user set it; call first
/// thing in `main`, before any thread starts (zenoh reads it once, when its
/// first runtime starts).
///
/// Why: with two receive workers tokio hands a woken link from one worker
/// thread to the other, and each message pays that thread hop; on a small
/// host (a lab laptop, a robot's single-board computer) one hop is the
/// largest part of the latency: one hop on loopback went from ~80 to
/// ~55 µs p50 on a 2-core machine (`benches/zenoh_hop.rs`). The swarm's
/// traffic (a few hundred small messages per second) never needs a second
/// worker.
pub fn tune_runtime() {
    if std::env::var_os("ZENOH_RUNTIME").is_none() {
        std::env::set_var("ZENOH_RUNTIME", RUNTIME);
    }
}

/// A JSON list of strings (endpoints never contain quotes or backslashes
/// that need more than Rust's `Debug` escaping, which JSON5 accepts).
fn json_strings(items: &[String]) -> String {
    let quoted: Vec<String> = items.iter().map(|s| format!("{s:?}")).collect();
    format!("[{}]", quoted.join(","))
}

/// The zenoh bus: one session; cheap to clone (clones share the session).
/// `Send + Sync`, and so are its ports.
#[derive(Clone)]
pub struct ZenohBus {
    session: ::zenoh::Session,
    config: Arc<ZenohConfig>,
    /// Source of publisher ids, mixed with the session's id.
    next_publisher: Arc<AtomicU64>,
    session_tag: u64,
}

impl ZenohBus {
    /// Opens a session with `config`.
    pub fn open(config: ZenohConfig) -> Result<Self, BusError> {
        let l = config.limits;
        if l.max_payload == 0 || l.buffer == 0 {
            return Err(BusError::InvalidConfig("max_payload and buffer must be at least 1"));
        }
        let zenoh_config = config.to_zenoh()?;
        config.check_certificates(&zenoh_config)?;
        let session = ::zenoh::open(zenoh_config)
            .wait()
            .map_err(|e| text::backend("open zenoh session", None, None, &e))?;
        let session_tag = hash_of(&session.zid().to_string());
        tracing::debug!(zid = %session.zid(), mode = config.mode.as_str(), "zenoh session open");
        Ok(Self { session, config: Arc::new(config), next_publisher: Arc::default(), session_tag })
    }

    /// The zenoh session (for liveliness, raw access, the benchmark).
    pub fn session(&self) -> &::zenoh::Session {
        &self.session
    }

    /// The configuration the bus was opened with.
    pub fn config(&self) -> &ZenohConfig {
        &self.config
    }

    /// A subscriber on `bycoms/<swarm>/**`: every message of the swarm,
    /// with the topic it was published on.
    pub fn swarm_subscriber(&self, swarm: &Swarm) -> Result<SwarmSubscriber, BusError> {
        ports::open_swarm_subscriber(&self.session, &self.config, swarm)
    }

    fn publisher_id(&self) -> u64 {
        let n = self.next_publisher.fetch_add(1, Ordering::Relaxed);
        hash_of(&(self.session_tag, n))
    }
}

/// A deterministic 64-bit hash (std's SipHash with fixed keys).
fn hash_of<T: core::hash::Hash>(value: &T) -> u64 {
    use core::hash::{BuildHasher, BuildHasherDefault};
    BuildHasherDefault::<std::collections::hash_map::DefaultHasher>::default().hash_one(value)
}

impl Bus for ZenohBus {
    type Publisher = ZenohPublisher;
    type Subscriber = ZenohSubscriber;
    type FanIn = ZenohSubscriber;

    fn publisher(&self, topic: &TopicName) -> Result<ZenohPublisher, BusError> {
        ports::open_publisher(&self.session, &self.config, topic, self.publisher_id())
    }

    fn subscriber(&self, topic: &TopicName) -> Result<ZenohSubscriber, BusError> {
        ports::open_subscriber(&self.session, &self.config, topic)
    }

    fn fan_in(&self, topics: &[TopicName]) -> Result<ZenohSubscriber, BusError> {
        ports::open_fan_in(&self.session, &self.config, topics)
    }

    fn limits(&self) -> Limits {
        self.config.limits
    }
}
