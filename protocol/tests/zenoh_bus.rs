//! What the zenoh backend adds to the conformance suite: delivery between
//! two sessions over tcp (as between two hosts), the swarm-wide
//! subscriber, per-publisher buffers and typed errors for bad endpoints.
//!
//! Every session listens on a loopback port the kernel handed out (retried
//! if taken meanwhile); every wait has a timeout.
#![cfg(feature = "zenoh")]

use bycoms_protocol::bus::zenoh::{Congestion, Mode, ZenohBus, ZenohConfig};

/// These tests check order and completeness across a tcp link: under CPU
/// load a burst may fill zenoh's queue, where `Drop` (the default) loses
/// messages by design.
const BLOCK: Congestion = Congestion::Block;
use bycoms_protocol::bus::{Bus, BusError, Limits, Publish, Subscribe};
use bycoms_protocol::naming::Route;
use bycoms_protocol::{RobotId, Swarm, TopicName};
use core::time::Duration;
use std::net::TcpListener;
use std::time::Instant;

const WAIT: Duration = Duration::from_secs(5);

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).expect("a free port").port()
}

/// A router listening on a free loopback port, and its endpoint.
fn router() -> (ZenohBus, String) {
    let config = |endpoint: &str| ZenohConfig {
        mode: Mode::Router,
        listen: vec![endpoint.to_owned()],
        congestion: BLOCK,
        ..ZenohConfig::default()
    };
    ZenohBus::loopback_router(config).expect("a router on a free loopback port")
}

fn peer_of(endpoint: &str) -> ZenohBus {
    ZenohBus::open(ZenohConfig {
        mode: Mode::Peer,
        congestion: BLOCK,
        connect: vec![endpoint.to_owned()],
        ..ZenohConfig::default()
    })
    .expect("peer session")
}

fn swarm(tag: &str) -> Swarm {
    Swarm::new(&format!("z{}-{tag}", std::process::id())).expect("valid swarm")
}

/// Publishes `probe` until `sub` receives it: the subscription has then
/// reached the publisher's session (declarations travel asynchronously).
fn await_route<P: Publish, S: Subscribe>(publ: &P, sub: &S, probe: &[u8]) {
    let deadline = Instant::now() + WAIT;
    while Instant::now() < deadline {
        publ.publish(probe).expect("publish probe");
        if sub.recv_timeout(Duration::from_millis(20)).expect("receive").is_some() {
            return;
        }
    }
    panic!("no route from publisher to subscriber within {WAIT:?}");
}

/// Skips leftover probes; the first other message is returned.
fn recv_skipping<S: Subscribe>(sub: &S, probe: &[u8]) -> Vec<u8> {
    loop {
        match sub.recv_timeout(WAIT).expect("receive") {
            Some(m) if m == probe => continue,
            Some(m) => return m,
            None => panic!("expected a message within {WAIT:?}"),
        }
    }
}

#[test]
fn messages_cross_sessions_in_order_both_ways() {
    let (router, endpoint) = router();
    let peer = peer_of(&endpoint);
    let topic = TopicName::parse(&format!("bycoms/{}/raw", swarm("cross").as_str())).expect("topic");
    for (from, to) in [(&peer, &router), (&router, &peer)] {
        let sub = to.subscriber(&topic).expect("subscriber");
        let publ = from.publisher(&topic).expect("publisher");
        await_route(&publ, &sub, b"probe");
        for i in 0..50u8 {
            publ.publish(&[i]).expect("publish");
        }
        for i in 0..50u8 {
            assert_eq!(recv_skipping(&sub, b"probe"), vec![i]);
        }
        assert_eq!(sub.recv_timeout(Duration::from_millis(30)).expect("receive"), None);
    }
}

/// Our sessions offer zenoh's low-latency transport; a session that does
/// not (a default outside client, e.g. Python's) still joins: the link falls
/// back to the standard transport, and messages cross both ways.
#[test]
fn a_session_without_the_low_latency_transport_still_joins() {
    assert!(ZenohConfig::default().low_latency, "offered by default");
    let config = ZenohConfig::default().to_zenoh().expect("config");
    assert_eq!(config.get_json("transport/unicast/lowlatency").expect("key"), "true");
    let (router, endpoint) = router();
    let standard = ZenohBus::open(ZenohConfig {
        mode: Mode::Peer,
        congestion: BLOCK,
        connect: vec![endpoint],
        low_latency: false,
        ..ZenohConfig::default()
    })
    .expect("a standard-transport peer joins");
    let topic = TopicName::parse(&format!("bycoms/{}/raw", swarm("mixed").as_str())).expect("topic");
    for (from, to) in [(&standard, &router), (&router, &standard)] {
        let sub = to.subscriber(&topic).expect("subscriber");
        let publ = from.publisher(&topic).expect("publisher");
        await_route(&publ, &sub, b"probe");
        publ.publish(b"hello").expect("publish");
        assert_eq!(recv_skipping(&sub, b"probe"), b"hello");
    }
}

#[test]
fn swarm_subscriber_sees_every_topic_of_its_swarm_only() {
    let (router, endpoint) = router();
    let peer = peer_of(&endpoint);
    let ours = swarm("whole");
    let theirs = swarm("other");
    let watch = router.swarm_subscriber(&ours).expect("swarm subscriber");
    let gate = peer.publisher(ours.gate().name()).expect("publisher");
    // Wait until the watcher's subscription reached the peer.
    let deadline = Instant::now() + WAIT;
    loop {
        gate.publish(b"probe").expect("publish");
        if watch.recv_timeout(Duration::from_millis(20)).expect("receive").is_some() {
            break;
        }
        assert!(Instant::now() < deadline, "watcher never reached");
    }
    let r = RobotId(7);
    let sends: [(TopicName, Route); 4] = [
        (*ours.pose(r).name(), Route::Pose(r)),
        (*ours.to_agent(r).name(), Route::ToAgent(r)),
        (*ours.from_agent(RobotId(5)).name(), Route::FromAgent(RobotId(5))),
        (*ours.gate().name(), Route::Gate),
    ];
    peer.publisher(theirs.gate().name()).expect("publisher").publish(b"not ours").expect("publish");
    for (i, (topic, _)) in sends.iter().enumerate() {
        let publ =
            if *topic == *ours.gate().name() { None } else { Some(peer.publisher(topic).expect("pub")) };
        match &publ {
            Some(p) => p.publish(&[i as u8]).expect("publish"),
            None => gate.publish(&[i as u8]).expect("publish"),
        }
        // Different publishers may interleave: receive each before the next.
        let got = loop {
            let m = watch.recv_timeout(WAIT).expect("receive").expect("a message within WAIT");
            if m.payload != b"probe" {
                break m;
            }
        };
        assert_eq!(got.key, topic.as_str());
        assert_eq!(got.route, Some(sends[i].1));
        assert_eq!(got.payload, vec![i as u8]);
    }
    assert_eq!(watch.recv_timeout(Duration::from_millis(30)).expect("receive"), None);
}

#[test]
fn buffer_is_per_publisher() {
    let limits = Limits { max_payload: 16, buffer: 3 };
    let bus =
        ZenohBus::open(ZenohConfig { limits, mode: Mode::Router, ..ZenohConfig::default() }).expect("bus");
    let topic = TopicName::parse(&format!("bycoms/{}/raw", swarm("perpub").as_str())).expect("topic");
    let sub = bus.subscriber(&topic).expect("subscriber");
    let a = bus.publisher(&topic).expect("publisher");
    let b = bus.publisher(&topic).expect("publisher");
    for i in 0..5u8 {
        a.publish(&[b'a', i]).expect("publish");
        b.publish(&[b'b', i]).expect("publish");
    }
    let mut got = Vec::new();
    while let Some(m) = sub.try_recv().expect("try_recv") {
        got.push(m);
    }
    let of = |tag: u8| got.iter().filter(|m| m[0] == tag).map(|m| m[1]).collect::<Vec<_>>();
    assert_eq!(of(b'a'), vec![2, 3, 4], "a's oldest overwritten, a's newest kept");
    assert_eq!(of(b'b'), vec![2, 3, 4], "b keeps its own buffer");
}

#[test]
fn unusable_configurations_are_typed_errors() {
    let zero = ZenohConfig { limits: Limits { max_payload: 0, buffer: 1 }, ..ZenohConfig::default() };
    assert!(matches!(ZenohBus::open(zero), Err(BusError::InvalidConfig(_))));
    let bad = ZenohConfig { listen: vec!["nonsense".into()], ..ZenohConfig::default() };
    assert!(matches!(ZenohBus::open(bad), Err(BusError::Backend { .. })));
    let missing =
        ZenohConfig { base_config: Some("/nonexistent/zenoh.json5".into()), ..ZenohConfig::default() };
    match ZenohBus::open(missing) {
        Err(BusError::Backend { detail, .. }) => {
            assert!(detail.contains("/nonexistent/zenoh.json5"), "{detail}");
        }
        other => panic!("expected a backend error, got {:?}", other.err()),
    }
}

#[test]
fn a_client_without_its_router_fails_fast() {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let start = Instant::now();
    let client = ZenohConfig { mode: Mode::Client, connect: vec![endpoint], ..ZenohConfig::default() };
    assert!(matches!(ZenohBus::open(client), Err(BusError::Backend { .. })));
    assert!(start.elapsed() < WAIT, "took {:?}", start.elapsed());
}

/// The documented lab configs in `deploy/zenoh/` parse with zenoh's own
/// (deny-unknown-fields) loader and say what their comments say.
#[test]
fn deploy_configs_parse() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy/zenoh");
    let expected = [
        ("orchestrator-host.json5", "router", true),
        ("robot-bridge-host.json5", "client", false),
        ("zenohd-router.json5", "router", false),
    ];
    let found = std::fs::read_dir(&dir)
        .expect("deploy/zenoh")
        .filter_map(Result::ok)
        .filter(|e| e.path().extension().is_some_and(|x| x == "json5"));
    assert_eq!(found.count(), expected.len(), "a config in deploy/zenoh/ is not covered here");
    for (file, mode, acl) in expected {
        let path = dir.join(file);
        let config = zenoh::Config::from_file(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(config.get_json("mode").expect("mode"), format!("{mode:?}"), "{file}");
        assert_eq!(config.get_json("scouting/multicast/enabled").expect("multicast"), "false", "{file}");
        assert_eq!(config.get_json("transport/link/tls/enable_mtls").expect("mtls"), "true", "{file}");
        assert_eq!(config.get_json("access_control/enabled").expect("acl"), acl.to_string(), "{file}");
        // And our bus accepts it as a base.
        let ours = ZenohConfig { base_config: Some(path.clone()), ..ZenohConfig::default() };
        ours.to_zenoh().unwrap_or_else(|e| panic!("{file}: {e}"));
    }
}
