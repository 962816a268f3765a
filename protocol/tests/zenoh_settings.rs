//! The run's settings (and, last, the orchestrator's clock) over zenoh: a client session asks the router's
//! queryable on `bycoms/<swarm>/settings` and gets the served bytes whole
//! (far beyond one bus message), every time it asks; another swarm's key
//! gets no answer, within the asked wait; the answer stops when the server
//! is dropped. An asker naming a robot outside the launch is refused with
//! the reason and counted; one naming none (an older agent) is answered.
//!
//! Every session listens on a loopback port the kernel handed out; every
//! wait has a timeout.
#![cfg(feature = "zenoh")]

use bycoms_protocol::bus::zenoh::settings::SettingsAnswer;
use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
use bycoms_protocol::{RobotId, Swarm};
use core::time::Duration;
use std::time::Instant;

/// A router listening on a free loopback port, and its endpoint.
fn router() -> (ZenohBus, String) {
    let config = |endpoint: &str| ZenohConfig {
        mode: Mode::Router,
        listen: vec![endpoint.to_owned()],
        ..ZenohConfig::default()
    };
    ZenohBus::loopback_router(config).expect("a router on a free loopback port")
}

fn client_of(endpoint: &str) -> ZenohBus {
    ZenohBus::open(ZenohConfig {
        mode: Mode::Client,
        connect: vec![endpoint.to_owned()],
        ..ZenohConfig::default()
    })
    .expect("client session")
}

fn swarm(tag: &str) -> Swarm {
    Swarm::new(&format!("s{}-{tag}", std::process::id())).expect("valid swarm")
}

/// Asks as robot `robot` until an answer comes, for up to 5 s (the
/// client's routes to the router's queryable are declared asynchronously
/// after it connects).
fn answer_soon(bus: &ZenohBus, swarm: &Swarm, robot: Option<u32>) -> Option<SettingsAnswer> {
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        // Each ask waits up to 500 ms for an answer: no pause between asks.
        let asked = bus.fetch_settings(swarm, robot.map(RobotId), Duration::from_millis(500));
        if let Some(answer) = asked.expect("query") {
            return Some(answer);
        }
    }
    None
}

/// The settings robot 1 gets, within 5 s.
fn fetch_soon(bus: &ZenohBus, swarm: &Swarm) -> Option<Vec<u8>> {
    match answer_soon(bus, swarm, Some(1)) {
        Some(SettingsAnswer::Settings(bytes)) => Some(bytes),
        other => panic!("robot 1 was not answered its settings: {other:?}"),
    }
}

#[test]
fn a_client_gets_the_served_settings_whole_and_another_swarm_gets_nothing() {
    let (router, endpoint) = router();
    let lab = swarm("lab");
    // A terrain's worth of bytes, every value of a byte in it.
    let served: Vec<u8> = (0..5000u32).map(|i| (i % 251) as u8).collect();
    let server = router.serve_settings(&lab, served.clone(), 3).expect("serve");
    let client = client_of(&endpoint);
    assert_eq!(fetch_soon(&client, &lab).as_deref(), Some(&served[..]), "the whole payload");
    assert_eq!(fetch_soon(&client, &lab).as_deref(), Some(&served[..]), "again, for every asker");
    // Another swarm's settings: nobody answers, within the wait asked for.
    let asked = Instant::now();
    let other = client.fetch_settings(&swarm("other"), Some(RobotId(1)), Duration::from_millis(300));
    let other = other.expect("query");
    assert_eq!(other, None);
    assert!(asked.elapsed() < Duration::from_secs(3), "the wait is bounded: {:?}", asked.elapsed());
    // Served for as long as the server lives: once the undeclaration has
    // reached the client (asynchronously), asks go unanswered.
    drop(server);
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut answered = true;
    while answered && Instant::now() < deadline {
        answered = client
            .fetch_settings(&lab, Some(RobotId(1)), Duration::from_millis(300))
            .expect("query")
            .is_some();
    }
    assert!(!answered, "still answered 5 s after the server was dropped");
}

#[test]
fn an_asker_for_a_robot_outside_the_launch_is_refused_and_counted() {
    let (router, endpoint) = router();
    let lab = swarm("strangers");
    let served = vec![1u8, 2, 3];
    let server = router.serve_settings(&lab, served.clone(), 3).expect("serve");
    let client = client_of(&endpoint);
    // The launch's robots, and an agent of an older build (no robot named).
    assert_eq!(answer_soon(&client, &lab, Some(3)), Some(SettingsAnswer::Settings(served.clone())));
    assert_eq!(answer_soon(&client, &lab, None), Some(SettingsAnswer::Settings(served)));
    assert_eq!(server.refused(), 0);
    // Robot 9 of 3: refused, saying why, and counted.
    let why = "robot 9 is not one of the launch's robots (it has robots 1 to 3)";
    assert_eq!(answer_soon(&client, &lab, Some(9)), Some(SettingsAnswer::Refused(why.into())));
    assert_eq!(server.refused(), 1);
}

/// The orchestrator's clock over zenoh (`bus::zenoh::clock`): a client
/// measures an offset near zero on one host, and near a skew given to its
/// clock (as the test-only `BYCOMS_TEST_CLOCK_SKEW_MS` does), within half
/// the round trip; another swarm's clock is not answered; a probe reports
/// at once.
#[test]
fn the_orchestrators_clock_is_measured_with_its_round_trip() {
    use bycoms_protocol::bus::zenoh::clock::HostClock;
    let (router, endpoint) = router();
    let lab = swarm("clock");
    let _served = router.serve_clock(&lab).expect("serve the clock");
    let client = client_of(&endpoint);
    let wait = Duration::from_secs(2);
    let same = client.measure_clock(&lab, HostClock::default(), wait).expect("query").expect("answered");
    // One host: the offset is within half the round trip (and the scheduler's noise).
    let slack = same.round_trip_us as i64 / 2 + 20_000;
    assert!(same.offset_us.abs() <= slack, "{same:?}");
    let ahead = HostClock { skew_us: 2_000_000 };
    let skewed = client.measure_clock(&lab, ahead, wait).expect("query").expect("answered");
    assert!((skewed.offset_us - 2_000_000).abs() <= skewed.round_trip_us as i64 / 2 + 20_000, "{skewed:?}");
    let none = client.measure_clock(&swarm("clock-other"), HostClock::default(), Duration::from_millis(200));
    assert_eq!(none.expect("query"), None, "nobody serves another swarm's clock");
    let probe = client.clock_probe(&lab, ahead);
    let first = probe.wait(wait).expect("the probe measures at once");
    assert!(first.offset_us > 1_900_000, "{first:?}");
}
