//! Mocap frame received → goal bearing published, end to end over real
//! sockets: the emulated lab's NatNet server streams 50 rigid bodies at
//! 120 Hz and at 240 Hz over loopback UDP; the orchestrator's NatNet pose
//! source receives each datagram, parses it, maps names, converts axes and
//! tracks every body; the moving robot's goal bearing is computed from its
//! trusted pose and published on the iceoryx2 bus as the launch sends it.
//! Latency per frame: from the datagram's arrival (the socket read
//! returning, before parsing) to the bearing's `publish` returning.
//! Prints p50, p99 and max per rate; target p50 ≤ 200 µs.
//!
//! Run: `cargo bench -p bycoms-orchestrator --bench mocap_bearing`
//! (`MOCAP_BENCH_SECONDS`, default 5, sets the duration per rate).

use bycoms_mocap::{ArenaTransform, ClientConfig, NatNetPoseSource, NatNetSourceConfig, TrackerConfig};
use bycoms_natnet_server::{BodyConfig, Faults, NatNetServer, ServerConfig};
use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::bus::BusExt;
use bycoms_protocol::msg::{GoalBearing, ToAgent};
use bycoms_protocol::{RobotId, Swarm};
use bycoms_runtime::ipc_config;
use bycoms_runtime::stats::quantile;
use bycoms_sim::Vec2;
use std::collections::BTreeMap;
use std::net::Ipv4Addr;
use std::time::{Duration, Instant};

const BODIES: usize = 50;

fn lab(rate_hz: f64) -> ServerConfig {
    ServerConfig {
        rate_hz,
        app_name: "bench".into(),
        multicast: None,
        bodies: (0..BODIES)
            .map(|k| BodyConfig {
                name: format!("robot{}", k + 1),
                id: k as i32 + 1,
                position: [0.1 * k as f32, 0.0, -0.2],
                yaw_deg: 10.0,
            })
            .collect(),
        faults: Faults::default(),
    }
}

fn measure(bus: &IpcBus, swarm: &Swarm, rate_hz: f64, seconds: f64) -> Vec<Duration> {
    let server = NatNetServer::start_any_port(lab(rate_hz), Ipv4Addr::LOCALHOST.into()).expect("server");
    let config = NatNetSourceConfig {
        client: ClientConfig {
            server: server.command_addr(),
            local: Ipv4Addr::LOCALHOST.into(),
            multicast: None,
            reply_timeout_ms: 1000,
        },
        arena: ArenaTransform { scale: 10.0, ..ArenaTransform::default() },
        bodies: (0..BODIES)
            .map(|k| (format!("robot{}", k + 1), RobotId(k as u32 + 1)))
            .collect::<BTreeMap<_, _>>(),
        tracker: TrackerConfig { max_speed: 1.5, jump_slack: 0.2, lost_after_us: 500_000 },
    };
    let mut source = NatNetPoseSource::connect(&config).expect("connect");
    let moving = RobotId(1);
    let bearings = bus.typed_publisher::<ToAgent>(&swarm.to_agent(moving)).expect("publisher");
    let robot_side = bus.typed_subscriber::<ToAgent>(&swarm.to_agent(moving)).expect("subscriber");
    let goal = Vec2::new(30.0, 10.0);
    let mut latencies = Vec::new();
    let end = Instant::now() + Duration::from_secs_f64(seconds);
    // Skip the first frames (sockets, caches, the tracker's first sighting).
    let mut warm_up = 20;
    while Instant::now() < end {
        let Some(batch) = source.poll(Duration::from_millis(200)).expect("poll") else { continue };
        let Some(pose) = batch.poses.iter().find(|p| p.robot == moving) else { continue };
        let bearing = Vec2::new(pose.x, pose.y).bearing_to(goal);
        let msg = ToAgent::GoalBearing(GoalBearing { robot: moving, bearing, step: pose.step + 1 });
        bearings.publish(&msg).expect("publish");
        let latency = source.last_frame().1.elapsed();
        assert_eq!(batch.poses.len(), BODIES, "every body trusted");
        // The robot reads its bearing (outside the measured span).
        while robot_side.try_recv().expect("recv").is_some() {}
        if warm_up > 0 {
            warm_up -= 1;
        } else {
            latencies.push(latency);
        }
    }
    latencies
}

fn main() {
    bycoms_runtime::cli::quiet_iceoryx2();
    let seconds: f64 = std::env::var("MOCAP_BENCH_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(5.0);
    let name = format!("bench-mocap-{}", std::process::id());
    let swarm = Swarm::new(&name).expect("swarm name");
    let mut cfg = ipc_config(2);
    cfg.cleans_dead_nodes = true;
    let bus = IpcBus::new(cfg).expect("iceoryx2 bus");
    println!("mocap frame received → goal bearing published ({BODIES} rigid bodies, loopback UDP, iceoryx2)");
    for rate in [120.0, 240.0] {
        let l = measure(&bus, &swarm, rate, seconds);
        assert!(!l.is_empty(), "no frames measured at {rate} Hz");
        // The runtime's one quantile (nearest rank).
        let us = |q: f64| quantile(&l, q).expect("frames measured").as_secs_f64() * 1e6;
        println!(
            "  {rate:>5} Hz: {:>5} frames  p50 {:>7.1} µs  p99 {:>7.1} µs  max {:>7.1} µs",
            l.len(),
            us(0.5),
            us(0.99),
            us(1.0),
        );
    }
}
