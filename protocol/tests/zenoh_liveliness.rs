//! Liveliness over the zenoh bus: tokens of agents and the orchestrator
//! seen appearing and disappearing from another session over tcp, the
//! lease settings reaching zenoh, and a peer reconnecting to a restarted
//! router within the fast retry period. (A cut link and a killed process
//! on another "host" are in `tests/tests/netns_liveliness.rs`.)
//!
//! Every session listens on a loopback port the kernel handed out; every
//! wait has a timeout.
#![cfg(feature = "zenoh")]

use ::zenoh::Wait as _;
use bycoms_protocol::bus::zenoh::{
    AliveWatch, Liveness, Mode, Presence, PresenceEvent, ZenohBus, ZenohConfig,
};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{RobotId, Swarm};
use core::time::Duration;
use std::time::Instant;

const WAIT: Duration = Duration::from_secs(5);

fn router_on(endpoint: &str) -> Result<ZenohBus, bycoms_protocol::bus::BusError> {
    ZenohBus::open(ZenohConfig {
        mode: Mode::Router,
        listen: vec![endpoint.to_owned()],
        liveness: Some(Liveness::FAST),
        ..ZenohConfig::default()
    })
}

/// A router listening on a free loopback port, and its endpoint.
fn router() -> (ZenohBus, String) {
    let config = |endpoint: &str| ZenohConfig {
        mode: Mode::Router,
        listen: vec![endpoint.to_owned()],
        liveness: Some(Liveness::FAST),
        ..ZenohConfig::default()
    };
    ZenohBus::loopback_router(config).expect("a router on a free loopback port")
}

fn peer_of(endpoint: &str) -> ZenohBus {
    ZenohBus::open(ZenohConfig {
        mode: Mode::Peer,
        connect: vec![endpoint.to_owned()],
        liveness: Some(Liveness::FAST),
        ..ZenohConfig::default()
    })
    .expect("peer session")
}

fn swarm(tag: &str) -> Swarm {
    Swarm::new(&format!("l{}-{tag}", std::process::id())).expect("valid swarm")
}

/// The first `presence` event of each of `members` (order of arrival),
/// waiting at most [`WAIT`] in all.
fn all_of(watch: &AliveWatch, members: &[Member], presence: Presence) -> Vec<PresenceEvent> {
    let deadline = Instant::now() + WAIT;
    let mut seen: Vec<PresenceEvent> = Vec::new();
    while seen.len() < members.len() {
        let Some(left) = deadline.checked_duration_since(Instant::now()) else { break };
        match watch.recv_timeout(left) {
            Some(e) if e.presence == presence && members.contains(&e.member) => {
                if !seen.iter().any(|s| s.member == e.member) {
                    seen.push(e);
                }
            }
            Some(_) => {}
            None => break,
        }
    }
    seen
}

#[test]
fn tokens_appear_and_disappear_across_sessions() {
    let (router, endpoint) = router();
    let peer = peer_of(&endpoint);
    let s = swarm("tokens");
    let watch = router.watch_alive(&s).expect("watch");
    let agent = Member::Agent(RobotId(3));
    let token = peer.declare_alive(&s, agent).expect("token");
    assert_eq!(token.member(), agent);
    let (alive, other) = watch.wait_for(agent, Presence::Alive, WAIT);
    assert!(alive.is_some(), "agent 3 never seen alive; saw {other:?}");
    // Another swarm's tokens are not this watch's business.
    let _foreign = peer.declare_alive(&swarm("elsewhere"), agent).expect("token");
    drop(token);
    let (lost, other) = watch.wait_for(agent, Presence::Lost, WAIT);
    assert!(lost.is_some(), "agent 3 never seen lost; saw {other:?}");
    assert!(other.is_empty(), "unexpected events {other:?}");
    assert_eq!(watch.recv_timeout(Duration::from_millis(100)), None);
}

/// An agent's watch of the orchestrator alone (its failsafe's): the
/// orchestrator's token comes and goes, the other agents' are not sent to
/// it (each agent watching every token is N² deliveries in a swarm of N).
#[test]
fn a_watch_of_one_member_sees_that_member_alone() {
    let (router, endpoint) = router();
    let peer = peer_of(&endpoint);
    let s = swarm("one");
    let _agent = router.declare_alive(&s, Member::Agent(RobotId(1))).expect("token");
    let watch = peer.watch_alive_of(&s, Member::Orchestrator).expect("watch");
    let _other = router.declare_alive(&s, Member::Agent(RobotId(2))).expect("token");
    let orchestrator = router.declare_alive(&s, Member::Orchestrator).expect("token");
    let (alive, other) = watch.wait_for(Member::Orchestrator, Presence::Alive, WAIT);
    assert!(alive.is_some(), "the orchestrator never seen alive; saw {other:?}");
    drop(orchestrator);
    let (lost, more) = watch.wait_for(Member::Orchestrator, Presence::Lost, WAIT);
    assert!(lost.is_some(), "the orchestrator never seen lost; saw {more:?}");
    assert!(other.is_empty() && more.is_empty(), "agents' tokens seen: {other:?} {more:?}");
    assert_eq!(watch.recv_timeout(Duration::from_millis(100)), None);
}

#[test]
fn a_late_watcher_sees_tokens_declared_before_it() {
    let (router, endpoint) = router();
    let peer = peer_of(&endpoint);
    let s = swarm("history");
    let _orchestrator = router.declare_alive(&s, Member::Orchestrator).expect("token");
    let _agent = router.declare_alive(&s, Member::Agent(RobotId(1))).expect("token");
    // The peer watches from the other end of the link, after both exist.
    let watch = peer.watch_alive(&s).expect("watch");
    let mut seen = Vec::new();
    let deadline = Instant::now() + WAIT;
    while seen.len() < 2 && Instant::now() < deadline {
        if let Some(e) = watch.recv_timeout(Duration::from_millis(50)) {
            assert_eq!(e.presence, Presence::Alive, "{e:?}");
            seen.push(e.member);
        }
    }
    seen.sort();
    assert_eq!(seen, vec![Member::Orchestrator, Member::Agent(RobotId(1))]);
}

#[test]
fn a_closed_session_loses_all_its_tokens() {
    let (router, endpoint) = router();
    let s = swarm("closed");
    let watch = router.watch_alive(&s).expect("watch");
    let peer = peer_of(&endpoint);
    let _a = peer.declare_alive(&s, Member::Agent(RobotId(1))).expect("token");
    let _b = peer.declare_alive(&s, Member::Agent(RobotId(2))).expect("token");
    let agents = [Member::Agent(RobotId(1)), Member::Agent(RobotId(2))];
    let alive = all_of(&watch, &agents, Presence::Alive);
    assert_eq!(alive.len(), 2, "not both alive: {alive:?}");
    let closed = Instant::now();
    peer.session().close().wait().expect("close");
    let lost: Vec<Duration> =
        all_of(&watch, &agents, Presence::Lost).iter().map(|e| e.at.duration_since(closed)).collect();
    assert_eq!(lost.len(), 2, "not both lost: {lost:?}");
    // A generous bound under CI load; `netns-bench` measures the figure.
    assert!(lost.iter().all(|d| *d < Duration::from_secs(2)), "{lost:?}");
}

#[test]
fn fast_liveness_reaches_zenoh_and_none_keeps_its_defaults() {
    let fast =
        ZenohConfig { liveness: Some(Liveness::FAST), ..ZenohConfig::default() }.to_zenoh().expect("config");
    assert_eq!(fast.get_json("transport/link/tx/lease").expect("lease"), "400");
    assert_eq!(fast.get_json("transport/link/tx/keep_alive").expect("keep_alive"), "4");
    let retry = fast.get_json("connect/retry").expect("retry");
    assert!(retry.contains(r#""period_init_ms":50"#) && retry.contains(r#""period_max_ms":500"#), "{retry}");
    let plain = ZenohConfig::default().to_zenoh().expect("config");
    assert_eq!(plain.get_json("transport/link/tx/lease").expect("lease"), "10000");
}

/// A restarted router (same endpoint) gets the peer back within the fast
/// retry period, and with it the peer's token.
#[test]
fn a_peer_reconnects_to_a_restarted_router() {
    let (router, endpoint) = router();
    let s = swarm("restart");
    let peer = peer_of(&endpoint);
    let _token = peer.declare_alive(&s, Member::Agent(RobotId(4))).expect("token");
    let watch = router.watch_alive(&s).expect("watch");
    assert!(watch.wait_for(Member::Agent(RobotId(4)), Presence::Alive, WAIT).0.is_some());
    drop(watch);
    router.session().close().wait().expect("close router");
    drop(router);
    let restarted = Instant::now();
    let again = (0..50)
        .find_map(|_| {
            router_on(&endpoint).ok().or_else(|| {
                // Retried: the closed router's port is free again at a moment
                // the OS does not announce.
                std::thread::sleep(Duration::from_millis(20));
                None
            })
        })
        .expect("router listens again on the same endpoint");
    let watch = again.watch_alive(&s).expect("watch");
    let (e, other) = watch.wait_for(Member::Agent(RobotId(4)), Presence::Alive, WAIT);
    assert!(e.is_some(), "peer never came back; saw {other:?}");
    assert!(restarted.elapsed() < Duration::from_secs(3), "took {:?}", restarted.elapsed());
}
