//! The transport seam's conformance suite: every method of
//! [`LaunchBus`] and what [`transport::open`] hands to the agents seam, for
//! every kind of transport a launch can run over (iceoryx2, zenoh, the
//! in-memory bus), opened the way a launch opens it.
//!
//! The bus contract itself (order, no history, overflow, typed errors) is
//! the protocol crate's suite (`protocol/tests/bus_conformance.rs`), run
//! against each backend; this one checks the seam's face of it: the kind,
//! the sizes every process of the swarm agrees on, ports through the boxed
//! face, dead-node cleanup that never touches a live port, and the links
//! (zenoh's liveliness watch and the orchestrator's token, the memory bus)
//! that only the transport may unpack.
//!
//! [`LaunchBus`]: bycoms_launch::transport::LaunchBus
//! [`transport::open`]: bycoms_launch::transport::open

use bycoms_launch::config::{Transport, TransportConfig};
use bycoms_launch::faults::FaultsConfig;
use bycoms_launch::transport::{self, Opened};
use bycoms_protocol::{Swarm, TopicName};
use bycoms_runtime::ipc_config;
use std::time::Duration;

/// What a kind of transport states about itself.
struct Expected {
    kind: &'static str,
    /// The launch listens somewhere agents on other hosts can reach.
    endpoints: bool,
    /// zenoh: a liveliness watch for the agents seam and the
    /// orchestrator's own token.
    liveliness: bool,
    /// The in-memory bus is handed to the agents seam (agents as threads).
    memory: bool,
}

const ROBOTS: u32 = 5;

fn open(kind: Transport, swarm: &str) -> Opened {
    let cfg = TransportConfig { kind, ..TransportConfig::default() };
    transport::open(&cfg, &FaultsConfig::default(), ROBOTS, swarm).expect("the transport opens")
}

/// Receives one message within 5 s (zenoh delivers on its own threads).
fn recv(sub: &transport::AnySubscriber, buf: &mut [u8]) -> Vec<u8> {
    let n =
        sub.recv_timeout_into(buf, Duration::from_secs(5)).expect("receive").expect("a message within 5 s");
    buf[..n].to_vec()
}

fn run_all(transport: Transport, want: &Expected) {
    let name = swarm_name_of(want.kind);
    let opened = open(transport, &name);
    let bus = &opened.bus;
    // kind and limits: the sizes every process of the swarm opens with.
    assert_eq!(bus.kind(), want.kind, "kind");
    let limits = bus.limits();
    assert_eq!(
        limits.max_payload,
        ipc_config(ROBOTS).limits.max_payload,
        "{}: the swarm's payload size",
        want.kind
    );
    // The links only the transport unpacks.
    assert_eq!(
        !opened.endpoints.is_empty(),
        want.endpoints,
        "{}: endpoints {:?}",
        want.kind,
        opened.endpoints
    );
    assert_eq!(opened.links.alive.is_some(), want.liveliness, "{}: liveliness watch", want.kind);
    assert_eq!(opened.presence.is_some(), want.liveliness, "{}: the orchestrator's token", want.kind);
    assert_eq!(opened.links.memory.is_some(), want.memory, "{}: the memory bus for threads", want.kind);
    // publisher and subscriber through the boxed face: a full-size message
    // arrives whole; one byte more is a typed error, not a cut message.
    let swarm = Swarm::new(&name).expect("swarm");
    let topic: TopicName = *swarm.gate().name();
    let sub = bus.subscriber(&topic).expect("subscriber");
    let publisher = bus.publisher(&topic).expect("publisher");
    let full: Vec<u8> = (0..limits.max_payload).map(|i| i as u8).collect();
    // zenoh: a subscriber declared a moment ago may miss the first message
    // while the declaration propagates; publish until one arrives.
    let mut buf = vec![0u8; limits.max_payload];
    let first = (0..50).find_map(|_| {
        publisher.publish(&full).expect("publish");
        sub.recv_timeout_into(&mut buf, Duration::from_millis(100)).expect("receive")
    });
    assert_eq!(first.map(|n| buf[..n].to_vec()), Some(full.clone()), "{}: a full-size message", want.kind);
    while sub.try_recv_into(&mut buf).expect("drain").is_some() {}
    let too_big = vec![0u8; limits.max_payload + 1];
    assert!(publisher.publish(&too_big).is_err(), "{}: a message over the limit is refused", want.kind);
    // cleanup_dead_nodes removes only what the dead left: live ports go on.
    bus.cleanup_dead_nodes();
    publisher.publish(b"after cleanup").expect("publish after cleanup");
    assert_eq!(recv(&sub, &mut buf), b"after cleanup", "{}: live ports survive the cleanup", want.kind);
}

/// A swarm name of this process and kind (no two runs share one).
fn swarm_name_of(kind: &str) -> String {
    format!("tsuite-{kind}-{}", std::process::id())
}

#[test]
fn ipc_passes_the_suite() {
    run_all(Transport::Ipc, &Expected { kind: "ipc", endpoints: false, liveliness: false, memory: false });
}

#[test]
fn zenoh_passes_the_suite() {
    run_all(Transport::Zenoh, &Expected { kind: "zenoh", endpoints: true, liveliness: true, memory: false });
}

#[test]
fn memory_passes_the_suite() {
    run_all(
        Transport::Memory,
        &Expected { kind: "memory", endpoints: false, liveliness: false, memory: true },
    );
}
