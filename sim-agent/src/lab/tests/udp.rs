//! The emulated ESP32s through real UDP sockets: a test gateway (the link's
//! `GatewayLink` on a socket bound to port 0) plays the operator's PC.

use crate::lab::scenario::Scenario;
use crate::lab::world::Lab;
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
