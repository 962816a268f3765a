//! The iceoryx2 bus's fan-in, tested through the bus (here, not in
//! `fan_in.rs`, which the bus uses: no file cycles).

use crate::bus::ipc::root::Isolated;
use crate::bus::ipc::{IpcBus, IpcConfig, Wake};
use crate::bus::{untag, Bus, Publish, Subscribe, FAN_IN_TAG};
use crate::{RobotId, Swarm};
use core::time::Duration;
use std::time::Instant;

/// More robots than event ids: robots 2, 65 and 128 ring with one id,
/// and the message of each is found (by reading the few topics of that
/// id, or the round of a slice later), tagged with its own topic, once.
#[test]
fn a_fan_in_finds_a_ring_among_robots_that_share_its_event_id() {
    let iso = Isolated::new("shared-id");
    let config = IpcConfig { isolation: Some(iso.tag().to_owned()), ..IpcConfig::default() };
    let swarm = Swarm::new("shared-id").expect("valid swarm");
    let topics: Vec<_> = (1..=130).map(|k| *swarm.pose(RobotId(k)).name()).collect();
    let reader = IpcBus::new(config.clone()).expect("iceoryx2 node");
    let fan_in = reader.fan_in(&topics).expect("fan-in");
    let mut buf = [0u8; 64 + FAN_IN_TAG];
    assert_eq!(fan_in.try_recv_into(&mut buf).expect("receive"), None, "nothing sent yet");
    let writer = IpcBus::new(config).expect("iceoryx2 node");
    for robot in [65u32, 2, 128] {
        let publisher = writer.publisher(&topics[robot as usize - 1]).expect("publisher");
        publisher.publish(&robot.to_le_bytes()).expect("publish");
        let n = fan_in.recv_timeout_into(&mut buf, Duration::from_secs(5)).expect("receive");
        let n = n.unwrap_or_else(|| panic!("robot {robot}'s message is found"));
        let bytes = robot.to_le_bytes();
        assert_eq!(untag(&buf[..n]), Some((robot as usize - 1, &bytes[..])), "robot {robot}");
    }
    assert_eq!(fan_in.try_recv_into(&mut buf).expect("receive"), None, "each message once");
}

/// A reader that only looks without waiting still gets a message whose
/// publisher did not ring (here one that polls), within a slice or so.
#[test]
fn a_fan_in_read_without_waiting_finds_what_did_not_ring() {
    let iso = Isolated::new("unrung");
    let config = IpcConfig { isolation: Some(iso.tag().to_owned()), ..IpcConfig::default() };
    let silent = IpcConfig {
        wake: Wake::Poll { spin: Duration::ZERO, max_sleep: Duration::from_millis(1) },
        ..config.clone()
    };
    let swarm = Swarm::new("unrung").expect("valid swarm");
    let topics: Vec<_> = (1..=3).map(|k| *swarm.pose(RobotId(k)).name()).collect();
    let reader = IpcBus::new(config).expect("iceoryx2 node");
    let fan_in = reader.fan_in(&topics).expect("fan-in");
    let mut buf = [0u8; 64 + FAN_IN_TAG];
    assert_eq!(fan_in.try_recv_into(&mut buf).expect("receive"), None, "nothing sent yet");
    let writer = IpcBus::new(silent).expect("iceoryx2 node");
    let publisher = writer.publisher(&topics[1]).expect("publisher");
    publisher.publish(b"pose").expect("publish");
    let deadline = Instant::now() + Duration::from_secs(5);
    let got = loop {
        if let Some(n) = fan_in.try_recv_into(&mut buf).expect("receive") {
            break Some(n);
        }
        if Instant::now() > deadline {
            break None;
        }
        core::hint::spin_loop();
    };
    let n = got.expect("the unrung message is found");
    assert_eq!(untag(&buf[..n]), Some((1, &b"pose"[..])));
}

/// A small fan-in (at most `fan_in::SMALL` topics) looks at every topic
/// instead of reading its doorbell first: what several topics hold is
/// read, each message once and tagged with its topic, without a wait; and
/// one that sleeps is still woken by a ring.
#[test]
fn a_small_fan_in_reads_every_topic_without_its_doorbell() {
    let iso = Isolated::new("small-fan-in");
    let iso_tag = iso.tag().to_owned();
    let config_of = |tag: &str| IpcConfig { isolation: Some(tag.to_owned()), ..IpcConfig::default() };
    let config = config_of(&iso_tag);
    let swarm = Swarm::new("small-fan-in").expect("valid swarm");
    // As many topics as a small fan-in has at most (a launch of 16 robots).
    let small = super::fan_in::SMALL as u32;
    let topics: Vec<_> = (1..=small).map(|k| *swarm.from_agent(RobotId(k)).name()).collect();
    assert!(topics.len() <= super::fan_in::SMALL);
    let last = topics.len() - 1;
    let reader = IpcBus::new(config.clone()).expect("iceoryx2 node");
    let fan_in = reader.fan_in(&topics).expect("fan-in");
    let mut buf = [0u8; 64 + FAN_IN_TAG];
    assert_eq!(fan_in.try_recv_into(&mut buf).expect("receive"), None, "nothing sent yet");
    let writer = IpcBus::new(config).expect("iceoryx2 node");
    let publishers: Vec<_> = topics.iter().map(|t| writer.publisher(t).expect("publisher")).collect();
    for (topic, payload) in [(0, b"a1"), (last, b"c1"), (0, b"a2")] {
        publishers[topic].publish(payload).expect("publish");
    }
    let mut got = Vec::new();
    while let Some(n) = fan_in.try_recv_into(&mut buf).expect("receive") {
        let (topic, payload) = untag(&buf[..n]).expect("tagged");
        got.push((topic, payload.to_vec()));
    }
    got.sort();
    let expected = [(0, b"a1".to_vec()), (0, b"a2".to_vec()), (last, b"c1".to_vec())];
    assert_eq!(got, expected, "each once");
    drop(publishers);
    // Ports stay in the thread that opened them: a bus of its own there.
    let topic = topics[1];
    let (read, done) = std::sync::mpsc::channel::<()>();
    let sender = std::thread::spawn(move || {
        let bus = IpcBus::new(config_of(&iso_tag)).expect("iceoryx2 node");
        let publisher = bus.publisher(&topic).expect("publisher");
        let sent = publisher.publish(b"b1");
        // Kept open until the message was read (or the reader gave up).
        let _ = done.recv_timeout(Duration::from_secs(10));
        sent
    });
    let n = fan_in.recv_timeout_into(&mut buf, Duration::from_secs(5)).expect("receive");
    drop(read);
    let n = n.expect("woken by the ring, or found at the first look");
    assert_eq!(untag(&buf[..n]), Some((1, &b"b1"[..])));
    sender.join().expect("sender").expect("publish");
}
