//! A zenoh bus peer for the network-namespace tests and benchmark
//! (`tests/src/netns.rs`): it plays the orchestrator or one agent on its
//! "host", declares that member's liveliness token, watches the swarm's
//! tokens, and optionally publishes a counter and/or prints the counters
//! it receives. Everything it sees goes to stdout as one JSON object per
//! line, stamped with `CLOCK_MONOTONIC` (shared by all namespaces), so the
//! test can time what happened on the other host against its own actions.
//!
//! Why a binary of its own: a process belongs to one network namespace,
//! so each "host" needs its own process; the real `orchestrator` and
//! `sim-agent` run the gate and robots on top, which these tests of the
//! link and its liveliness do not need.

use bycoms_protocol::bus::zenoh::{Liveness, Mode, Presence, ZenohBus, ZenohConfig};
use bycoms_protocol::bus::{Bus as _, Publish as _, Subscribe as _};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{RobotId, Swarm, TopicName};
use clap::Parser;
use std::io::Write as _;
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(about = "zenoh peer for the netns tests: liveliness + a counter, JSON lines on stdout")]
struct Args {
    /// Swarm name.
    #[arg(long)]
    swarm: String,
    /// `orchestrator` or a robot id (this process's liveliness token).
    #[arg(long)]
    member: String,
    /// Router (the rendezvous) or peer.
    #[arg(long, default_value = "peer")]
    mode: String,
    /// Endpoints to listen on.
    #[arg(long)]
    listen: Vec<String>,
    /// Endpoints to connect to.
    #[arg(long)]
    connect: Vec<String>,
    /// Publish a counter (u64, little-endian) every this many ms.
    #[arg(long)]
    publish_every_ms: Option<u64>,
    /// Print the counters received.
    #[arg(long)]
    subscribe: bool,
    /// Exit after this many seconds at the latest (never outlive a test).
    #[arg(long, default_value_t = 120)]
    max_seconds: u64,
}

fn mono_ns() -> u128 {
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC)
        .map(|t| Duration::from(t).as_nanos())
        .unwrap_or(0)
}

/// `CLOCK_MONOTONIC` of an earlier instant.
fn mono_of(at: Instant) -> u128 {
    mono_ns().saturating_sub(at.elapsed().as_nanos())
}

fn line(value: serde_json::Value) {
    let mut out = std::io::stdout().lock();
    // A closed stdout means the test is gone; the deadline ends us then.
    let _ = writeln!(out, "{value}");
    let _ = out.flush();
}

fn member_name(m: Member) -> String {
    match m {
        Member::Orchestrator => "orchestrator".into(),
        Member::Agent(id) => id.0.to_string(),
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let swarm = Swarm::new(&args.swarm)?;
    let member = match args.member.as_str() {
        "orchestrator" => Member::Orchestrator,
        id => Member::Agent(RobotId(id.parse().map_err(|e| format!("--member {id}: {e}"))?)),
    };
    let mode = match args.mode.as_str() {
        "router" => Mode::Router,
        "peer" => Mode::Peer,
        other => return Err(format!("--mode {other}: router or peer").into()),
    };
    let bus = ZenohBus::open(ZenohConfig {
        mode,
        listen: args.listen,
        connect: args.connect,
        liveness: Some(Liveness::FAST),
        ..ZenohConfig::default()
    })?;
    let counter = TopicName::parse(&format!("bycoms/{}/netns/counter", swarm.as_str()))?;
    let watch = bus.watch_alive(&swarm)?;
    let _token = bus.declare_alive(&swarm, member)?;
    let publisher = args.publish_every_ms.map(|_| bus.publisher(&counter)).transpose()?;
    let subscriber = if args.subscribe { Some(bus.subscriber(&counter)?) } else { None };
    line(serde_json::json!({"event": "ready", "mono_ns": mono_ns()}));

    let end = Instant::now() + Duration::from_secs(args.max_seconds);
    let period = Duration::from_millis(args.publish_every_ms.unwrap_or(u64::MAX / 4));
    let mut next_publish = Instant::now();
    let mut seq: u64 = 0;
    let mut buf = [0u8; 64];
    while Instant::now() < end {
        while let Some(e) = watch.try_recv() {
            let event = if e.presence == Presence::Alive { "alive" } else { "lost" };
            line(
                serde_json::json!({"event": event, "member": member_name(e.member), "mono_ns": mono_of(e.at)}),
            );
        }
        if let Some(sub) = &subscriber {
            while let Some(n) = sub.try_recv_into(&mut buf)? {
                let Some(bytes) = buf.get(..n).and_then(|b| <[u8; 8]>::try_from(b).ok()) else { continue };
                line(
                    serde_json::json!({"event": "msg", "seq": u64::from_le_bytes(bytes), "mono_ns": mono_ns()}),
                );
            }
        }
        if let Some(p) = &publisher {
            if Instant::now() >= next_publish {
                p.publish(&seq.to_le_bytes())?;
                seq += 1;
                next_publish += period;
            }
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    Ok(())
}
