//! The fault layer (`bus::fault`): with every rate 0 it passes the bus
//! conformance suite unchanged; with a fixed seed each fault happens at its
//! configured rate, visibly in what the subscriber receives, and the same
//! seed gives the same faults.

use crate::conformance;

use bycoms_protocol::bus::fault::{FaultBus, FaultConfig, FaultStats};
use bycoms_protocol::bus::memory::MemoryBus;
use bycoms_protocol::bus::{Bus, Limits, Publish, Subscribe};
use conformance::unique_topic;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// The in-memory bus behind a transparent fault layer (shared, like the
/// memory backend's own suite, so two-thread checks meet on one hub).
fn transparent() -> FaultBus<MemoryBus> {
    static BUS: OnceLock<MemoryBus> = OnceLock::new();
    let inner = BUS.get_or_init(|| MemoryBus::new(Limits::default()).expect("limits")).clone();
    FaultBus::new(inner, FaultConfig::none(7)).expect("valid config")
}

fn transparent_small() -> FaultBus<MemoryBus> {
    static BUS: OnceLock<MemoryBus> = OnceLock::new();
    let limits = Limits { max_payload: 32, buffer: 4 };
    let inner = BUS.get_or_init(|| MemoryBus::new(limits).expect("limits")).clone();
    FaultBus::new(inner, FaultConfig::none(7)).expect("valid config")
}

crate::conformance_suite!(fault_layer_all_rates_zero, crate::bus_fault::transparent);
crate::conformance_suite!(fault_layer_all_rates_zero_small_limits, crate::bus_fault::transparent_small);

/// Messages sent in one go.
const N: u32 = 4_000;
/// The rate of the fault under test.
const P: f64 = 0.1;

/// Publishes 0..N as 4-byte sequence numbers and receives until quiet;
/// returns what arrived, in order, and the layer's counts.
fn deliver(config: FaultConfig) -> (Vec<u32>, FaultStats) {
    let inner = MemoryBus::new(Limits { max_payload: 16, buffer: N as usize }).expect("limits");
    let bus = FaultBus::new(inner, config).expect("valid config");
    let topic = unique_topic("fault");
    let sub = bus.subscriber(&topic).expect("subscriber");
    let publ = bus.publisher(&topic).expect("publisher");
    for i in 0..N {
        publ.publish(&i.to_le_bytes()).expect("publish");
    }
    let mut got = Vec::new();
    // Quiet for longer than `delay_by`: everything held has been released.
    while let Some(bytes) = sub.recv_timeout(config.delay_by + Duration::from_millis(200)).expect("receive") {
        got.push(u32::from_le_bytes(bytes.try_into().expect("4 bytes")));
    }
    (got, sub.stats())
}

fn config(seed: u64) -> FaultConfig {
    FaultConfig { delay_by: Duration::from_millis(2), ..FaultConfig::none(seed) }
}

/// For reordering: a held message is released after `delay_by` even without
/// a successor, which would depend on scheduling; every successor here is
/// already published, so a long `delay_by` makes each swap certain (only
/// the very last message may wait it out).
fn patient(seed: u64) -> FaultConfig {
    FaultConfig { delay_by: Duration::from_millis(500), ..FaultConfig::none(seed) }
}

/// `count` is a plausible draw of Binomial(N, P): within 5 standard deviations.
fn assert_rate(what: &str, count: u64) {
    let mean = f64::from(N) * P;
    let sd = (mean * (1.0 - P)).sqrt();
    assert!((count as f64 - mean).abs() < 5.0 * sd, "{what}: {count} of {N}, expected about {mean}");
}

fn inversions(got: &[u32]) -> usize {
    got.windows(2).filter(|w| w[0] > w[1]).count()
}

#[test]
fn drop_loses_messages_at_the_rate_and_keeps_the_rest_in_order() {
    let (got, stats) = deliver(FaultConfig { drop: P, ..config(1) });
    assert_rate("dropped", stats.dropped);
    assert_eq!(stats.received, u64::from(N));
    assert_eq!(got.len() as u64, u64::from(N) - stats.dropped, "exactly the dropped ones are missing");
    assert_eq!(inversions(&got), 0, "no reordering");
    assert!(got.windows(2).all(|w| w[0] < w[1]), "no duplicates");
    assert_eq!((stats.duplicated, stats.delayed, stats.reordered), (0, 0, 0));
}

#[test]
fn duplicate_repeats_messages_at_the_rate() {
    let (got, stats) = deliver(FaultConfig { duplicate: P, ..config(2) });
    assert_rate("duplicated", stats.duplicated);
    assert_eq!(got.len() as u64, u64::from(N) + stats.duplicated);
    let repeats = got.windows(2).filter(|w| w[0] == w[1]).count() as u64;
    assert_eq!(repeats, stats.duplicated, "each duplicate follows its original");
    let mut distinct = got.clone();
    distinct.dedup();
    assert_eq!(distinct, (0..N).collect::<Vec<_>>(), "nothing lost or reordered");
}

#[test]
fn reorder_swaps_messages_with_their_successor_at_the_rate() {
    let (got, stats) = deliver(FaultConfig { reorder: P, ..patient(3) });
    assert_rate("reordered", stats.reordered);
    assert_eq!(inversions(&got) as u64, stats.reordered, "one inversion per swap");
    let mut sorted = got.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, (0..N).collect::<Vec<_>>(), "every message exactly once");
}

#[test]
fn delay_holds_messages_at_the_rate_and_later_ones_overtake_them() {
    let (got, stats) = deliver(FaultConfig { delay: P, ..config(4) });
    assert_rate("delayed", stats.delayed);
    assert!(inversions(&got) > 0, "delayed messages were overtaken");
    let mut sorted = got.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, (0..N).collect::<Vec<_>>(), "every message exactly once");
}

#[test]
fn a_delayed_message_arrives_no_earlier_than_delay_by() {
    let delay_by = Duration::from_millis(50);
    let cfg = FaultConfig { delay: 1.0, delay_by, ..FaultConfig::none(5) };
    let bus = FaultBus::new(MemoryBus::new(Limits::default()).expect("limits"), cfg).expect("config");
    let topic = unique_topic("delay");
    let sub = bus.subscriber(&topic).expect("subscriber");
    let publ = bus.publisher(&topic).expect("publisher");
    let sent = Instant::now();
    publ.publish(b"late").expect("publish");
    assert_eq!(sub.try_recv().expect("receive"), None, "held back");
    let got = sub.recv_timeout(Duration::from_secs(5)).expect("receive");
    assert_eq!(got.as_deref(), Some(&b"late"[..]));
    assert!(sent.elapsed() >= delay_by, "released after {:?}", sent.elapsed());
}

#[test]
fn the_same_seed_gives_the_same_faults_and_another_seed_others() {
    let faults = |seed| FaultConfig { drop: P, duplicate: P, reorder: P, ..patient(seed) };
    let (a, stats_a) = deliver(faults(11));
    let (b, stats_b) = deliver(faults(11));
    assert_eq!((&a, stats_a), (&b, stats_b), "same seed, same run");
    let (c, _) = deliver(faults(12));
    assert_ne!(a, c, "another seed, other faults");
}
