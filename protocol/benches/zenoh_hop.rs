//! One bus hop over zenoh on loopback, ours against raw zenoh in the same
//! run, and the time to join: session open + first delivered message.
//!
//! Hop: the same ping-pong as `bus_hop` (see `common`): two threads, each
//! with its own zenoh session as two hosts would have: a router listening
//! on a loopback tcp port and a peer connected to it. One hop = round trip
//! / 2 over the tcp link, timed on one thread's clock.
//!
//! Variants, all in the runtime our binaries use
//! (`bus::zenoh::tune_runtime`, unless `ZENOH_RUNTIME` is set) and on the
//! low-latency transport our sessions offer (`ZenohConfig::low_latency`):
//! * `raw zenoh`: declared publishers (express, as ours) and subscribers
//!   with zenoh's default FIFO channel handler, `recv_timeout`; the floor;
//! * `ours ZenohBus`: the byte traits (`publish` / `recv_timeout_into`);
//!   the typed layer adds the same encode + decode as in `bus_hop`;
//! * `raw zenoh (repeat)`: the first row again, to expose drift;
//! * the same two on zenoh's standard (batching) transport, for comparison.
//!
//! Join: from `ZenohBus::open` of a peer that connects to a running router
//! to the first message it published being received by the router's
//! subscriber (the peer republishes every 1 ms until then), with our
//! configuration and with zenoh's default scouting delay.
//!
//! Run: `cargo bench -p bycoms-protocol --features zenoh --bench zenoh_hop`
//! (`BYCOMS_BENCH_SAMPLES=n` changes the sample count).

mod common;

use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
use bycoms_protocol::bus::{Bus, Publish, Subscribe};
use bycoms_protocol::{TopicName, MAX_MESSAGE_LEN};
use common::{figures, names, payload, ping_pong, us, WAIT};
use core::time::Duration;
use std::sync::mpsc;
use std::time::Instant;
use zenoh::Wait as _;

/// A router on a free loopback port and its endpoint.
fn router(low_latency: bool) -> (ZenohBus, String) {
    let config = |endpoint: &str| ZenohConfig {
        mode: Mode::Router,
        listen: vec![endpoint.to_owned()],
        low_latency,
        ..ZenohConfig::default()
    };
    ZenohBus::loopback_router(config).expect("a router on a free loopback port")
}

fn peer_config(endpoint: &str, low_latency: bool) -> ZenohConfig {
    ZenohConfig {
        mode: Mode::Peer,
        connect: vec![endpoint.to_owned()],
        low_latency,
        ..ZenohConfig::default()
    }
}

/// Hands out the router's bus to the first caller and a connected peer to
/// the next: the two sides of the ping-pong.
fn two_hosts(low_latency: bool) -> impl Fn() -> ZenohBus + Sync {
    let (router, endpoint) = router(low_latency);
    let taken = std::sync::Mutex::new(Some(router));
    move || match taken.lock().map(|mut t| t.take()) {
        Ok(Some(router)) => router,
        _ => ZenohBus::open(peer_config(&endpoint, low_latency)).expect("peer"),
    }
}

/// One side of a ping-pong: send a payload, receive one (with a timeout).
struct Side {
    send: SendFn,
    recv: RecvFn,
}

type SendFn = Box<dyn Fn(&[u8]) + Send>;
type RecvFn = Box<dyn Fn(&mut [u8], Duration) -> Option<usize> + Send>;

/// The raw zenoh side: a declared publisher (express, as ours) and a
/// subscriber with zenoh's default FIFO channel handler.
fn raw_side(bus: &ZenohBus, send: &str, recv: &str) -> Side {
    let s = bus.session();
    let publ = s.declare_publisher(send.to_owned()).express(true).wait().expect("publisher");
    let sub = s.declare_subscriber(recv.to_owned()).wait().expect("subscriber");
    Side {
        send: Box::new(move |bytes| publ.put(bytes).wait().expect("put")),
        recv: Box::new(move |buf, timeout| {
            let sample = sub.recv_timeout(timeout).expect("recv")?;
            let bytes = sample.payload().to_bytes();
            buf[..bytes.len()].copy_from_slice(&bytes);
            Some(bytes.len())
        }),
    }
}

/// Our side: the bus's byte traits.
fn ours_side(bus: &ZenohBus, send: &str, recv: &str) -> Side {
    let publ = bus.publisher(&TopicName::parse(send).expect("topic")).expect("publisher");
    let sub = bus.subscriber(&TopicName::parse(recv).expect("topic")).expect("subscriber");
    Side {
        send: Box::new(move |bytes| publ.publish(bytes).expect("publish")),
        recv: Box::new(move |buf, timeout| sub.recv_timeout_into(buf, timeout).expect("recv")),
    }
}

/// Ping-pong between a router and a peer session; `side` builds each end.
/// Declarations travel asynchronously, so the first ping is re-sent until
/// one comes back (outside the clock); an empty payload stops the echo.
fn hop(
    tag: &str,
    samples: usize,
    low_latency: bool,
    side: fn(&ZenohBus, &str, &str) -> Side,
) -> Vec<Duration> {
    let make = two_hosts(low_latency);
    let (ping, pong) = names(tag);
    let payload = payload();
    let echo = |_: usize, ready: mpsc::Sender<()>| {
        let bus = make();
        let far = side(&bus, &pong, &ping);
        ready.send(()).expect("ready");
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        loop {
            match (far.recv)(&mut buf, WAIT) {
                Some(0) => break,
                Some(n) => (far.send)(&buf[..n]),
                None => panic!("ping lost"),
            }
        }
    };
    let bus = make();
    let near = side(&bus, &ping, &pong);
    ping_pong(samples, echo, |n, record| {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        let deadline = Instant::now() + WAIT;
        loop {
            (near.send)(&payload);
            if (near.recv)(&mut buf, Duration::from_millis(200)).is_some() {
                break;
            }
            assert!(Instant::now() < deadline, "no route within {WAIT:?}");
        }
        for _ in 1..n {
            let t0 = Instant::now();
            (near.send)(&payload);
            (near.recv)(&mut buf, WAIT).expect("pong lost");
            record(t0.elapsed());
        }
        (near.send)(&[]);
    })
}

/// Milliseconds from opening a peer to its first message arriving at the
/// router, `reps` times; the router and its subscriber are up first.
fn join(reps: usize, scouting_delay_ms: Option<u64>) -> Vec<Duration> {
    let (router, endpoint) = router(true);
    let topic = TopicName::parse(&format!("bycoms/bench{}-join/gate", std::process::id())).expect("topic");
    let sub = router.subscriber(&topic).expect("subscriber");
    (0..reps)
        .map(|_| {
            let t0 = Instant::now();
            let peer = match scouting_delay_ms {
                None => ZenohBus::open(peer_config(&endpoint, true)).expect("peer"),
                Some(ms) => {
                    let mut z = peer_config(&endpoint, true).to_zenoh().expect("config");
                    z.insert_json5("scouting/delay", &ms.to_string()).expect("delay");
                    let session = zenoh::open(z).wait().expect("peer");
                    let publ = session.declare_publisher(topic.as_str().to_owned()).wait().expect("pub");
                    while sub.recv_timeout(Duration::from_millis(1)).expect("recv").is_none() {
                        publ.put(&b"hello"[..]).wait().expect("put");
                        assert!(t0.elapsed() < WAIT, "no first message within {WAIT:?}");
                    }
                    while sub.try_recv().expect("drain").is_some() {}
                    return t0.elapsed();
                }
            };
            let publ = peer.publisher(&topic).expect("publisher");
            while sub.recv_timeout(Duration::from_millis(1)).expect("recv").is_none() {
                publ.publish(b"hello").expect("publish");
                assert!(t0.elapsed() < WAIT, "no first message within {WAIT:?}");
            }
            let took = t0.elapsed();
            while sub.try_recv().expect("drain").is_some() {}
            took
        })
        .collect()
}

fn main() {
    bycoms_protocol::bus::zenoh::tune_runtime();
    let samples =
        std::env::var("BYCOMS_BENCH_SAMPLES").ok().and_then(|v| v.parse().ok()).unwrap_or(20_000usize);
    println!(
        "zenoh hop latency over tcp loopback, router <-> peer, one way = round trip / 2, {samples} samples"
    );
    let runtime = std::env::var("ZENOH_RUNTIME").unwrap_or_default();
    println!("ZENOH_RUNTIME={runtime}; low-latency transport unless the row says otherwise");
    let rows: Vec<(&str, Vec<Duration>)> = vec![
        ("raw zenoh, FIFO handler", hop("zraw", samples, true, raw_side)),
        ("ours ZenohBus", hop("zours", samples, true, ours_side)),
        ("raw zenoh, FIFO handler (repeat)", hop("zraw2", samples, true, raw_side)),
        ("raw zenoh, standard transport", hop("zrawstd", samples, false, raw_side)),
        ("ours ZenohBus, standard transport", hop("zoursstd", samples, false, ours_side)),
    ];
    println!("{:<42} {:>9} {:>9} {:>9}", "variant", "p50 us", "p99 us", "p99.9 us");
    let mut table = Vec::new();
    for (name, hops) in rows {
        let f = figures(hops);
        println!("{name:<42} {:>9.2} {:>9.2} {:>9.2}", us(f.p50), us(f.p99), us(f.p999));
        table.push(f);
    }
    let p50 = |i: usize| us(table[i].p50);
    let raw = p50(0).max(p50(2));
    println!(
        "ours / raw, p50: {:.2}x (against the slower raw run; raw runs {:.2} / {:.2} us)",
        p50(1) / raw,
        p50(0),
        p50(2)
    );

    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!("join: peer open -> first message at the router (ms), median / max");
    for (name, delay, reps) in
        [("ours (scouting delay 0)", None, 20), ("zenoh default scouting delay 500 ms", Some(500), 3)]
    {
        let t = join(reps, delay);
        let at = |q: f64| bycoms_runtime::stats::quantile(&t, q).unwrap_or_default();
        let (median, max) = (at(0.5), at(1.0));
        println!("{name:<42} {:>9.2} {:>9.2}  ({reps} runs)", ms(median), ms(max));
    }
}
