//! The run's settings over zenoh: a client session asks the router's
//! queryable on `bycoms/<swarm>/settings` and gets the served bytes whole
//! (far beyond one bus message), every time it asks; another swarm's key
//! gets no answer, within the asked wait; the answer stops when the server
//! is dropped.
//!
//! Every session listens on a loopback port the kernel handed out; every
//! wait has a timeout.
#![cfg(feature = "zenoh")]

use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
use bycoms_protocol::Swarm;
use core::time::Duration;
use std::net::TcpListener;
use std::time::Instant;

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).expect("a free port").port()
}

/// A router listening on a free loopback port, and its endpoint.
fn router() -> (ZenohBus, String) {
    let mut last = None;
    for _ in 0..5 {
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        let config =
            ZenohConfig { mode: Mode::Router, listen: vec![endpoint.clone()], ..ZenohConfig::default() };
        match ZenohBus::open(config) {
            Ok(bus) => return (bus, endpoint),
            Err(e) => last = Some(e),
        }
    }
    panic!("no router could listen: {last:?}")
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

/// Asks until an answer comes, for up to 5 s (the client's routes to the
/// router's queryable are declared asynchronously after it connects).
fn fetch_soon(bus: &ZenohBus, swarm: &Swarm) -> Option<Vec<u8>> {
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        // Each ask waits up to 500 ms for an answer: no pause between asks.
        if let Some(bytes) = bus.fetch_settings(swarm, Duration::from_millis(500)).expect("query") {
            return Some(bytes);
        }
    }
    None
}

#[test]
fn a_client_gets_the_served_settings_whole_and_another_swarm_gets_nothing() {
    let (router, endpoint) = router();
    let lab = swarm("lab");
    // A terrain's worth of bytes, every value of a byte in it.
    let served: Vec<u8> = (0..5000u32).map(|i| (i % 251) as u8).collect();
    let server = router.serve_settings(&lab, served.clone()).expect("serve");
    let client = client_of(&endpoint);
    assert_eq!(fetch_soon(&client, &lab).as_deref(), Some(&served[..]), "the whole payload");
    assert_eq!(fetch_soon(&client, &lab).as_deref(), Some(&served[..]), "again, for every asker");
    // Another swarm's settings: nobody answers, within the wait asked for.
    let asked = Instant::now();
    let other = client.fetch_settings(&swarm("other"), Duration::from_millis(300)).expect("query");
    assert_eq!(other, None);
    assert!(asked.elapsed() < Duration::from_secs(3), "the wait is bounded: {:?}", asked.elapsed());
    // Served for as long as the server lives: once the undeclaration has
    // reached the client (asynchronously), asks go unanswered.
    drop(server);
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut answered = true;
    while answered && Instant::now() < deadline {
        answered = client.fetch_settings(&lab, Duration::from_millis(300)).expect("query").is_some();
    }
    assert!(!answered, "still answered 5 s after the server was dropped");
}
