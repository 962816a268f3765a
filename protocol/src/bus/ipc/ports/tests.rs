use super::*;
use crate::bus::ipc::root::Isolated;
use crate::bus::ipc::{IpcBus, IpcConfig};
use crate::bus::Bus;
use crate::naming::TopicName;
use std::sync::mpsc;

/// The event ids waiting on `sub`'s listener (taken, without waiting).
fn rings(sub: &IpcSubscriber<iceoryx2::prelude::ipc::Service>) -> Vec<usize> {
    let mut ids = Vec::new();
    match &sub.waker {
        Waker::Event { listener, .. } => {
            let listener = listener.get().expect("the reader has waited, so it listens");
            listener.try_wait(|a| ids.push(a.id.as_value())).expect("read listener");
        }
        Waker::Poll { .. } => panic!("the default bus wakes by events"),
    }
    ids.sort_unstable();
    ids.dedup();
    ids
}

/// `sub` waits once (a microsecond, nothing is there): from now on it
/// has a listener on its doorbell, as a reader has after its first wait.
fn waits(sub: &IpcSubscriber<iceoryx2::prelude::ipc::Service>) {
    let mut buf = [0u8; 16];
    assert_eq!(sub.recv_timeout_into(&mut buf, Duration::from_micros(1)).expect("wait"), None);
    assert!(matches!(&sub.waker, Waker::Event { listener, .. } if listener.listener.get().is_some()));
}

/// On a shared doorbell a send wakes only the readers of its own robot
/// (and fan-ins), also readers that came, left and came back after the
/// bell last looked; one notifier serves all the bus's publishers of
/// the family.
#[test]
fn a_shared_doorbell_wakes_only_the_robot_that_was_sent_to() {
    let iso = Isolated::new("bells");
    let config = IpcConfig { isolation: Some(iso.tag().to_owned()), ..IpcConfig::default() };
    let swarm = crate::Swarm::new("bells").expect("valid swarm");
    let topic = |k| *swarm.to_agent(crate::RobotId(k)).name();
    let bus = IpcBus::new(config.clone()).expect("iceoryx2 node");
    let agents = IpcBus::new(config).expect("iceoryx2 node");
    let one = agents.subscriber(&topic(1)).expect("subscriber");
    let two = agents.subscriber(&topic(2)).expect("subscriber");
    waits(&one);
    waits(&two);
    let to_one = bus.publisher(&topic(1)).expect("publisher");
    let to_two = bus.publisher(&topic(2)).expect("publisher");
    assert_eq!(bus.bells.open.lock().expect("lock").len(), 1, "one ringer for the family");
    to_one.publish(b"tick").expect("publish");
    assert_eq!((rings(&one), rings(&two)), (vec![1], vec![]));
    to_two.publish(b"tick").expect("publish");
    to_two.publish(b"tick").expect("publish");
    assert_eq!((rings(&one), rings(&two)), (vec![], vec![2]));
    // A reader that joins later is woken by the next send.
    let three = agents.subscriber(&topic(3)).expect("subscriber");
    waits(&three);
    let to_three = bus.publisher(&topic(3)).expect("publisher");
    to_three.publish(b"tick").expect("publish");
    assert_eq!((rings(&one), rings(&two), rings(&three)), (vec![], vec![], vec![3]));
    // Robot 1's reader is replaced (same number of listeners).
    drop(one);
    let one = agents.subscriber(&topic(1)).expect("subscriber");
    waits(&one);
    to_one.publish(b"tick").expect("publish");
    assert_eq!((rings(&one), rings(&two), rings(&three)), (vec![1], vec![], vec![]));
    let mut buf = [0u8; 16];
    assert_eq!(one.try_recv_into(&mut buf).expect("receive"), Some(4), "the message is there");
}

/// A wait of less than a microsecond on the event listener returns.
///
/// iceoryx2 0.10 waits on a Unix datagram socket with `SO_RCVTIMEO`
/// set from the timeout truncated to whole microseconds, and a zero
/// `SO_RCVTIMEO` means "never time out": a wait of 1 to 999 ns blocked
/// until the next notification. A real-time agent whose deadline fell
/// within that last microsecond hung until its orchestrator next sent
/// it something, which a stuck robot's orchestrator never does, and it
/// was killed as "fell silent" (issue 17).
///
/// No notification ever comes here unless the wait hangs: then the
/// test publishes one to free the waiting thread and fails.
#[test]
fn a_sub_microsecond_event_wait_times_out() {
    let iso = Isolated::new("subusec");
    let config = IpcConfig { isolation: Some(iso.tag().to_owned()), ..IpcConfig::default() };
    let topic = TopicName::parse("bycoms/subusec/wait").expect("valid topic");
    let (opened_tx, opened_rx) = mpsc::channel();
    let (done_tx, done_rx) = mpsc::channel();
    let waiter = {
        let config = config.clone();
        std::thread::spawn(move || {
            let bus = IpcBus::new(config).expect("iceoryx2 node");
            let sub = bus.subscriber(&topic).expect("subscriber");
            opened_tx.send(()).expect("main thread waits");
            let mut results = Vec::new();
            for ns in [1, 500, 999] {
                let mut poll = POLL_FIRST_SLEEP;
                results.push(matches!(
                    sub.waker.sleep(&sub.topic, Duration::from_nanos(ns), &mut poll, false),
                    Ok(Slept::Again)
                ));
            }
            let _ = done_tx.send(results);
        })
    };
    opened_rx.recv_timeout(Duration::from_secs(30)).expect("the subscriber opens");
    let outcome = done_rx.recv_timeout(Duration::from_secs(10));
    if outcome.is_err() {
        // Free the hung waiter (one notification per hung wait) so the
        // test ends, then fail.
        let bus = IpcBus::new(config).expect("iceoryx2 node");
        let publisher = bus.publisher(&topic).expect("publisher");
        let freed = (0..3).any(|_| {
            publisher.publish(b"wake").expect("publish");
            done_rx.recv_timeout(Duration::from_secs(5)).is_ok()
        });
        if freed {
            waiter.join().expect("waiter thread");
        }
        panic!("a wait of under 1 µs on the event listener hung until a notification came");
    }
    waiter.join().expect("waiter thread");
    let results = outcome.expect("checked above");
    assert_eq!(results, vec![true, true, true], "every wait ended without error");
}

#[test]
fn an_idle_reader_sleeps_once_for_the_whole_wait() {
    let ms = Duration::from_millis;
    assert_eq!(listener_wait(ms(50), true), ms(50));
    assert_eq!(listener_wait(ms(50), false), EVENT_WAIT_SLICE);
    assert_eq!(listener_wait(ms(5), false), ms(5));
    assert_eq!(listener_wait(Duration::from_nanos(10), true), MIN_EVENT_WAIT);
    assert_eq!(listener_wait(Duration::from_nanos(10), false), MIN_EVENT_WAIT);
}

/// An idle wait is still ended by a notification: a message sent while
/// a reader waits for a minute idly reaches it at once.
#[test]
fn an_idle_wait_is_woken_by_a_message() {
    let iso = Isolated::new("idlewait");
    let config = IpcConfig { isolation: Some(iso.tag().to_owned()), ..IpcConfig::default() };
    let topic = TopicName::parse("bycoms/idlewait/wait").expect("valid topic");
    let (waiting_tx, waiting_rx) = mpsc::channel();
    let (done_tx, done_rx) = mpsc::channel();
    let reader = {
        let config = config.clone();
        std::thread::spawn(move || {
            let bus = IpcBus::new(config).expect("iceoryx2 node");
            let sub = bus.subscriber(&topic).expect("subscriber");
            let mut buf = [0u8; 16];
            // Listening before the publisher exists: nothing to take yet.
            assert_eq!(sub.try_recv_into(&mut buf).expect("look"), None);
            waiting_tx.send(()).expect("main thread waits");
            let got = sub.recv_idle_into(&mut buf, Duration::from_secs(60)).expect("idle wait");
            let _ = done_tx.send(got.map(|n| buf[..n].to_vec()));
        })
    };
    waiting_rx.recv_timeout(Duration::from_secs(30)).expect("the reader opens");
    let bus = IpcBus::new(config).expect("iceoryx2 node");
    let publisher = bus.publisher(&topic).expect("publisher");
    publisher.publish(b"shutdown").expect("publish");
    let got = done_rx
        .recv_timeout(Duration::from_secs(20))
        .expect("the idle reader was not woken by the message within 20 s of its 60 s wait");
    assert_eq!(got.as_deref(), Some(&b"shutdown"[..]));
    reader.join().expect("reader thread");
}

/// A reader takes a slot of its doorbell's listeners only when it first
/// waits: readers that never wait are not limited by the slots, a
/// message sent before a reader waits is still received, and a waiting
/// reader beyond the slots gets an error that names the doorbell.
#[test]
fn a_reader_listens_on_its_doorbell_only_once_it_waits() {
    let iso = Isolated::new("lazybell");
    let swarm = crate::Swarm::new("lazy").expect("valid swarm");
    let topic = |k| *swarm.pose(crate::RobotId(k)).name();
    let config = IpcConfig {
        isolation: Some(iso.tag().to_owned()),
        port_limits: vec![crate::bus::ipc::PortLimits {
            suffix: "/poses",
            max_publishers: 8,
            max_subscribers: 1,
        }],
        ..IpcConfig::default()
    };
    let bus = IpcBus::new(config).expect("iceoryx2 node");
    let readers: Vec<_> = (1..=3).map(|k| bus.subscriber(&topic(k)).expect("subscriber")).collect();
    let writers: Vec<_> = (1..=3).map(|k| bus.publisher(&topic(k)).expect("publisher")).collect();
    for w in &writers {
        w.publish(b"pose").expect("publish");
    }
    let mut buf = [0u8; 16];
    for r in &readers {
        assert_eq!(r.try_recv_into(&mut buf).expect("receive"), Some(4), "read without waiting");
    }
    // One waits (the doorbell's one listener slot); its message sent
    // before it waited is received.
    writers[0].publish(b"pose").expect("publish");
    let wait = Duration::from_millis(100);
    assert_eq!(readers[0].recv_timeout_into(&mut buf, wait).expect("wait"), Some(4));
    assert_eq!(readers[0].recv_timeout_into(&mut buf, Duration::from_micros(1)).expect("wait"), None);
    // A second reader that waits finds no slot left.
    let err = readers[1].recv_timeout_into(&mut buf, Duration::from_micros(1)).expect_err("no slot left");
    assert!(err.to_string().contains("poses"), "{err}");
}
