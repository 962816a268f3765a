//! The bus conformance suite: one set of checks, run unchanged against
//! every backend by [`conformance_suite!`].
//!
//! Why generic functions plus a macro: each check is an ordinary generic
//! function over [`Bus`], so a new backend (zenoh) gets the whole suite by
//! adding one macro line. A backend is given as a factory `Fn() -> B`;
//! checks that need two threads call it once per thread, so backends whose
//! ports are confined to a thread (iceoryx2 `ipc::Service`) are covered
//! too. Every topic is unique per process and call (`pid` + counter), so
//! parallel test threads and concurrent test processes never meet. Every
//! wait has a timeout ([`WAIT`]); no check sleeps to "let things settle".

use bycoms_protocol::bus::{Bus, BusError, BusExt, Publish, Subscribe};
use bycoms_protocol::msg::{GateEvent, GateKind};
use bycoms_protocol::{RobotId, Swarm, Topic, TopicName};
use core::sync::atomic::{AtomicU32, Ordering};
use core::time::Duration;
use std::sync::mpsc;
use std::time::Instant;

/// Upper bound of any wait for a message that must arrive.
pub const WAIT: Duration = Duration::from_secs(5);
/// How long a check waits for a message that must *not* arrive.
pub const QUIET: Duration = Duration::from_millis(30);

static COUNTER: AtomicU32 = AtomicU32::new(0);

/// A swarm name no other test or process uses.
pub fn unique_swarm(tag: &str) -> Swarm {
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    Swarm::new(&format!("t{}-{n}-{tag}", std::process::id())).expect("valid swarm name")
}

/// A raw topic name no other test or process uses.
pub fn unique_topic(tag: &str) -> TopicName {
    let swarm = unique_swarm(tag);
    TopicName::parse(&format!("bycoms/{}/raw", swarm.as_str())).expect("valid topic name")
}

fn recv<S: Subscribe>(sub: &S) -> Vec<u8> {
    match sub.recv_timeout(WAIT) {
        Ok(Some(bytes)) => bytes,
        other => panic!("expected a message within {WAIT:?}, got {other:?}"),
    }
}

fn assert_quiet<S: Subscribe>(sub: &S) {
    assert_eq!(sub.recv_timeout(QUIET).expect("receive"), None, "expected no message");
}

/// Messages of one publisher arrive in publish order.
pub fn order_is_preserved<B: Bus>(bus: &B) {
    let topic = unique_topic("order");
    let sub = bus.subscriber(&topic).expect("subscriber");
    let publ = bus.publisher(&topic).expect("publisher");
    let n = bus.limits().buffer.min(32) as u8;
    for i in 0..n {
        publ.publish(&[i, i.wrapping_mul(3)]).expect("publish");
    }
    for i in 0..n {
        assert_eq!(recv(&sub), vec![i, i.wrapping_mul(3)]);
    }
    assert_quiet(&sub);
}

/// Every subscriber of a topic gets every message.
pub fn every_subscriber_gets_every_message<B: Bus>(bus: &B) {
    let topic = unique_topic("fanout");
    let subs: Vec<_> = (0..3).map(|_| bus.subscriber(&topic).expect("subscriber")).collect();
    let publ = bus.publisher(&topic).expect("publisher");
    let n = bus.limits().buffer.min(10) as u8;
    for i in 0..n {
        publ.publish(&[i]).expect("publish");
    }
    for sub in &subs {
        for i in 0..n {
            assert_eq!(recv(sub), vec![i]);
        }
        assert_quiet(sub);
    }
}

/// No history: a subscriber created after a publish does not see it.
pub fn late_subscriber_gets_no_stale_data<B: Bus>(bus: &B) {
    let topic = unique_topic("late");
    let early = bus.subscriber(&topic).expect("subscriber");
    let publ = bus.publisher(&topic).expect("publisher");
    publ.publish(b"old").expect("publish");
    let late = bus.subscriber(&topic).expect("subscriber");
    publ.publish(b"new").expect("publish");
    assert_eq!(recv(&late), b"new");
    assert_quiet(&late);
    assert_eq!(recv(&early), b"old");
    assert_eq!(recv(&early), b"new");
}

/// A subscriber also receives from publishers created after it.
pub fn later_publisher_reaches_subscriber<B: Bus>(bus: &B) {
    let topic = unique_topic("laterpub");
    let sub = bus.subscriber(&topic).expect("subscriber");
    let first = bus.publisher(&topic).expect("publisher");
    first.publish(&[1]).expect("publish");
    let second = bus.publisher(&topic).expect("publisher");
    second.publish(&[2]).expect("publish");
    let mut got = vec![recv(&sub), recv(&sub)];
    got.sort();
    assert_eq!(got, vec![vec![1], vec![2]]);
}

/// Two topics never see each other's messages.
pub fn topics_are_isolated<B: Bus>(bus: &B) {
    let a = unique_topic("isoa");
    let b = unique_topic("isob");
    let sub_a = bus.subscriber(&a).expect("subscriber");
    let sub_b = bus.subscriber(&b).expect("subscriber");
    let pub_a = bus.publisher(&a).expect("publisher");
    pub_a.publish(b"for a").expect("publish");
    assert_eq!(recv(&sub_a), b"for a");
    assert_quiet(&sub_b);
}

/// A payload over the limit is a typed error; one at the limit goes through.
pub fn payload_too_large_is_a_typed_error<B: Bus>(bus: &B) {
    let topic = unique_topic("large");
    let max = bus.limits().max_payload;
    let sub = bus.subscriber(&topic).expect("subscriber");
    let publ = bus.publisher(&topic).expect("publisher");
    let err = publ.publish(&vec![7u8; max + 1]).expect_err("too large");
    assert_eq!(err, BusError::PayloadTooLarge { len: max + 1, max });
    publ.publish(&vec![9u8; max]).expect("publish at the limit");
    publ.publish(&[]).expect("publish empty");
    assert_eq!(recv(&sub), vec![9u8; max]);
    assert_eq!(recv(&sub), Vec::<u8>::new());
    assert_quiet(&sub);
}

/// A receive buffer smaller than the message is a typed error, and the
/// subscriber goes on with the next message.
pub fn small_receive_buffer_is_a_typed_error<B: Bus>(bus: &B) {
    let topic = unique_topic("smallbuf");
    let sub = bus.subscriber(&topic).expect("subscriber");
    let publ = bus.publisher(&topic).expect("publisher");
    publ.publish(&[1, 2, 3, 4]).expect("publish");
    publ.publish(&[5]).expect("publish");
    let mut buf = [0u8; 2];
    let err = sub.recv_timeout_into(&mut buf, WAIT).expect_err("too small");
    assert_eq!(err, BusError::BufferTooSmall { len: 4, capacity: 2 });
    assert_eq!(sub.recv_timeout_into(&mut buf, WAIT), Ok(Some(1)));
    assert_eq!(buf[0], 5);
}

/// `recv_timeout` returns `None` once its timeout has passed, not before.
pub fn recv_timeout_returns_none_after_timeout<B: Bus>(bus: &B) {
    let topic = unique_topic("timeout");
    let sub = bus.subscriber(&topic).expect("subscriber");
    assert_eq!(sub.try_recv().expect("try_recv"), None);
    let timeout = Duration::from_millis(50);
    let start = Instant::now();
    assert_eq!(sub.recv_timeout(timeout).expect("receive"), None);
    let waited = start.elapsed();
    assert!(waited >= timeout, "returned after {waited:?}, before {timeout:?}");
    assert!(waited < WAIT, "overslept: {waited:?}");
    assert_eq!(sub.recv_timeout(Duration::ZERO).expect("receive"), None);
}

/// A burst of `buffer` messages is kept whole while nobody reads.
pub fn burst_up_to_buffer_is_not_lost<B: Bus>(bus: &B) {
    let topic = unique_topic("burst");
    let buffer = bus.limits().buffer;
    let sub = bus.subscriber(&topic).expect("subscriber");
    let publ = bus.publisher(&topic).expect("publisher");
    for i in 0..buffer as u32 {
        publ.publish(&i.to_le_bytes()).expect("publish");
    }
    for i in 0..buffer as u32 {
        assert_eq!(sub.try_recv().expect("try_recv"), Some(i.to_le_bytes().to_vec()));
    }
    assert_eq!(sub.try_recv().expect("try_recv"), None);
}

/// Past `buffer` unread messages the oldest are overwritten, never the newest.
pub fn overflow_drops_the_oldest<B: Bus>(bus: &B) {
    let topic = unique_topic("overflow");
    let buffer = bus.limits().buffer as u32;
    let sub = bus.subscriber(&topic).expect("subscriber");
    let publ = bus.publisher(&topic).expect("publisher");
    for i in 0..buffer + 5 {
        publ.publish(&i.to_le_bytes()).expect("publish never blocks");
    }
    for i in 5..buffer + 5 {
        assert_eq!(sub.try_recv().expect("try_recv"), Some(i.to_le_bytes().to_vec()));
    }
    assert_eq!(sub.try_recv().expect("try_recv"), None);
}

/// A subscriber blocked in `recv_timeout` on one thread is woken by a
/// publish from another thread (each with its own bus from `make`).
pub fn waiting_subscriber_is_woken<B: Bus, F: Fn() -> B + Sync>(make: &F) {
    let topic = unique_topic("wake");
    let (ready_tx, ready_rx) = mpsc::channel();
    std::thread::scope(|s| {
        let waiter = s.spawn(|| {
            let bus = make();
            let sub = bus.subscriber(&topic).expect("subscriber");
            ready_tx.send(()).expect("signal ready");
            let start = Instant::now();
            let got = sub.recv_timeout(WAIT).expect("receive");
            (got, start.elapsed())
        });
        ready_rx.recv_timeout(WAIT).expect("waiter ready");
        let bus = make();
        let publ = bus.publisher(&topic).expect("publisher");
        // The waiter is probably asleep by now; no sleep is needed for
        // correctness, only to make the wake-up path likely.
        std::thread::sleep(Duration::from_millis(5));
        publ.publish(b"wake").expect("publish");
        let (got, waited) = waiter.join().expect("waiter thread");
        assert_eq!(got.as_deref(), Some(&b"wake"[..]));
        assert!(waited < WAIT / 2, "woken late: {waited:?}");
    });
}

/// The typed layer carries messages of the topic's type and reports an
/// undecodable payload as a codec error without losing the next message.
pub fn typed_layer_round_trips<B: Bus>(bus: &B) {
    let swarm = unique_swarm("typed");
    let topic: Topic<GateEvent> = swarm.gate();
    let sub = bus.typed_subscriber(&topic).expect("subscriber");
    let publ = bus.typed_publisher(&topic).expect("publisher");
    let raw = bus.publisher(topic.name()).expect("raw publisher");
    let event = GateEvent {
        robot: RobotId(2),
        kind: GateKind::Stopped { arrived: false },
        x: 20.25,
        y: 31.0,
        step: 4321,
    };
    // Order across publishers is not part of the contract: one at a time.
    raw.publish(&[1, 2, 99]).expect("publish garbage");
    assert!(matches!(sub.recv_timeout(WAIT), Err(BusError::Codec(_))));
    publ.publish(&event).expect("publish");
    assert_eq!(sub.recv_timeout(WAIT).expect("receive"), Some(event));
    assert_eq!(sub.try_recv().expect("try_recv"), None);
}

/// A fan-in over three robots' report topics: every message arrives once,
/// tagged with its topic's index, in publish order per topic; other topics
/// stay out; a fan-in does not take messages from a topic's subscriber.
pub fn fan_in_tags_every_message_with_its_topic<B: Bus>(bus: &B) {
    let swarm = unique_swarm("fanin");
    let topics: Vec<TopicName> = (1..=3).map(|k| *swarm.from_agent(RobotId(k)).name()).collect();
    let fan_in = bus.fan_in(&topics).expect("fan-in");
    let plain = bus.subscriber(&topics[1]).expect("subscriber");
    let outsider = bus.publisher(swarm.to_agent(RobotId(1)).name()).expect("publisher");
    let publishers: Vec<_> = topics.iter().map(|t| bus.publisher(t).expect("publisher")).collect();
    let n = bus.limits().buffer.min(8) as u8;
    for i in 0..n {
        for (k, p) in publishers.iter().enumerate() {
            p.publish(&[k as u8, i]).expect("publish");
        }
        outsider.publish(&[9, i]).expect("publish");
    }
    assert_eq!(fan_in.max_payload(), bus.limits().max_payload + bycoms_protocol::bus::FAN_IN_TAG);
    let mut next = [0u8; 3];
    for _ in 0..3 * usize::from(n) {
        let message = recv(&fan_in);
        let (topic, payload) = bycoms_protocol::bus::untag(&message).expect("tagged");
        assert!(topic < 3, "index {topic}");
        assert_eq!(payload, [topic as u8, next[topic]], "topic {topic} in publish order");
        next[topic] += 1;
    }
    assert_eq!(next, [n; 3]);
    assert_quiet(&fan_in);
    for i in 0..n {
        assert_eq!(recv(&plain), vec![1, i], "the topic's own subscriber still gets everything");
    }
}

/// Runs `wait` on a fan-in over `topics` in a thread of its own (with its
/// own bus from `make`), and `publish` here (with another) once that
/// fan-in exists; returns what `wait` returned. The bus and the publisher
/// `publish` returns are kept until the waiter is done: a publisher's
/// messages may go with it (iceoryx2).
fn beside_a_waiting_fan_in<B: Bus, F: Fn() -> B + Sync, T: Send>(
    make: &F,
    topics: &[TopicName],
    wait: impl FnOnce(&B::FanIn) -> T + Send,
    publish: impl FnOnce(&B) -> B::Publisher,
) -> T {
    let (ready_tx, ready_rx) = mpsc::channel();
    std::thread::scope(|s| {
        let waiter = s.spawn(|| {
            let bus = make();
            let fan_in = bus.fan_in(topics).expect("fan-in");
            ready_tx.send(()).expect("signal ready");
            wait(&fan_in)
        });
        ready_rx.recv_timeout(WAIT).expect("waiter ready");
        let bus = make();
        let _publisher = publish(&bus);
        waiter.join().expect("waiter thread")
    })
}

/// A fan-in waiting in one thread wakes for a message on any of its
/// topics published from another (the last topic, so a reader that only
/// waited on its first topic's wake-ups would time out).
pub fn fan_in_wakes_for_any_topic<B: Bus, F: Fn() -> B + Sync>(make: &F) {
    let swarm = unique_swarm("fanin-wake");
    let topics: Vec<TopicName> = (1..=4).map(|k| *swarm.from_agent(RobotId(k)).name()).collect();
    let wait = |fan_in: &B::FanIn| {
        let start = Instant::now();
        let got = fan_in.recv_timeout(WAIT).expect("receive");
        (got, start.elapsed())
    };
    let publish = |bus: &B| {
        let publ = bus.publisher(&topics[3]).expect("publisher");
        // Only makes the wake-up path likely; not needed for correctness.
        std::thread::sleep(Duration::from_millis(5));
        publ.publish(&[42]).expect("publish");
        publ
    };
    let (got, waited) = beside_a_waiting_fan_in(make, &topics, wait, publish);
    let got = got.expect("a message");
    assert_eq!(bycoms_protocol::bus::untag(&got), Some((3, &[42u8][..])));
    assert!(waited < WAIT / 2, "woken late: {waited:?}");
}

/// Messages published quietly, then one published as usual, wake a fan-in
/// waiting in another thread, and it finds them all, in order: the quiet
/// ones are not lost or held back behind the wake-up.
pub fn quiet_publishes_arrive_with_the_next_one<B: Bus, F: Fn() -> B + Sync>(make: &F) {
    let swarm = unique_swarm("quiet");
    let topics: Vec<TopicName> = (1..=3).map(|k| *swarm.pose(RobotId(k)).name()).collect();
    let wait = |fan_in: &B::FanIn| {
        let mut got = Vec::new();
        while got.len() < 4 {
            match fan_in.recv_timeout(WAIT).expect("receive") {
                Some(m) => got.push(m),
                None => break,
            }
        }
        got
    };
    let publish = |bus: &B| {
        let publ = bus.publisher(&topics[2]).expect("publisher");
        for k in 1..=3u8 {
            publ.publish_quietly(&[k]).expect("publish quietly");
        }
        publ.publish(&[4]).expect("publish");
        publ
    };
    let got = beside_a_waiting_fan_in(make, &topics, wait, publish);
    let got: Vec<_> = got.iter().map(|m| bycoms_protocol::bus::untag(m).expect("tagged")).collect();
    let want: Vec<(usize, &[u8])> = vec![(2, &[1]), (2, &[2]), (2, &[3]), (2, &[4])];
    assert_eq!(got, want);
}

/// Instantiates the whole suite for one backend: `$make` is an expression
/// of a `Fn() -> impl Bus + Sync` factory.
#[macro_export]
macro_rules! conformance_suite {
    ($name:ident, $make:expr) => {
        mod $name {
            use $crate::conformance as c;
            fn bus() -> impl bycoms_protocol::bus::Bus {
                ($make)()
            }
            #[test]
            fn fan_in_tags_every_message_with_its_topic() {
                c::fan_in_tags_every_message_with_its_topic(&bus())
            }
            #[test]
            fn fan_in_wakes_for_any_topic() {
                c::fan_in_wakes_for_any_topic(&$make)
            }
            #[test]
            fn quiet_publishes_arrive_with_the_next_one() {
                c::quiet_publishes_arrive_with_the_next_one(&$make)
            }
            #[test]
            fn order_is_preserved() {
                c::order_is_preserved(&bus())
            }
            #[test]
            fn every_subscriber_gets_every_message() {
                c::every_subscriber_gets_every_message(&bus())
            }
            #[test]
            fn late_subscriber_gets_no_stale_data() {
                c::late_subscriber_gets_no_stale_data(&bus())
            }
            #[test]
            fn later_publisher_reaches_subscriber() {
                c::later_publisher_reaches_subscriber(&bus())
            }
            #[test]
            fn topics_are_isolated() {
                c::topics_are_isolated(&bus())
            }
            #[test]
            fn payload_too_large_is_a_typed_error() {
                c::payload_too_large_is_a_typed_error(&bus())
            }
            #[test]
            fn small_receive_buffer_is_a_typed_error() {
                c::small_receive_buffer_is_a_typed_error(&bus())
            }
            #[test]
            fn recv_timeout_returns_none_after_timeout() {
                c::recv_timeout_returns_none_after_timeout(&bus())
            }
            #[test]
            fn burst_up_to_buffer_is_not_lost() {
                c::burst_up_to_buffer_is_not_lost(&bus())
            }
            #[test]
            fn overflow_drops_the_oldest() {
                c::overflow_drops_the_oldest(&bus())
            }
            #[test]
            fn waiting_subscriber_is_woken() {
                c::waiting_subscriber_is_woken(&$make)
            }
            #[test]
            fn typed_layer_round_trips() {
                c::typed_layer_round_trips(&bus())
            }
        }
    };
}
