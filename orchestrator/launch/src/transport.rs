//! The transport seam: the bus a launch runs over, whatever its backend.
//!
//! Why a trait object over the protocol crate's [`Bus`]: the engine, the
//! gate and the ports must not know whether messages cross iceoryx2 shared
//! memory, a zenoh network or the in-memory hub of a test. [`Bus`] has
//! associated port types (zero-cost for the agents' hot loop) and is
//! therefore not object-safe; [`LaunchBus`] is its object-safe face with
//! boxed ports, implemented for every backend by [`Backend`]. The
//! orchestrator handles a few messages per tick per robot, so one virtual
//! call per message costs nothing measurable, and no generic parameter
//! spreads through every file of the launch.
//!
//! Every implementation must keep the bus contract of
//! `bycoms_protocol::bus` (order per publisher, no history, subscribers
//! before publishers), checked by the protocol crate's conformance suite
//! (`protocol/tests/bus_conformance.rs`) for each backend; the seam's own
//! face ([`LaunchBus`] as [`open`] hands it over: kind, sizes, boxed ports,
//! dead-node cleanup, the links for the agents seam) by
//! `orchestrator/tests/transport_suite.rs` for each kind of transport.

use super::agents::choice::AgentLinks;
use super::config::FaultsConfig;
use super::config::{Transport, TransportConfig};
use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::bus::memory::MemoryBus;
use bycoms_protocol::bus::zenoh::{AliveToken, Mode, ZenohBus};
use bycoms_protocol::bus::{Bus, BusError, Limits, Publish, Subscribe};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{NameError, Swarm, TopicName};
use bycoms_runtime::{ipc_config, zenoh_config};
use std::rc::Rc;

/// A boxed publisher of any backend.
pub type AnyPublisher = Box<dyn Publish>;
/// A boxed subscriber of any backend.
pub type AnySubscriber = Box<dyn Subscribe>;

/// The object-safe face of a [`Bus`]: what a launch needs of its transport.
pub trait LaunchBus {
    /// The backend's name (`ipc`, `zenoh`, `memory`), for logs and the record.
    fn kind(&self) -> &'static str;
    /// Opens a publisher on `topic`.
    fn publisher(&self, topic: &TopicName) -> Result<AnyPublisher, BusError>;
    /// Opens a subscriber on `topic`; it sees messages published from now on.
    fn subscriber(&self, topic: &TopicName) -> Result<AnySubscriber, BusError>;
    /// Opens one receiver of all of `topics` ([`Bus::fan_in`]: each message
    /// tagged with its topic's index).
    fn fan_in(&self, topics: &[TopicName]) -> Result<AnySubscriber, BusError>;
    /// The sizes the bus was opened with.
    fn limits(&self) -> Limits;
    /// Removes what killed agents left behind (iceoryx2's dead nodes in
    /// shared memory); nothing on backends that leave nothing behind.
    fn cleanup_dead_nodes(&self) {}
}

/// A shared handle on the launch's bus (the ports and a bus pose source
/// open their ports on the same one).
pub type SharedBus = Rc<dyn LaunchBus>;

/// What a backend adds to [`Bus`] for a launch: its name and its cleanup.
pub trait Backend: Bus {
    /// See [`LaunchBus::kind`].
    const KIND: &'static str;
    /// See [`LaunchBus::cleanup_dead_nodes`].
    fn cleanup(&self) {}
}

impl Backend for IpcBus {
    const KIND: &'static str = "ipc";
    fn cleanup(&self) {
        let report = self.cleanup_dead_nodes();
        if report.failed > 0 {
            tracing::debug!(failed = report.failed, "some dead iceoryx2 nodes could not be cleaned");
        }
    }
}

impl Backend for ZenohBus {
    const KIND: &'static str = "zenoh";
}

impl Backend for MemoryBus {
    const KIND: &'static str = "memory";
}

impl<B> LaunchBus for B
where
    B: Backend,
    B::Publisher: 'static,
    B::Subscriber: 'static,
    B::FanIn: 'static,
{
    fn kind(&self) -> &'static str {
        B::KIND
    }
    fn publisher(&self, topic: &TopicName) -> Result<AnyPublisher, BusError> {
        Ok(Box::new(Bus::publisher(self, topic)?))
    }
    fn subscriber(&self, topic: &TopicName) -> Result<AnySubscriber, BusError> {
        Ok(Box::new(Bus::subscriber(self, topic)?))
    }
    fn fan_in(&self, topics: &[TopicName]) -> Result<AnySubscriber, BusError> {
        Ok(Box::new(Bus::fan_in(self, topics)?))
    }
    fn limits(&self) -> Limits {
        Bus::limits(self)
    }
    fn cleanup_dead_nodes(&self) {
        self.cleanup();
    }
}

/// Why the launch's bus could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    /// The backend refused to open.
    #[error("cannot open the {kind} bus: {source}")]
    Open {
        /// `ipc` or `zenoh`.
        kind: &'static str,
        /// The backend's error.
        source: BusError,
    },
    /// The fault layer refused its configuration (`[faults]`).
    #[error("fault injection: {0:#}")]
    Faults(anyhow::Error),
    /// A listen endpoint is not `PROTO/HOST:PORT`.
    #[error("bad listen endpoint {0:?}: expected tcp/HOST:PORT, quic/HOST:PORT or tls/HOST:PORT")]
    Endpoint(String),
    /// The swarm name is not a valid topic chunk.
    #[error("bad swarm name: {0}")]
    Swarm(#[from] NameError),
    /// No free port could be found for a `:0` endpoint.
    #[error("cannot find a free port for {endpoint}: {source}")]
    FreePort {
        /// The endpoint asked for.
        endpoint: String,
        /// What the OS said.
        source: std::io::Error,
    },
}

/// The launch's bus, open, and how agents reach it.
pub struct Opened {
    /// The bus.
    pub bus: SharedBus,
    /// zenoh: the endpoints the orchestrator listens on (ports resolved),
    /// and what spawned agents are told to `--connect` to. Empty over ipc.
    pub endpoints: Vec<String>,
    /// What the agent source needs of the transport (zenoh's liveliness
    /// watch on the swarm, the in-memory bus): handed to
    /// `AgentsConfig::open`, so no kind of transport is unpacked elsewhere.
    pub links: AgentLinks,
    /// zenoh: the orchestrator's own liveliness token (agents see the
    /// orchestrator go when it is dropped or the link is cut): keep it for
    /// the whole launch.
    pub presence: Option<AliveToken>,
    /// zenoh: the session (a clone sharing it), for what is no bus message:
    /// the run's settings served to agents started elsewhere.
    pub zenoh: Option<ZenohBus>,
}

/// Opens the bus of a launch of `robots` robots in swarm `swarm`, in the
/// seeded fault layer when `faults` asks for it.
///
/// Over iceoryx2 it first removes what dead processes left in shared memory.
/// In memory the bus is this process's own (its agents are threads).
/// Over zenoh the session is a router listening on `listen`; a port 0 is
/// replaced by a free port the OS hands out just before the session opens
/// (zenoh's stable API does not report the port a listener bound), and the
/// open is retried with fresh ports should another process take it first.
pub fn open(
    cfg: &TransportConfig,
    faults: &FaultsConfig,
    robots: u32,
    swarm: &str,
) -> Result<Opened, TransportError> {
    match cfg.kind {
        Transport::Ipc => {
            let mut ipc = ipc_config(robots);
            ipc.cleans_dead_nodes = true;
            ipc.node_name = Some(format!("bycoms-{swarm}-orchestrator"));
            let bus = IpcBus::new(ipc).map_err(|source| TransportError::Open { kind: "ipc", source })?;
            let bus = faults.wrap(bus).map_err(TransportError::Faults)?;
            Ok(Opened {
                bus,
                endpoints: Vec::new(),
                links: AgentLinks::default(),
                presence: None,
                zenoh: None,
            })
        }
        Transport::Memory => {
            let limits = ipc_config(robots).limits;
            let bus =
                MemoryBus::new(limits).map_err(|source| TransportError::Open { kind: "memory", source })?;
            let links = AgentLinks { alive: None, memory: Some(bus.clone()) };
            let bus = faults.wrap(bus).map_err(TransportError::Faults)?;
            Ok(Opened { bus, endpoints: Vec::new(), links, presence: None, zenoh: None })
        }
        Transport::Zenoh => {
            let mut last = None;
            for _ in 0..3 {
                let listen = cfg.listen.iter().map(|e| with_free_port(e)).collect::<Result<Vec<_>, _>>()?;
                let config =
                    zenoh_config(Mode::Router, listen.clone(), cfg.connect.clone(), cfg.zenoh_config.clone());
                match ZenohBus::open(config) {
                    Ok(bus) => {
                        let endpoints: Vec<String> = listen.iter().map(|e| reachable(e)).collect();
                        tracing::info!(endpoints = ?endpoints, "zenoh: the orchestrator listens (router)");
                        // The orchestrator's token, and a watch on every
                        // token of the swarm for the agent source.
                        let swarm = Swarm::new(swarm)?;
                        let open = |source| TransportError::Open { kind: "zenoh", source };
                        let presence = Some(bus.declare_alive(&swarm, Member::Orchestrator).map_err(open)?);
                        let links =
                            AgentLinks { alive: Some(bus.watch_alive(&swarm).map_err(open)?), memory: None };
                        let zenoh = Some(bus.clone());
                        return Ok(Opened {
                            bus: faults.wrap(bus).map_err(TransportError::Faults)?,
                            endpoints,
                            links,
                            presence,
                            zenoh,
                        });
                    }
                    Err(source) => {
                        let retry = cfg.listen.iter().any(|e| port_of(e) == Some("0"));
                        last = Some(source);
                        if !retry {
                            break;
                        }
                    }
                }
            }
            let source = last.unwrap_or(BusError::InvalidConfig("no attempt to open zenoh"));
            Err(TransportError::Open { kind: "zenoh", source })
        }
    }
}

/// How long a launch waits, once its zenoh session is open, for one of its
/// `--connect` endpoints (`transport.connect`) to answer: zenoh connects to
/// them in the background, so without this wait an endpoint nothing
/// answers at would go unsaid. On loopback or a lab's network a zenoh
/// router answers within milliseconds.
pub const CONNECT_WINDOW: std::time::Duration = std::time::Duration::from_secs(2);

/// Checks that the session `zenoh` reached a router or peer at one of its
/// `connect` endpoints within [`CONNECT_WINDOW`]. When none did, an error
/// naming them if the launch `needs` them (the why, in words: `--ros2`'s
/// graph, remote agents), else a warning.
pub fn check_connected(zenoh: &ZenohBus, connect: &[String], needs: Option<&str>) -> anyhow::Result<()> {
    if connect.is_empty() || reached_any(zenoh, CONNECT_WINDOW) {
        return Ok(());
    }
    let shown: Vec<String> = connect.iter().map(|e| bycoms_protocol::bus::zenoh::shown(e)).collect();
    let said = format!(
        "zenoh: nothing answered at {} (transport.connect, --connect) within {} s: no zenoh router or \
         peer there (is it running, is the endpoint right?)",
        shown.join(", "),
        CONNECT_WINDOW.as_secs_f64()
    );
    match needs {
        Some(why) => anyhow::bail!("{said}; {why} needs it"),
        None => {
            tracing::warn!("{said}; the launch runs on without it");
            Ok(())
        }
    }
}

/// Whether `zenoh` is connected to a router or a peer, waiting up to `window`.
fn reached_any(zenoh: &ZenohBus, window: std::time::Duration) -> bool {
    use zenoh::Wait as _;
    let deadline = std::time::Instant::now() + window;
    loop {
        let info = zenoh.session().info();
        if info.routers_zid().wait().next().is_some() || info.peers_zid().wait().next().is_some() {
            return true;
        }
        if std::time::Instant::now() >= deadline {
            return false;
        }
        // Polled: zenoh 1.x's stable API tells who is connected, not when
        // that changes; at most CONNECT_WINDOW of a launch's start-up.
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// The address part and the rest of an endpoint: `tcp/1.2.3.4:0?x` →
/// (`tcp/`, `1.2.3.4:0`, `?x`).
fn split(endpoint: &str) -> Option<(&str, &str, &str)> {
    let slash = endpoint.find('/')? + 1;
    let (proto, rest) = endpoint.split_at(slash);
    let end = rest.find(['?', '#']).unwrap_or(rest.len());
    let (addr, tail) = rest.split_at(end);
    Some((proto, addr, tail))
}

fn port_of(endpoint: &str) -> Option<&str> {
    split(endpoint).and_then(|(_, addr, _)| addr.rsplit_once(':')).map(|(_, port)| port)
}

/// `endpoint` with a port 0 replaced by a free port of its host: a UDP
/// port for `quic/` (QUIC runs over UDP), a TCP port otherwise.
pub(crate) fn with_free_port(endpoint: &str) -> Result<String, TransportError> {
    let (proto, addr, tail) = split(endpoint).ok_or_else(|| TransportError::Endpoint(endpoint.into()))?;
    let (host, port) = addr.rsplit_once(':').ok_or_else(|| TransportError::Endpoint(endpoint.into()))?;
    if port != "0" {
        return Ok(endpoint.into());
    }
    let free = |source| TransportError::FreePort { endpoint: endpoint.into(), source };
    let bind_host = host.trim_start_matches('[').trim_end_matches(']');
    let port = if proto == "quic/" {
        std::net::UdpSocket::bind((bind_host, 0)).and_then(|s| s.local_addr()).map_err(free)?.port()
    } else {
        std::net::TcpListener::bind((bind_host, 0)).and_then(|l| l.local_addr()).map_err(free)?.port()
    };
    Ok(format!("{proto}{host}:{port}{tail}"))
}

/// What a process on this host connects to for a listen endpoint (an
/// unspecified address becomes loopback).
fn reachable(endpoint: &str) -> String {
    endpoint.replacen("/0.0.0.0:", "/127.0.0.1:", 1).replacen("/[::]:", "/[::1]:", 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn port_zero_becomes_a_free_port_and_others_stay() {
        let e = with_free_port("tcp/127.0.0.1:0").expect("free port");
        let port: u16 = port_of(&e).expect("port").parse().expect("number");
        assert!(port > 0 && e.starts_with("tcp/127.0.0.1:"), "{e}");
        assert_eq!(with_free_port("tls/lab:7447").expect("unchanged"), "tls/lab:7447");
        let q = with_free_port("quic/127.0.0.1:0").expect("free UDP port");
        let port: u16 = q.rsplit_once(':').and_then(|(_, p)| p.parse().ok()).expect("a port");
        assert!(port > 0 && q.starts_with("quic/127.0.0.1:"), "{q}");
        assert!(with_free_port("tcp/127.0.0.1:0?x=1").expect("tail kept").ends_with("?x=1"));
        assert!(matches!(with_free_port("nonsense"), Err(TransportError::Endpoint(_))));
        assert_eq!(reachable("tcp/0.0.0.0:7447"), "tcp/127.0.0.1:7447");
    }
}
