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
mod config;
mod liveliness;
mod ports;
pub mod settings;
mod text;

pub use config::{Congestion, Liveness, Mode, ZenohConfig};
pub use liveliness::{AliveToken, AliveWatch, Presence, PresenceEvent};
pub use ports::{SwarmMessage, SwarmSubscriber, ZenohPublisher, ZenohSubscriber};
pub use text::{check_endpoint, is_secured, shown, zenoh_error, zenoh_words, EndpointError, LINKS};

use super::{Bus, BusError, Limits};
use crate::naming::{Swarm, TopicName};
use ::zenoh::Wait as _;
use core::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

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

    /// A router listening on a free loopback TCP port, and its endpoint
    /// (tests, benches): `config` makes the router's settings for the
    /// endpoint tried. A port that is free when asked may be taken by
    /// another process before zenoh binds it (tests run side by side), so
    /// a few ports are tried; the last error if none could be bound.
    pub fn loopback_router(config: impl Fn(&str) -> ZenohConfig) -> Result<(Self, String), BusError> {
        let mut last = BusError::InvalidConfig("no loopback port tried");
        for _ in 0..5 {
            let port = std::net::TcpListener::bind((core::net::Ipv4Addr::LOCALHOST, 0))
                .and_then(|l| l.local_addr())
                .map_err(|e| BusError::backend("find a free loopback port", None, e))?
                .port();
            let endpoint = format!("tcp/127.0.0.1:{port}");
            match Self::open(config(&endpoint)) {
                Ok(bus) => return Ok((bus, endpoint)),
                Err(e) => last = e,
            }
        }
        Err(last)
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
