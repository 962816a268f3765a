//! The ping-pong harness and percentile figures shared by the hop
//! benchmarks (`bus_hop`, `zenoh_hop`), so both measure the same way.
#![allow(dead_code)]

use bycoms_protocol::bus::{Bus, Publish, Subscribe};
use bycoms_protocol::msg::{GoalBearing, ToAgent};
use bycoms_protocol::{encode, RobotId, TopicName, MAX_MESSAGE_LEN};
use core::time::Duration;
use std::sync::mpsc;
use std::time::Instant;

pub const WAIT: Duration = Duration::from_secs(5);
pub const WARMUP: usize = 2_000;

pub fn message() -> ToAgent {
    ToAgent::GoalBearing(GoalBearing { robot: RobotId(1), bearing: 0.785, step: 42 })
}

pub fn payload() -> Vec<u8> {
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    encode(&message(), &mut buf).map(<[u8]>::to_vec).unwrap_or_default()
}

pub fn names(tag: &str) -> (String, String) {
    let base = format!("bycoms/bench{}-{tag}", std::process::id());
    (format!("{base}/ping"), format!("{base}/pong"))
}

/// Runs `echo` on a second thread and `round_trip` `WARMUP + samples`
/// times on this one; returns the per-hop latencies (round trip / 2).
pub fn ping_pong<E, R>(samples: usize, echo: E, round_trip: R) -> Vec<Duration>
where
    E: FnOnce(usize, mpsc::Sender<()>) + Send,
    R: FnOnce(usize, &mut dyn FnMut(Duration)),
{
    let total = WARMUP + samples;
    let (ready_tx, ready_rx) = mpsc::channel();
    let mut hops = Vec::with_capacity(total);
    std::thread::scope(|s| {
        s.spawn(move || echo(total, ready_tx));
        if ready_rx.recv_timeout(WAIT).is_err() {
            panic!("echo thread did not start");
        }
        round_trip(total, &mut |rtt| hops.push(rtt / 2));
    });
    hops.split_off(WARMUP.min(hops.len()))
}

pub struct Figures {
    pub p50: Duration,
    pub p99: Duration,
    pub p999: Duration,
}

/// The hops' quantiles, by the workspace's one rule (`bycoms_runtime::stats`).
pub fn figures(hops: Vec<Duration>) -> Figures {
    let at = |q: f64| bycoms_runtime::stats::quantile(&hops, q).unwrap_or_default();
    Figures { p50: at(0.50), p99: at(0.99), p999: at(0.999) }
}

pub fn us(d: Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

/// Ping-pong through the byte traits of any bus; `make` is called once per
/// thread (each side gets its own bus, as two processes would).
pub fn ours<B: Bus, F: Fn() -> B + Sync>(make: &F, tag: &str, samples: usize) -> Vec<Duration> {
    let (ping, pong) = names(tag);
    let ping = TopicName::parse(&ping).expect("topic");
    let pong = TopicName::parse(&pong).expect("topic");
    let payload = payload();
    let echo = |n: usize, ready: mpsc::Sender<()>| {
        let bus = make();
        let sub = bus.subscriber(&ping).expect("subscriber");
        let publ = bus.publisher(&pong).expect("publisher");
        ready.send(()).expect("ready");
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        for _ in 0..n {
            let len = sub.recv_timeout_into(&mut buf, WAIT).expect("recv").expect("ping lost");
            publ.publish(&buf[..len]).expect("publish");
        }
    };
    let bus = make();
    let sub = bus.subscriber(&pong).expect("subscriber");
    let publ = bus.publisher(&ping).expect("publisher");
    ping_pong(samples, echo, |n, record| {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        for _ in 0..n {
            let t0 = Instant::now();
            publ.publish(&payload).expect("publish");
            sub.recv_timeout_into(&mut buf, WAIT).expect("recv").expect("pong lost");
            record(t0.elapsed());
        }
    })
}
