//! `orchestrator bridge`: republish a local iceoryx2 swarm on zenoh, so a
//! launch on this host can be watched from another one without changing
//! its agents.
//!
//! Why our own bridge and not iceoryx2's tunnel crates: the newest
//! `iceoryx2-tunnel-zenoh` (0.8.1) is built on iceoryx2 0.8 while this
//! workspace uses iceoryx2 0.10, and services of different iceoryx2
//! releases cannot see each other; the tunnel also mirrors services under
//! its own key scheme, whereas a watcher here subscribes to the protocol's
//! names (`bycoms/<swarm>/**`, `protocol/PROTOCOL.md`). This bridge is a
//! loop over the bus traits: one iceoryx2 fan-in per kind of topic (every
//! robot's poses, commands, reports, sensor data; the gate) and one zenoh
//! publisher per topic, bytes copied unchanged. Why fan-ins: a robot's
//! topics of one kind share one wake-up service on iceoryx2
//! (`TopicName::doorbell`) with room for a listener per robot plus a few,
//! so a bridge listening per topic would not fit, nor would its open files
//! at a thousand robots.
//!
//! Direction: iceoryx2 → zenoh only (watching). Joining from another host
//! (zenoh → iceoryx2) needs loop suppression and is left to the launch's
//! zenoh transport.
//!
//! Pacing: iceoryx2 has no wildcard subscription, so the loop polls every
//! fan-in (each reads only the topics that rang), and sleeps 1 ms after a
//! round that moved nothing. A message may
//! thus wait up to ~1 ms; a lockstep burst faster than the bridge drains
//! loses the oldest samples of a topic past its buffer (64), like any slow
//! iceoryx2 subscriber — the launch itself never waits for the bridge.

use anyhow::{Context, Result};
use bycoms_launch::config::{check_endpoints, check_robot_count, check_swarm};
use bycoms_launch::interrupt_flag;
use bycoms_protocol::bus::ipc::{IpcBus, IpcFanIn};
use bycoms_protocol::bus::zenoh::{Congestion, Mode, ZenohBus, ZenohConfig, ZenohPublisher};
use bycoms_protocol::bus::{untag, Bus, Limits, Publish, Subscribe, FAN_IN_TAG};
use bycoms_protocol::{RobotId, Swarm, TopicName, MAX_MESSAGE_LEN};
use bycoms_runtime::exit;
use bycoms_runtime::ipc_config;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Republish a local (iceoryx2) swarm on zenoh for watchers on other hosts.
///
/// Start it before `orchestrator launch --swarm NAME --robots N` with the
/// same name and robot count (iceoryx2 services are sized by the robot
/// count); then connect e.g. `deploy/clients/watch.py --connect
/// tcp/THIS_HOST:7447 --swarm NAME`. Runs until Ctrl-C or --duration.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The launch's swarm name.
    #[arg(long)]
    pub swarm: String,
    /// The launch's robot count (robots 1..=N are bridged).
    #[arg(long, default_value_t = 3)]
    pub robots: u32,
    /// zenoh endpoint(s) to listen on (router mode: the rendezvous).
    #[arg(long, value_name = "ENDPOINT", default_value = "tcp/0.0.0.0:7447")]
    pub listen: Vec<String>,
    /// zenoh endpoint(s) to connect to, e.g. a lab router.
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// zenoh JSON5 config read first (TLS, access control; deploy/zenoh/).
    #[arg(long, value_name = "FILE.json5")]
    pub zenoh_config: Option<PathBuf>,
    /// Stop after this many seconds [default: until Ctrl-C].
    #[arg(long, value_name = "SECONDS", value_parser = bycoms_runtime::seconds::seconds)]
    pub duration: Option<f64>,
}

/// One bridged kind of topic: a fan-in of its topics, and a zenoh
/// publisher per topic (in the fan-in's order).
struct Lane {
    from: IpcFanIn<iceoryx2::prelude::ipc::Service>,
    to: Vec<(TopicName, ZenohPublisher)>,
    forwarded: u64,
}

/// The swarm's topics, one kind per lane: the gate, then every robot's
/// poses, commands, reports and sensor data.
fn kinds(swarm: &Swarm, robots: u32) -> Vec<Vec<TopicName>> {
    let each = |f: &dyn Fn(RobotId) -> TopicName| (1..=robots).map(|k| f(RobotId(k))).collect();
    vec![
        vec![*swarm.gate().name()],
        each(&|r| *swarm.pose(r).name()),
        each(&|r| *swarm.to_agent(r).name()),
        each(&|r| *swarm.from_agent(r).name()),
        each(&|r| *swarm.sensor(r).name()),
    ]
}

pub fn run(args: Args) -> Result<i32> {
    let swarm = check_swarm(&args.swarm)?;
    check_endpoints("--listen", &args.listen)?;
    check_endpoints("--connect", &args.connect)?;
    check_robot_count("--robots", args.robots)?;
    // In range: the value parser's one check of seconds.
    let duration = args.duration.map(Duration::from_secs_f64);
    bycoms_runtime::cli::quiet_iceoryx2();
    let mut ipc = ipc_config(args.robots);
    ipc.node_name = Some(format!("bycoms-{}-bridge", args.swarm));
    let local = IpcBus::new(ipc).context("cannot open the iceoryx2 bus")?;
    let remote = ZenohBus::open(ZenohConfig {
        limits: Limits { max_payload: MAX_MESSAGE_LEN, buffer: 64 },
        mode: Mode::Router,
        listen: args.listen.clone(),
        connect: args.connect.clone(),
        base_config: args.zenoh_config.clone(),
        // A slow watcher stalls the bridge, never the launch; iceoryx2
        // then drops the oldest local samples of busy topics (poses),
        // while rare ones (gate events) still get through.
        congestion: Congestion::Block,
        ..ZenohConfig::default()
    })
    .context("cannot open the zenoh session")?;
    let mut lanes = Vec::new();
    for topics in kinds(&swarm, args.robots) {
        let kind = topics.first().map(TopicName::doorbell);
        let kind = kind.as_ref().map_or("", TopicName::as_str);
        let from = local.fan_in(&topics).with_context(|| format!("cannot subscribe to {kind} (iceoryx2)"))?;
        let to = topics
            .into_iter()
            .map(|topic| {
                let publisher =
                    remote.publisher(&topic).with_context(|| format!("cannot publish {topic} (zenoh)"))?;
                Ok((topic, publisher))
            })
            .collect::<Result<Vec<_>>>()?;
        lanes.push(Lane { from, to, forwarded: 0 });
    }
    bycoms_runtime::logging::status_line(&format!(
        "bridge: bycoms/{}/** (robots 1..={}) from iceoryx2 to zenoh, listening on {}",
        args.swarm,
        args.robots,
        args.listen.join(", ")
    ));
    let stop = interrupt_flag();
    let started = Instant::now();
    let mut buf = [0u8; MAX_MESSAGE_LEN + FAN_IN_TAG];
    while !stop.load(Ordering::SeqCst) && duration.is_none_or(|d| started.elapsed() < d) {
        let mut moved = false;
        for lane in &mut lanes {
            while let Some(n) = lane.from.try_recv_into(&mut buf).context("receive from iceoryx2")? {
                let Some((index, payload)) = untag(&buf[..n]) else { continue };
                let Some((topic, to)) = lane.to.get(index) else { continue };
                to.publish(payload).with_context(|| format!("republish {topic}"))?;
                lane.forwarded += 1;
                moved = true;
            }
        }
        if !moved {
            std::thread::sleep(Duration::from_millis(1));
        }
    }
    let total: u64 = lanes.iter().map(|l| l.forwarded).sum();
    bycoms_runtime::logging::status_line(&format!("bridge: forwarded {total} messages"));
    Ok(if stop.load(Ordering::SeqCst) { exit::INTERRUPTED } else { exit::SUCCESS })
}
