//! `gateway bench`: the gateway's added latency, robot frame in → bus out.
//!
//! Why in one process with real sockets and the real bus: the figure must
//! include everything the gateway adds — the UDP receive, the link checks
//! (HMAC), the decode and the iceoryx2 publish — and nothing the bench
//! invents. A robot (the link's `RobotLink` on its own UDP socket) sends one
//! telemetry frame at a time to a gateway running its real loop on a
//! thread; the bench waits for the frame's `Telemetry` on the robot's `from_agent`.
//! Two figures come out: the gateway's own time (socket receive returned →
//! bus messages published, measured inside its loop) and the end-to-end
//! time (robot send → bus subscriber woken), which adds one loopback UDP
//! hop and one bus hop.

use super::core::{GatewayCore, Timers};
use super::run::{Gateway, GatewayPorts};
use anyhow::{bail, Context};
use bycoms_protocol::bus::ipc::{IpcBus, IpcConfig};
use bycoms_protocol::bus::BusExt;
use bycoms_protocol::link::{
    Health, LinkKey, Payload, RobotEvent, RobotLink, RobotState, Telemetry, MAX_FRAME_LEN,
};
use bycoms_protocol::msg::{FromAgent, ToAgent};
use bycoms_protocol::{RobotId, Swarm};
use bycoms_runtime::stats::quantile;
use bycoms_runtime::{ipc_config, Epoch, Lifeline};
use std::net::UdpSocket;
use std::time::{Duration, Instant};

/// Measure the gateway's added latency: robot frame in → bus message out.
///
/// A robot on its own UDP socket sends telemetry frames, one at a time, to
/// a gateway running its real loop on a thread in this process over
/// iceoryx2; prints the gateway's own time (socket receive → bus publish)
/// and the end-to-end time (robot send → bus subscriber woken), p50/p99.
#[derive(Clone, Debug, PartialEq, Eq, clap::Args)]
pub struct BenchArgs {
    /// Telemetry frames to relay (at least 1: no frame, no figure).
    #[arg(long, default_value_t = 2000, value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: u32,
    /// Pause between frames, ms.
    #[arg(long, default_value_t = 2, value_parser = bycoms_runtime::seconds::millis_or_zero)]
    pub interval_ms: u64,
}

fn frame(step: u32) -> Payload {
    Payload::Telemetry(Telemetry {
        step,
        state: RobotState::Driving,
        mode: 1,
        mics: [1000.0; 6],
        v_ave: 1000.0,
        gradient: Some(0.5),
        left: 100.0,
        right: 120.0,
        battery_mv: 7400,
        health: Health(0),
        link_drops: 0,
    })
}

/// Runs the bench and prints its figures.
pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let swarm = Swarm::new(&format!("gwbench{}", std::process::id()))?;
    let key = LinkKey::new(&[0x42; 32]);
    let gw_socket = UdpSocket::bind(("127.0.0.1", 0))?;
    let gw_addr = gw_socket.local_addr()?;
    let (gw_swarm, gw_key) = (swarm, key.clone());
    let gateway = std::thread::spawn(move || -> anyhow::Result<Vec<u64>> {
        let config = IpcConfig { node_name: Some("bycoms-gwbench-gateway".into()), ..ipc_config(1) };
        let bus = IpcBus::new(config)?;
        let ports = GatewayPorts::open(&bus, &gw_swarm, RobotId(1))?;
        let epoch = Epoch::now();
        let core = GatewayCore::new(RobotId(1), gw_key, Timers::paper(1.0), 1, epoch.elapsed());
        let mut gw = Gateway::new(core, ports, gw_socket, Duration::from_millis(100), None, epoch)?;
        gw.run(&mut Lifeline::detached())?;
        Ok(gw.stats().relay_ns.clone())
    });
    let config = IpcConfig { node_name: Some("bycoms-gwbench".into()), ..ipc_config(1) };
    let bus = IpcBus::new(config)?;
    let reports = bus.typed_subscriber::<FromAgent>(&swarm.from_agent(RobotId(1)))?;
    let commands = bus.typed_publisher::<ToAgent>(&swarm.to_agent(RobotId(1)))?;
    let robot_socket = UdpSocket::bind(("127.0.0.1", 0))?;
    robot_socket.set_read_timeout(Some(Duration::from_secs(2)))?;
    let mut robot = RobotLink::new(RobotId(1), key);
    let mut buf = [0u8; MAX_FRAME_LEN];
    robot_socket.send_to(robot.hello([7; 16], &mut buf)?, gw_addr)?;
    let mut rx = [0u8; 256];
    let (n, _) = robot_socket.recv_from(&mut rx).context("no welcome from the gateway")?;
    if !matches!(robot.receive(&rx[..n]), Ok(RobotEvent::Connected(_))) {
        bail!("the gateway's answer is not a welcome");
    }
    robot_socket.set_nonblocking(true)?;
    let mut end_to_end = Vec::with_capacity(args.frames as usize);
    for step in 1..=args.frames {
        while robot_socket.recv_from(&mut rx).is_ok() {} // gateway heartbeats
        let bytes = robot.send(frame(step), &mut buf)?.to_vec();
        let sent = Instant::now();
        robot_socket.send_to(&bytes, gw_addr)?;
        let deadline = sent + Duration::from_secs(1);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                bail!("telemetry {step} never reached the bus");
            }
            if let Ok(Some(FromAgent::Telemetry(t))) = reports.recv_timeout(left) {
                if t.period == step {
                    end_to_end.push(sent.elapsed().as_nanos() as u64);
                    break;
                }
            }
        }
        std::thread::sleep(Duration::from_millis(args.interval_ms));
    }
    commands.publish(&ToAgent::Shutdown)?;
    let inside = gateway.join().map_err(|_| anyhow::anyhow!("the gateway thread panicked"))??;
    let us = |v: &[u64], q| quantile(v, q).map_or(f64::NAN, |n| n as f64 / 1000.0);
    println!("gateway added latency, {} telemetry frames (µs):", end_to_end.len());
    println!(
        "  in the gateway (socket receive → bus publish done): p50 {:.1}  p99 {:.1}",
        us(&inside, 0.5),
        us(&inside, 0.99)
    );
    println!(
        "  end to end (robot UDP send → bus subscriber woken): p50 {:.1}  p99 {:.1}",
        us(&end_to_end, 0.5),
        us(&end_to_end, 0.99)
    );
    Ok(())
}
