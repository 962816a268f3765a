//! The loop over a real zenoh bus on loopback, in-process: what only the
//! loop does (the session's rules are tested sans-IO in `session/tests.rs`).

use super::*;
use crate::gateway::core::Timers;
use bycoms_protocol::bus::zenoh::clock::HostClock;
use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
use bycoms_protocol::link::LinkKey;
use std::net::{Ipv4Addr, TcpListener};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A gateway whose host clock runs 1.5 s ahead (a skewed [`HostClock`],
/// as `BYCOMS_TEST_CLOCK_SKEW_MS` makes it in a process) reports that
/// offset to the orchestrator's clock (`FromAgent::Clock`) before its
/// first `Register`, so the launch judges the registration by it.
#[test]
fn a_gateway_reports_its_hosts_clock_offset_before_it_registers() {
    const SKEW_US: i64 = 1_500_000;
    let robot = RobotId(1);
    let port = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).and_then(|l| l.local_addr()).expect("port").port();
    let listen = format!("tcp/127.0.0.1:{port}");
    let orchestrator = ZenohBus::open(ZenohConfig {
        mode: Mode::Router,
        listen: vec![listen.clone()],
        ..ZenohConfig::default()
    })
    .expect("router");
    let swarm = Swarm::new("gwclock").expect("swarm");
    let _clock = orchestrator.serve_clock(&swarm).expect("clock");
    let reports = orchestrator.typed_subscriber::<FromAgent>(&swarm.from_agent(robot)).expect("reports");

    let bus =
        ZenohBus::open(ZenohConfig { mode: Mode::Client, connect: vec![listen], ..ZenohConfig::default() })
            .expect("client");
    let ports = GatewayPorts::open(&bus, &swarm, robot).expect("ports");
    let epoch = Epoch::now();
    let core = GatewayCore::new(robot, LinkKey::new(&[7; 32]), Timers::paper(1.0), 1, epoch.elapsed());
    let socket = UdpSocket::bind((Ipv4Addr::LOCALHOST, 0)).expect("socket");
    let mut gateway =
        Gateway::new(core, ports, socket, Duration::from_millis(50), None, epoch).expect("gateway");
    gateway.report_clock(bus.clock_probe(&swarm, HostClock { skew_us: SKEW_US }));
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let running = std::thread::spawn(move || gateway.run(&mut Lifeline::with_flag(flag)));

    let deadline = Instant::now() + Duration::from_secs(10);
    let mut seen = Vec::new();
    while !seen.iter().any(|m| matches!(m, FromAgent::Register(_))) {
        let left = deadline.saturating_duration_since(Instant::now());
        assert!(!left.is_zero(), "no Register within 10 s; seen {seen:?}");
        if let Some(m) = reports.recv_timeout(left).expect("recv") {
            seen.push(m);
        }
    }
    stop.store(true, Ordering::SeqCst);
    let ended = running.join().expect("the gateway thread");
    assert!(matches!(ended, Ok(ExitCause::Signal)), "{ended:?}");
    let Some(FromAgent::Clock(c)) = seen.first() else { panic!("the first report is no clock: {seen:?}") };
    assert_eq!(c.robot, robot);
    // Both clocks are this machine's: the measured offset is the skew, off
    // by at most half the round trip (and a microsecond of rounding).
    let error = (c.offset_us - SKEW_US).unsigned_abs();
    assert!(error <= u64::from(c.round_trip_us) / 2 + 1, "{c:?}");
}
