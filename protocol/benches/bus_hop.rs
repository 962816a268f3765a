//! One bus hop, ours against raw iceoryx2, in the same run.
//!
//! Why ping-pong: two threads of one process bounce a small message
//! (an encoded `GoalBearing`, 13 bytes) over two topics; one hop is half a
//! round trip, timed with one clock on one thread, so no clock skew enters.
//! Every variant opens its own iceoryx2 node per thread, as two processes
//! would. Figures are per-hop p50/p99/p99.9 over all samples after a
//! warm-up; the harness is hand-written (not criterion) because the
//! question is the latency distribution, not the mean.
//!
//! Variants:
//! * `raw spin`: iceoryx2 publisher/subscriber, receiver busy-polls
//!   `receive()`; the floor for any wrapper;
//! * `raw event`: iceoryx2 publisher + notifier, receiver sleeps in
//!   `Listener::timed_wait` (no spinning); the floor for a sleeping receiver;
//! * `ours ...`: `IpcBus` through the byte traits (`publish` /
//!   `recv_timeout_into`) with each wake strategy, and the typed layer
//!   (encode + decode) with the default;
//! * `memory`: the in-process backend, for reference;
//! * `fan-in of N`: the answer comes back through one fan-in over N report
//!   topics (`Bus::fan_in`), as the launch reads every robot's reports.
//!
//! Run: `cargo bench -p bycoms-protocol --features ipc --bench bus_hop`
//! (`BYCOMS_BENCH_SAMPLES=n` changes the sample count).

mod common;

use bycoms_protocol::bus::ipc::{IpcBus, IpcConfig, Wake};
use bycoms_protocol::bus::memory::MemoryBus;
use bycoms_protocol::bus::{Bus, BusExt, Limits, Publish, Subscribe};
use bycoms_protocol::{RobotId, Swarm, MAX_MESSAGE_LEN};
use common::{figures, message, names, ours, payload, ping_pong, us, WAIT, WARMUP};
use core::time::Duration;
use iceoryx2::prelude::*;
use std::sync::mpsc;
use std::time::Instant;

fn ours_typed(tag: &str, samples: usize) -> Vec<Duration> {
    let make = || IpcBus::new(IpcConfig::default()).expect("node");
    let swarm = Swarm::new(&format!("bench{}-{tag}", std::process::id())).expect("swarm");
    let (ping, pong) = (swarm.to_agent(RobotId(1)), swarm.to_agent(RobotId(2)));
    let msg = message();
    let echo = |n: usize, ready: mpsc::Sender<()>| {
        let bus = make();
        let sub = bus.typed_subscriber(&ping).expect("subscriber");
        let publ = bus.typed_publisher(&pong).expect("publisher");
        ready.send(()).expect("ready");
        for _ in 0..n {
            let m = sub.recv_timeout(WAIT).expect("recv").expect("ping lost");
            publ.publish(&m).expect("publish");
        }
    };
    let bus = make();
    let sub = bus.typed_subscriber(&pong).expect("subscriber");
    let publ = bus.typed_publisher(&ping).expect("publisher");
    ping_pong(samples, echo, |n, record| {
        for _ in 0..n {
            let t0 = Instant::now();
            publ.publish(&msg).expect("publish");
            let back = sub.recv_timeout(WAIT).expect("recv").expect("pong lost");
            record(t0.elapsed());
            assert_eq!(back, msg);
        }
    })
}

/// The orchestrator's side of a lockstep answer: the pong comes back on the
/// last of `robots` report topics, read through one fan-in over all of
/// them (`Bus::fan_in`, as the launch reads every robot's reports).
fn ours_fan_in(tag: &str, robots: u32, samples: usize) -> Vec<Duration> {
    let make = || {
        IpcBus::new(IpcConfig { max_publishers: robots as usize + 4, ..IpcConfig::default() }).expect("node")
    };
    let swarm = Swarm::new(&format!("bench{}-{tag}", std::process::id())).expect("swarm");
    let ping = *swarm.to_agent(RobotId(robots)).name();
    let reports: Vec<_> = (1..=robots).map(|k| *swarm.from_agent(RobotId(k)).name()).collect();
    let pong = reports[robots as usize - 1];
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
    let fan_in = bus.fan_in(&reports).expect("fan-in");
    let publ = bus.publisher(&ping).expect("publisher");
    ping_pong(samples, echo, |n, record| {
        let mut buf = [0u8; MAX_MESSAGE_LEN + bycoms_protocol::bus::FAN_IN_TAG];
        for _ in 0..n {
            let t0 = Instant::now();
            publ.publish(&payload).expect("publish");
            fan_in.recv_timeout_into(&mut buf, WAIT).expect("recv").expect("pong lost");
            record(t0.elapsed());
        }
    })
}

/// Raw iceoryx2 ports of one node: what the wrapper is compared with.
struct RawPorts {
    publisher: iceoryx2::port::publisher::Publisher<ipc::Service, [u8], ()>,
    subscriber: iceoryx2::port::subscriber::Subscriber<ipc::Service, [u8], ()>,
    notifier: Option<iceoryx2::port::notifier::Notifier<ipc::Service>>,
    listener: Option<iceoryx2::port::listener::Listener<ipc::Service>>,
    _node: Node<ipc::Service>,
}

fn raw_ports(send: &str, recv: &str, event: bool) -> RawPorts {
    let node = NodeBuilder::new()
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .expect("node");
    let pubsub = |name: &str| {
        node.service_builder(&ServiceName::new(name).expect("name"))
            .publish_subscribe::<[u8]>()
            .history_size(0)
            .subscriber_max_buffer_size(64)
            .open_or_create()
            .expect("service")
    };
    let events = |name: &str| {
        node.service_builder(&ServiceName::new(name).expect("name"))
            .event()
            .open_or_create()
            .expect("event service")
    };
    let publisher = pubsub(send)
        .publisher_builder()
        .initial_max_slice_len(256)
        .allocation_strategy(AllocationStrategy::Static)
        .create()
        .expect("publisher");
    let subscriber = pubsub(recv).subscriber_builder().buffer_size(64).create().expect("subscriber");
    let (notifier, listener) = if event {
        (
            Some(events(send).notifier_builder().create().expect("notifier")),
            Some(events(recv).listener_builder().create().expect("listener")),
        )
    } else {
        (None, None)
    };
    RawPorts { publisher, subscriber, notifier, listener, _node: node }
}

impl RawPorts {
    fn send(&self, bytes: &[u8]) {
        let sample = self.publisher.loan_slice_uninit(bytes.len()).expect("loan");
        sample.write_from_slice(bytes).send().expect("send");
        if let Some(n) = &self.notifier {
            n.notify().expect("notify");
        }
    }

    fn recv(&self, buf: &mut [u8]) -> usize {
        let deadline = Instant::now() + WAIT;
        loop {
            if let Some(sample) = self.subscriber.receive().expect("receive") {
                let p = sample.payload();
                buf[..p.len()].copy_from_slice(p);
                return p.len();
            }
            assert!(Instant::now() < deadline, "raw message lost");
            match &self.listener {
                Some(l) => {
                    l.timed_wait(|_| {}, WAIT).expect("wait");
                }
                None => core::hint::spin_loop(),
            }
        }
    }
}

fn raw(tag: &str, event: bool, samples: usize) -> Vec<Duration> {
    let (ping, pong) = names(tag);
    let payload = payload();
    let echo = |n: usize, ready: mpsc::Sender<()>| {
        let ports = raw_ports(&pong, &ping, event);
        ready.send(()).expect("ready");
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        for _ in 0..n {
            let len = ports.recv(&mut buf);
            ports.send(&buf[..len]);
        }
    };
    let ports = raw_ports(&ping, &pong, event);
    ping_pong(samples, echo, |n, record| {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        for _ in 0..n {
            let t0 = Instant::now();
            ports.send(&payload);
            ports.recv(&mut buf);
            record(t0.elapsed());
        }
    })
}

fn main() {
    let samples =
        std::env::var("BYCOMS_BENCH_SAMPLES").ok().and_then(|v| v.parse().ok()).unwrap_or(50_000usize);
    let ipc_with =
        |wake: Wake| move || IpcBus::new(IpcConfig { wake, ..IpcConfig::default() }).expect("node");
    let event_spin = ipc_with(Wake::default());
    let event_nospin = ipc_with(Wake::Event { spin: Duration::ZERO });
    let poll = ipc_with(Wake::Poll { spin: Duration::from_micros(20), max_sleep: Duration::from_millis(1) });
    let memory = MemoryBus::new(Limits::default()).expect("limits");
    let memory = || memory.clone();

    println!("bus hop latency, one way = round trip / 2, {samples} samples after {WARMUP} warm-up, 13-byte message");
    let rows: Vec<(&str, Vec<Duration>)> = vec![
        ("raw iceoryx2, spin", raw("raw-spin", false, samples)),
        ("ours IpcBus, Event spin 20us (default)", ours(&event_spin, "ev", samples)),
        ("ours IpcBus typed, Event spin 20us", ours_typed("typed", samples)),
        ("ours IpcBus, Poll spin 20us", ours(&poll, "poll", samples)),
        ("raw iceoryx2, event wait (no spin)", raw("raw-ev", true, samples)),
        ("ours IpcBus, Event spin 0", ours(&event_nospin, "ev0", samples)),
        ("ours MemoryBus", ours(&memory, "mem", samples)),
        ("ours IpcBus, back through a fan-in of 3", ours_fan_in("fan3", 3, samples)),
        ("ours IpcBus, back through a fan-in of 100", ours_fan_in("fan100", 100, samples)),
        ("ours IpcBus, back through a fan-in of 1000", ours_fan_in("fan1000", 1000, samples / 10)),
        // The first row again, to expose drift (CPU frequency, other load).
        ("raw iceoryx2, spin (repeat)", raw("raw-spin2", false, samples)),
    ];
    println!("{:<42} {:>9} {:>9} {:>9}", "variant", "p50 us", "p99 us", "p99.9 us");
    let mut table = Vec::new();
    for (name, hops) in rows {
        let f = figures(hops);
        println!("{name:<42} {:>9.2} {:>9.2} {:>9.2}", us(f.p50), us(f.p99), us(f.p999));
        table.push((name, f));
    }
    let ratio = |a: usize, b: usize| us(table[a].1.p50) / us(table[b].1.p50).max(1e-9);
    println!("ours default / raw spin, p50: {:.2}x", ratio(1, 0));
    println!("ours typed / raw spin, p50: {:.2}x", ratio(2, 0));
    println!("ours spin 0 / raw event, p50: {:.2}x", ratio(5, 4));
    println!("fan-in of 3 / ours default, p50: {:.2}x", ratio(7, 1));
    println!("fan-in of 100 / ours default, p50: {:.2}x", ratio(8, 1));
    println!("fan-in of 1000 / ours default, p50: {:.2}x", ratio(9, 1));
}
