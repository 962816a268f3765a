//! The emulated ESP32s through real UDP sockets: a test gateway (the link's
//! `GatewayLink` on a socket bound to port 0) plays the operator's PC.

use crate::scenario::Scenario;
use crate::world::Lab;
use bycoms_agent::angle::wrap;
use bycoms_protocol::link::{DropReason, GatewayEvent, GatewayLink, LinkKey, Payload, RobotState, SessionId};
use bycoms_protocol::RobotId;
use core::time::Duration;
use std::net::{SocketAddr, UdpSocket};

fn key(robot: u32) -> LinkKey {
    LinkKey::new(&[robot as u8 * 17; 32])
}

/// One robot's gateway side, without the bus.
struct TestGateway {
    link: GatewayLink,
    socket: UdpSocket,
    robot_addr: Option<SocketAddr>,
    session: u64,
    telemetry: u32,
}

impl TestGateway {
    fn new(robot: u32) -> Self {
        let socket = UdpSocket::bind(("127.0.0.1", 0)).unwrap();
        socket.set_nonblocking(true).unwrap();
        let link = GatewayLink::new(RobotId(robot), key(robot));
        Self { link, socket, robot_addr: None, session: 1000 * u64::from(robot), telemetry: 0 }
    }

    fn addr(&self) -> SocketAddr {
        self.socket.local_addr().unwrap()
    }

    /// Handles everything received; answers hellos.
    fn pump(&mut self) {
        let mut buf = [0u8; 512];
        while let Ok((n, from)) = self.socket.recv_from(&mut buf) {
            let Ok(accepted) = self.link.receive(&buf[..n]) else { continue };
            self.robot_addr = Some(from);
            match accepted.event {
                GatewayEvent::Hello(nonce) => {
                    self.session += 1;
                    let mut out = [0u8; 128];
                    let w = self.link.welcome(nonce, SessionId(self.session), &mut out).unwrap();
                    self.socket.send_to(w, from).unwrap();
                }
                GatewayEvent::Telemetry(_) => self.telemetry += 1,
                GatewayEvent::Heartbeat { .. } => {}
            }
        }
    }

    fn send(&mut self, payload: Payload) -> Option<Vec<u8>> {
        let addr = self.robot_addr?;
        let mut out = [0u8; 128];
        let frame = self.link.send(payload, &mut out).ok()?.to_vec();
        self.socket.send_to(&frame, addr).unwrap();
        Some(frame)
    }
}

fn lab(name: &str) -> (Lab, Vec<TestGateway>) {
    let scenario = Scenario::builtin(name).unwrap();
    let n = scenario.tones.len() as u32;
    let gateways: Vec<TestGateway> = (1..=n).map(TestGateway::new).collect();
    let keys: Vec<LinkKey> = (1..=n).map(key).collect();
    let addrs: Vec<SocketAddr> = gateways.iter().map(TestGateway::addr).collect();
    (Lab::new(scenario, &keys, &addrs, 3).unwrap(), gateways)
}

/// The goal bearing in robot `i`'s frame, from its true pose (the mocap's job).
fn bearing(lab: &Lab, i: usize) -> Option<f32> {
    let b = lab.robots()[i].body?;
    let g = lab.scenario().goal;
    Some(wrap((g.y - b.y).atan2(g.x - b.x) - b.heading) as f32)
}

#[test]
fn an_emulated_robot_connects_drives_and_fails_safe_over_udp() {
    let (mut lab, mut gws) = lab("exp-short");
    let gw = &mut gws[0];
    // Handshake over the sockets.
    while lab.now() < Duration::from_millis(300) {
        lab.step().unwrap();
        gw.pump();
    }
    assert!(lab.robots()[0].esp.firmware().connected());
    assert!(lab.robots()[0].body.is_none(), "off the arena until deployed");
    gw.send(Payload::Enable).unwrap();
    let mut last_goal = lab.now();
    while lab.now() < Duration::from_secs(3) {
        if lab.now() >= last_goal + Duration::from_millis(100) {
            let b = bearing(&lab, 0).unwrap_or(0.0);
            gw.send(Payload::Goal { bearing: b });
            last_goal = lab.now();
        }
        lab.step().unwrap();
        gw.pump();
    }
    let body = lab.robots()[0].body.unwrap();
    let start = lab.scenario().start;
    assert!(body.x > start.x + 0.2, "drove towards the goal: {body:?}");
    assert!(gw.telemetry > 15, "telemetry every control period: {}", gw.telemetry);
    // A replayed goal and a forged one are refused and counted.
    let old = gw.send(Payload::Goal { bearing: 0.0 }).unwrap();
    gw.socket.send_to(&old, gw.robot_addr.unwrap()).unwrap();
    let mut forged = old.clone();
    forged[20] ^= 0x40;
    gw.socket.send_to(&forged, gw.robot_addr.unwrap()).unwrap();
    // Cut the link: no more commands. The motors stop within 500 ms.
    let cut = lab.now();
    while lab.now() < cut + Duration::from_millis(495) {
        lab.step().unwrap();
    }
    assert_eq!(lab.robots()[0].esp.firmware().state(), RobotState::Driving);
    while lab.now() < cut + Duration::from_millis(505) {
        lab.step().unwrap();
    }
    let fw = lab.robots()[0].esp.firmware();
    assert_eq!(fw.state(), RobotState::Failsafe);
    assert_eq!((fw.motors().left, fw.motors().right), (0.0, 0.0));
    assert_eq!(fw.drops().count(DropReason::Replayed), 1);
    assert_eq!(fw.drops().count(DropReason::BadTag), 1);
    // The tracks coast down with their lag (τ = 0.1 s), then stand still.
    for _ in 0..100 {
        lab.step().unwrap();
    }
    let x = lab.robots()[0].body.unwrap().x;
    for _ in 0..100 {
        lab.step().unwrap();
    }
    assert!((lab.robots()[0].body.unwrap().x - x).abs() < 1e-3, "the body has stopped");
}

/// Runs a scenario as the paper's lab did: deploy robot k, send it goal
/// bearings every 100 ms from its true pose, and when it has stood still
/// for 1 s (the gate's rule, from poses alone) stop it (a beacon) and
/// deploy the next. Returns (stuck robots, arrived robot) and logs poses.
fn run_experiment(name: &str, limit: Duration) -> (Vec<usize>, Option<usize>, Lab) {
    let (mut lab, mut gws) = lab(name);
    let n = gws.len();
    let goal = lab.scenario().goal;
    let radius = lab.scenario().goal_radius;
    let (mut current, mut stuck) = (0usize, vec![]);
    let mut enabled = false;
    let (mut last_goal, mut still_since, mut last_pos) = (Duration::ZERO, Duration::ZERO, (0.0, 0.0));
    while lab.now() < limit {
        for g in gws.iter_mut() {
            g.pump();
        }
        let gw = &mut gws[current];
        if !enabled && gw.link.session().is_some() {
            enabled = gw.send(Payload::Enable).is_some();
            still_since = lab.now();
        }
        if enabled && lab.now() >= last_goal + Duration::from_millis(100) {
            if let Some(b) = bearing(&lab, current) {
                gw.send(Payload::Goal { bearing: b });
            }
            last_goal = lab.now();
        }
        if let Some(b) = lab.robots()[current].body {
            if (b.x - goal.x).hypot(b.y - goal.y) < radius {
                return (stuck, Some(current + 1), lab);
            }
            if (b.x - last_pos.0).hypot(b.y - last_pos.1) > 0.005 {
                last_pos = (b.x, b.y);
                still_since = lab.now();
            } else if lab.now() > still_since + Duration::from_secs(1) {
                gws[current].send(Payload::Stop);
                stuck.push(current + 1);
                current += 1;
                enabled = false;
                if current == n {
                    return (stuck, None, lab);
                }
            }
        }
        lab.step().unwrap();
    }
    (stuck, None, lab)
}

#[test]
fn exp_short_robot_1_sticks_at_the_frame_and_robot_2_reaches_the_goal() {
    let (stuck, arrived, lab) = run_experiment("exp-short", Duration::from_secs(120));
    let poses: Vec<_> = lab.robots().iter().map(|r| r.body).collect();
    assert_eq!((stuck, arrived), (vec![1], Some(2)), "{poses:?} at {:?}", lab.now());
    let r1 = poses[0].unwrap();
    assert!(r1.stuck && (1.3..1.5).contains(&r1.x), "robot 1 at the frame: {r1:?}");
}

#[test]
fn exp_long_robots_1_and_2_stick_and_robot_3_reaches_the_goal() {
    let (stuck, arrived, lab) = run_experiment("exp-long", Duration::from_secs(240));
    let poses: Vec<_> = lab.robots().iter().map(|r| r.body).collect();
    assert_eq!((stuck, arrived), (vec![1, 2], Some(3)), "{poses:?} at {:?}", lab.now());
    let (r1, r2) = (poses[0].unwrap(), poses[1].unwrap());
    assert!(r1.stuck && r2.stuck && r2.y > r1.y + 0.3, "robot 2 bypassed robot 1, then stuck: {r2:?}");
}

/// Issue 49: an address the lab cannot bind (another host's, or one in
/// use) names the robot and the address.
#[test]
fn an_address_the_lab_cannot_bind_names_the_robot_and_the_address() {
    use crate::world::Wiring;
    let gateway = SocketAddr::from(([127, 0, 0, 1], 9));
    let taken = UdpSocket::bind("127.0.0.1:0").expect("bind");
    let taken = taken.local_addr().expect("addr");
    // 192.0.2.0/24 is TEST-NET-1: no interface of this host has it.
    let foreign: SocketAddr = "192.0.2.7:47101".parse().expect("addr");
    let scenario = Scenario::builtin("exp-short").expect("built in");
    for (wired, says) in [
        ([foreign, "127.0.0.1:0".parse().expect("addr")], "robot 1's address 192.0.2.7:47101: "),
        (["127.0.0.1:0".parse().expect("addr"), taken], &*format!("robot 2's address {taken}: ")),
    ] {
        let wiring: Vec<Wiring> =
            (0..2).map(|k| Wiring { key: key(k as u32 + 1), bind: wired[k], gateway }).collect();
        let Err(err) = Lab::wired(scenario.clone(), &wiring, 1) else { panic!("{says}: not refused") };
        assert!(err.to_string().starts_with(says), "{err}");
    }
}
