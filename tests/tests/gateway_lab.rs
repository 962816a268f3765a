//! The `gateway` end to end, through real UDP sockets and the real
//! iceoryx2 bus: with the emulated lab (`sim-agent lab`) as its robot, and
//! with the test itself playing a robot that misbehaves.
//!
//! The test plays the orchestrator on the bus (deploy, goal bearings from
//! the lab's poses, stop). Every process is killed and reaped on drop
//! ([`Proc`]), every wait has a deadline, swarm names are unique. UDP ports
//! for the robots file are taken by binding port 0 and releasing it: the
//! robots file names fixed addresses (a real robot's flashed settings), so
//! a port-0 socket cannot be handed over.

use bycoms_agent::gateway::GatewayArgs;
use bycoms_lab::process::LabArgs;
use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::bus::BusExt;
use bycoms_protocol::link::{
    Health, LinkKey, Payload, RobotEvent, RobotLink, RobotState, Telemetry as LinkTelemetry,
};
use bycoms_protocol::msg::{Deploy, DriveState, FromAgent, GoalBearing, Pose, RobotKind, ToAgent};
use bycoms_protocol::{RobotId, Swarm};
use bycoms_runtime::ipc_config;
use bycoms_tests::{bin, is_zombie, signal, swarm_name, wait_for, Proc};
use nix::sys::signal::Signal;
use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use bycoms_tests::{free_udp_port as free_port, TEST_KEYS as KEYS};

/// A robots file for `n` robots in `dir`: (path, robot addresses, gateway addresses).
fn robots_file(dir: &Path, n: usize) -> (PathBuf, Vec<SocketAddr>, Vec<SocketAddr>) {
    let (mut text, mut robots, mut gateways) = (String::new(), vec![], vec![]);
    for (i, key) in KEYS.iter().enumerate().take(n) {
        let (robot, gateway) = (free_port(), free_port());
        std::fs::write(dir.join(format!("robot-{}.key", i + 1)), key).expect("key file");
        text += &format!(
            "[[robot]]\nid = {}\naddress = \"{robot}\"\ngateway = \"{gateway}\"\nkey_file = \"robot-{}.key\"\n",
            i + 1,
            i + 1
        );
        robots.push(robot);
        gateways.push(gateway);
    }
    let path = dir.join("robots.toml");
    std::fs::write(&path, text).expect("robots file");
    (path, robots, gateways)
}

fn key(i: usize) -> LinkKey {
    LinkKey::from_hex(KEYS[i]).expect("key")
}

fn gateway(swarm: &str, robot: u32, bind: SocketAddr, dir: &Path, size: u32) -> Proc {
    let key_file = dir.join(format!("robot-{robot}.key"));
    let args = GatewayArgs { swarm_size: Some(size), ..GatewayArgs::new(swarm, robot, bind, key_file) };
    Proc::start(&bin("gateway"), &args.to_flags())
}

fn lab(swarm: &str, scenario: &str, robots: &Path) -> Proc {
    let args = LabArgs { seed: 3, ..LabArgs::new(scenario, robots, swarm) };
    Proc::start(&bin("sim-agent"), &args.to_args())
}

/// The test's side of the bus: the orchestrator's ports for robot 1.
struct Orchestrator {
    bus: IpcBus,
    reports:
        bycoms_protocol::bus::TypedSubscriber<<IpcBus as bycoms_protocol::bus::Bus>::Subscriber, FromAgent>,
    poses: bycoms_protocol::bus::TypedSubscriber<<IpcBus as bycoms_protocol::bus::Bus>::Subscriber, Pose>,
    commands: bycoms_protocol::bus::TypedPublisher<<IpcBus as bycoms_protocol::bus::Bus>::Publisher, ToAgent>,
}

impl Orchestrator {
    fn new(swarm: &str, size: u32) -> Self {
        let swarm = Swarm::new(swarm).expect("swarm");
        let bus = IpcBus::new(ipc_config(size)).expect("bus");
        let reports = bus.typed_subscriber(&swarm.from_agent(RobotId(1))).expect("reports");
        let poses = bus.typed_subscriber(&swarm.pose(RobotId(1))).expect("poses");
        let commands = bus.typed_publisher(&swarm.to_agent(RobotId(1))).expect("commands");
        Self { bus, reports, poses, commands }
    }

    /// Waits up to `timeout` for a report that `accept` maps to a value.
    fn report<T>(&self, timeout: Duration, mut accept: impl FnMut(&FromAgent) -> Option<T>) -> Option<T> {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if let Ok(Some(m)) = self.reports.recv_timeout(Duration::from_millis(5)) {
                if let Some(v) = accept(&m) {
                    return Some(v);
                }
            }
        }
        None
    }
}

#[test]
fn a_gateway_drives_an_emulated_robot_and_its_failsafe_stops_it_when_commands_cease() {
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = swarm_name("gwlab");
    let (robots, _, gateways) = robots_file(dir.path(), 2);
    let orch = Orchestrator::new(&swarm, 2);
    let lab = lab(&swarm, "exp-short", &robots);
    let mut gw = gateway(&swarm, 1, gateways[0], dir.path(), 2);
    let reg = orch.report(Duration::from_secs(20), |m| match m {
        FromAgent::Register(r) => Some(*r),
        _ => None,
    });
    assert_eq!(
        reg.map(|r| (r.robot, r.kind)),
        Some((RobotId(1), RobotKind::Real)),
        "the gateway registers as Real"
    );
    let up = orch.report(Duration::from_secs(10), |m| matches!(m, FromAgent::Link(l) if l.up).then_some(()));
    assert!(up.is_some(), "the emulated robot connects to its gateway");
    orch.commands
        .publish(&ToAgent::Deploy(Deploy { robot: RobotId(1), x: 0.4, y: 1.0, heading: 0.0 }))
        .unwrap();
    // Answer every pose with the bearing to the goal (2.6, 1.0), as the gate does.
    let mut last: Option<Pose> = None;
    let mut driving = None;
    let deadline = Instant::now() + Duration::from_secs(20);
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        if last.is_some_and(|p| p.x > 0.7) {
            break;
        }
        // The next pose is the event (mocap's rate paces the loop), then
        // every pose that came with it.
        let next = orch.poses.recv_timeout(left).ok().flatten();
        for p in next.into_iter().chain(std::iter::from_fn(|| orch.poses.try_recv().ok().flatten())) {
            let bearing = (1.0 - p.y).atan2(2.6 - p.x);
            orch.commands
                .publish(&ToAgent::GoalBearing(GoalBearing { robot: RobotId(1), bearing, step: p.step }))
                .unwrap();
            last = Some(p);
        }
        while let Ok(Some(m)) = orch.reports.try_recv() {
            if let FromAgent::Telemetry(t) = m {
                if t.state == DriveState::Driving {
                    driving = Some(t);
                }
            }
        }
    }
    let p = last.expect("the operator placed robot 1 and mocap sees it");
    assert!(p.x > 0.7, "robot 1 drove towards the goal from x = 0.4: {p:?}");
    let t = driving.expect("telemetry of a driving robot reaches the bus");
    assert!(t.mics.iter().all(|v| v.is_finite() && *v >= 0.0) && t.left != 0.0, "{t:?}");
    // Freeze the gateway: no more commands. The firmware's failsafe stops
    // the motors 500 ms (lab time = wall time at speed 1) after the last.
    signal(gw.pid(), Signal::SIGSTOP);
    let frozen = Instant::now();
    let mut poses = vec![];
    while frozen.elapsed() < Duration::from_millis(3000) {
        if let Ok(Some(p)) = orch.poses.recv_timeout(Duration::from_millis(20)) {
            poses.push((frozen.elapsed(), p));
        }
    }
    let cut_lab_s = poses.first().expect("poses keep coming").1.time_us as f64 / 1e6;
    // Killed while still frozen: resumed first, it could send its robot one
    // more command, and the firmware would leave Failsafe before the end.
    gw.kill();
    signal(lab.pid(), Signal::SIGTERM);
    let out = lab.wait(Duration::from_secs(10));
    let failsafe_lab_s = out
        .stderr
        .lines()
        .find(|l| l.contains("from=Driving to=Failsafe") && l.contains("robot=1"))
        .and_then(|l| l.split("lab_s=").nth(1)?.split_whitespace().next()?.parse::<f64>().ok())
        .unwrap_or_else(|| panic!("robot 1's firmware went to failsafe:\n{}", out.stderr));
    // The last command left at most ~50 ms before the first pose seen after
    // the freeze; the failsafe fires 500 ms after it (lab time).
    let after = failsafe_lab_s - cut_lab_s;
    assert!((0.0..0.6).contains(&after), "failsafe {after:.3} s after the cut");
    // Then the tracks coast down (lag τ = 0.1 s): still within 1 mm over the last 0.5 s.
    let late: Vec<&Pose> =
        poses.iter().filter(|(_, p)| p.time_us as f64 / 1e6 > failsafe_lab_s + 1.0).map(|(_, p)| p).collect();
    let (first, last) = (late.first().expect("poses after the stop"), late.last().expect("poses"));
    assert!((last.x - first.x).hypot(last.y - first.y) < 1e-3, "the body stands still: {first:?} → {last:?}");
    assert_eq!(out.json()["robots"][0]["state"], "Failsafe");
    orch.bus.cleanup_dead_nodes();
}

#[test]
fn a_dead_lab_is_reported_as_a_lost_link_within_500_ms_and_nothing_is_left_behind() {
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = swarm_name("gwlost");
    let (robots, _, gateways) = robots_file(dir.path(), 2);
    let orch = Orchestrator::new(&swarm, 2);
    let mut lab = lab(&swarm, "exp-short", &robots);
    let gw = gateway(&swarm, 1, gateways[0], dir.path(), 2);
    let up = orch.report(Duration::from_secs(20), |m| matches!(m, FromAgent::Link(l) if l.up).then_some(()));
    assert!(up.is_some(), "the emulated robot connects to its gateway");
    // Let the link run for a while (five gateway heartbeats), then pull the plug.
    let mut beats = 0;
    let flowing = orch.report(Duration::from_secs(10), |m| {
        beats += u32::from(matches!(m, FromAgent::Heartbeat(_)));
        (beats >= 5).then_some(())
    });
    assert!(flowing.is_some(), "the gateway reports while its robot is connected");
    let lab_pid = lab.pid();
    lab.kill();
    let killed = Instant::now();
    let lost = orch.report(Duration::from_secs(5), |m| match m {
        FromAgent::Link(l) if !l.up => Some((*l, killed.elapsed())),
        _ => None,
    });
    let (status, after) = lost.expect("the gateway reports the lost link");
    assert!(after < Duration::from_millis(500), "reported {after:?} after the lab died");
    assert!(status.silent_ms >= 300, "after its 300 ms timeout: {status:?}");
    drop(lab);
    assert!(is_zombie(lab_pid), "the lab is gone");
    // The gateway exits on SIGTERM (status 130, interrupted, as the
    // orchestrator) and leaves no process.
    let gw_pid = gw.pid();
    signal(gw_pid, Signal::SIGTERM);
    let out = gw.wait(Duration::from_secs(10));
    assert_eq!(out.status.code(), Some(130), "{}", out.stderr);
    assert!(wait_for(Duration::from_secs(2), || is_zombie(gw_pid).then_some(())).is_some());
    orch.bus.cleanup_dead_nodes();
}

fn telemetry(step: u32) -> Payload {
    Payload::Telemetry(LinkTelemetry {
        step,
        state: RobotState::Idle,
        mode: 1,
        mics: [3.0; 6],
        v_ave: 3.0,
        gradient: None,
        left: 0.0,
        right: 0.0,
        battery_mv: 7200,
        health: Health(0),
        link_drops: 0,
    })
}

#[test]
fn forged_replayed_foreign_and_garbage_frames_are_refused_and_counted_on_the_bus() {
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = swarm_name("gwbad");
    let (_, _, gateways) = robots_file(dir.path(), 2);
    let orch = Orchestrator::new(&swarm, 2);
    let gw = gateway(&swarm, 1, gateways[0], dir.path(), 2);
    orch.report(Duration::from_secs(20), |m| matches!(m, FromAgent::Register(_)).then_some(()))
        .expect("registers");
    // The test is robot 1 (it has the key); it connects like the firmware.
    let socket = UdpSocket::bind(("127.0.0.1", 0)).expect("robot socket");
    socket.set_read_timeout(Some(Duration::from_secs(5))).expect("timeout");
    let mut robot = RobotLink::new(RobotId(1), key(0));
    let mut buf = [0u8; 128];
    socket.send_to(robot.hello([5; 16], &mut buf).expect("hello"), gateways[0]).expect("send");
    let n = socket.recv(&mut buf).expect("a welcome");
    assert!(matches!(robot.receive(&buf[..n]), Ok(RobotEvent::Connected(_))));
    let genuine = robot.send(telemetry(1), &mut buf).expect("frame").to_vec();
    socket.send_to(&genuine, gateways[0]).expect("send");
    let relayed = orch.report(Duration::from_secs(5), |m| {
        matches!(m, FromAgent::Telemetry(t) if t.period == 1).then_some(())
    });
    assert!(relayed.is_some(), "the genuine frame is relayed");
    let mut forged = robot.send(telemetry(2), &mut buf).expect("frame").to_vec();
    forged[30] ^= 0x01; // a changed microphone value: the tag no longer matches
    let mut other = RobotLink::new(RobotId(2), key(1));
    let foreign = other.hello([6; 16], &mut buf).expect("hello").to_vec();
    let mut wrong_key = RobotLink::new(RobotId(1), key(2));
    let impostor = wrong_key.hello([7; 16], &mut buf).expect("hello").to_vec();
    for bad in [&genuine[..], &forged, &foreign, &impostor, b"\x01garbage"] {
        socket.send_to(bad, gateways[0]).expect("send");
    }
    let refused = orch.report(Duration::from_secs(5), |m| match m {
        // Reported at most once a second: wait for the count to settle.
        FromAgent::Link(l) if l.refused >= 5 => Some(l.refused),
        _ => None,
    });
    assert_eq!(refused, Some(5), "replayed, forged, foreign, wrong key, garbage");
    // Nothing refused was relayed: the only telemetry on the bus is period 1.
    let more =
        orch.report(Duration::from_millis(300), |m| matches!(m, FromAgent::Telemetry(_)).then_some(()));
    assert!(more.is_none(), "a refused frame reached the bus");
    // Shutdown: the gateway stops the robot, then exits 0 and names the refusals.
    orch.commands.publish(&ToAgent::Shutdown).expect("shutdown");
    let out = gw.wait(Duration::from_secs(10));
    assert_eq!(out.status.code(), Some(0), "{}", out.stderr);
    let mut stop = None;
    while let Ok(n) = socket.recv(&mut buf) {
        if let Ok(RobotEvent::Stop) = robot.receive(&buf[..n]) {
            stop = Some(());
            break;
        }
    }
    assert!(stop.is_some(), "the robot was told to stop");
    for why in ["replayed=1", "bad_tag=2", "foreign_robot=1", "truncated=1"] {
        assert!(out.stderr.contains(why), "{why} in:\n{}", out.stderr);
    }
    orch.bus.cleanup_dead_nodes();
}
