//! The session rules: handshake, replay refusal, reboots, hijack attempts.

use super::super::*;
use super::{key, NONCE, ROBOT};
use crate::RobotId;

fn buf() -> [u8; MAX_FRAME_LEN] {
    [0u8; MAX_FRAME_LEN]
}

/// A robot and a gateway with an established session.
fn connected(session: u64) -> (RobotLink, GatewayLink) {
    let mut robot = RobotLink::new(ROBOT, key());
    let mut gateway = GatewayLink::new(ROBOT, key());
    let (mut b1, mut b2) = (buf(), buf());
    let hello = robot.hello(NONCE, &mut b1).unwrap();
    let accepted = gateway.receive(hello).unwrap();
    assert_eq!(accepted.event, GatewayEvent::Hello(NONCE));
    let welcome = gateway.welcome(NONCE, SessionId(session), &mut b2).unwrap();
    assert_eq!(robot.receive(welcome), Ok(RobotEvent::Connected(SessionId(session))));
    assert_eq!(gateway.session(), None, "pending until the robot speaks in it");
    let hb = robot.send(Payload::RobotHeartbeat { uptime_ms: 1 }, &mut b1).unwrap();
    let accepted = gateway.receive(hb).unwrap();
    assert_eq!(accepted.session_started, Some(SessionId(session)));
    assert_eq!(gateway.session(), Some(SessionId(session)));
    (robot, gateway)
}

#[test]
fn handshake_then_commands_and_telemetry_flow() {
    let (mut robot, mut gateway) = connected(77);
    let mut b = buf();
    let f = gateway.send(Payload::Enable, &mut b).unwrap().to_vec();
    assert_eq!(robot.receive(&f), Ok(RobotEvent::Enable));
    let f = gateway.send(Payload::Goal { bearing: -0.5 }, &mut b).unwrap().to_vec();
    assert_eq!(robot.receive(&f), Ok(RobotEvent::Goal(-0.5)));
    let f = gateway.send(Payload::Stop, &mut b).unwrap().to_vec();
    assert_eq!(robot.receive(&f), Ok(RobotEvent::Stop));
    let t = super::telemetry();
    let f = robot.send(Payload::Telemetry(t), &mut b).unwrap().to_vec();
    let accepted = gateway.receive(&f).unwrap();
    assert_eq!(accepted, Accepted { event: GatewayEvent::Telemetry(t), session_started: None });
    assert_eq!(robot.drops().total() + gateway.drops().total(), 0);
}

#[test]
fn replayed_duplicated_and_reordered_frames_are_refused_and_counted() {
    let (mut robot, mut gateway) = connected(5);
    let mut b = buf();
    let first = gateway.send(Payload::Goal { bearing: 0.1 }, &mut b).unwrap().to_vec();
    let second = gateway.send(Payload::Goal { bearing: 0.2 }, &mut b).unwrap().to_vec();
    assert_eq!(robot.receive(&second), Ok(RobotEvent::Goal(0.2)));
    assert_eq!(robot.receive(&first), Err(DropReason::Replayed), "reordered");
    assert_eq!(robot.receive(&second), Err(DropReason::Replayed), "duplicate");
    let tel = robot.send(Payload::RobotHeartbeat { uptime_ms: 9 }, &mut b).unwrap().to_vec();
    assert!(gateway.receive(&tel).is_ok());
    assert_eq!(gateway.receive(&tel), Err(DropReason::Replayed));
    assert_eq!(robot.drops().count(DropReason::Replayed), 2);
    assert_eq!(gateway.drops().count(DropReason::Replayed), 1);
}

#[test]
fn a_rebooted_robot_refuses_the_old_session_and_its_welcome() {
    let (_, mut gateway) = connected(11);
    let mut b = buf();
    let old_welcome = {
        // The welcome a sniffer captured for the first session.
        let mut g = GatewayLink::new(ROBOT, key());
        g.welcome(NONCE, SessionId(11), &mut b).unwrap().to_vec()
    };
    let old_goal = gateway.send(Payload::Goal { bearing: 1.0 }, &mut b).unwrap().to_vec();
    // Reboot: a new robot state, a new nonce.
    let mut robot = RobotLink::new(ROBOT, key());
    assert_eq!(robot.receive(&old_goal), Err(DropReason::NoSession));
    let new_nonce = [0x55; NONCE_LEN];
    let mut hb = buf();
    robot.hello(new_nonce, &mut hb).unwrap();
    assert_eq!(robot.receive(&old_welcome), Err(DropReason::UnexpectedWelcome));
    assert_eq!(robot.receive(&old_goal), Err(DropReason::NoSession));
    let welcome = gateway.welcome(new_nonce, SessionId(12), &mut b).unwrap().to_vec();
    assert_eq!(robot.receive(&welcome), Ok(RobotEvent::Connected(SessionId(12))));
    assert_eq!(robot.receive(&old_goal), Err(DropReason::WrongSession), "old session's capture");
    assert_eq!(robot.receive(&welcome), Err(DropReason::UnexpectedWelcome), "welcome replayed");
}

#[test]
fn a_replayed_hello_cannot_take_over_the_current_session() {
    let (mut robot, mut gateway) = connected(21);
    let mut b = buf();
    let captured_hello = {
        let mut r = RobotLink::new(ROBOT, key());
        r.hello([0x11; NONCE_LEN], &mut b).unwrap().to_vec()
    };
    let accepted = gateway.receive(&captured_hello).unwrap();
    let GatewayEvent::Hello(nonce) = accepted.event else { panic!("hello expected") };
    gateway.welcome(nonce, SessionId(22), &mut b).unwrap();
    // The real robot keeps talking in session 21 and the gateway keeps it.
    let f = robot.send(Payload::RobotHeartbeat { uptime_ms: 3 }, &mut b).unwrap().to_vec();
    assert!(gateway.receive(&f).is_ok());
    assert_eq!(gateway.session(), Some(SessionId(21)));
    let f = gateway.send(Payload::Enable, &mut b).unwrap().to_vec();
    assert_eq!(robot.receive(&f), Ok(RobotEvent::Enable));
}

#[test]
fn a_repeated_hello_gets_the_same_welcome() {
    let mut robot = RobotLink::new(ROBOT, key());
    let mut gateway = GatewayLink::new(ROBOT, key());
    let (mut b1, mut b2) = (buf(), buf());
    let hello = robot.hello(NONCE, &mut b1).unwrap().to_vec();
    gateway.receive(&hello).unwrap();
    let lost = gateway.welcome(NONCE, SessionId(31), &mut b2).unwrap().to_vec();
    // The welcome is lost; the robot repeats its hello.
    let hello_again = robot.hello(NONCE, &mut b1).unwrap().to_vec();
    gateway.receive(&hello_again).unwrap();
    let welcome = gateway.welcome(NONCE, SessionId(32), &mut b2).unwrap().to_vec();
    assert_eq!(welcome, lost);
    assert_eq!(robot.receive(&welcome), Ok(RobotEvent::Connected(SessionId(31))));
}

#[test]
fn foreign_forged_and_sessionless_frames_are_refused() {
    let (mut robot, mut gateway) = connected(41);
    let mut b = buf();
    // Robot 4's gateway, with robot 4's key, talking to robot 3.
    let mut other = GatewayLink::new(RobotId(4), LinkKey::new(&[4; KEY_LEN]));
    let mut r4 = RobotLink::new(RobotId(4), LinkKey::new(&[4; KEY_LEN]));
    let h = r4.hello([1; NONCE_LEN], &mut b).unwrap().to_vec();
    other.receive(&h).unwrap();
    let w = other.welcome([1; NONCE_LEN], SessionId(41), &mut b).unwrap().to_vec();
    r4.receive(&w).unwrap();
    let hb = r4.send(Payload::RobotHeartbeat { uptime_ms: 0 }, &mut b).unwrap().to_vec();
    other.receive(&hb).unwrap();
    let foreign = other.send(Payload::Enable, &mut b).unwrap().to_vec();
    assert_eq!(robot.receive(&foreign), Err(DropReason::ForeignRobot));
    // Same robot id, wrong key: a forgery.
    let mut forger = GatewayLink::new(ROBOT, LinkKey::new(&[9; KEY_LEN]));
    let forged = forger.welcome(NONCE, SessionId(41), &mut b).unwrap().to_vec();
    assert_eq!(robot.receive(&forged), Err(DropReason::BadTag));
    // A command reflected back at the gateway.
    let cmd = gateway.send(Payload::Stop, &mut b).unwrap().to_vec();
    assert_eq!(gateway.receive(&cmd), Err(DropReason::WrongDirection));
    // Commands before any session.
    let fresh = GatewayLink::new(ROBOT, key()).send(Payload::Enable, &mut b).map(|_| ());
    assert_eq!(fresh, Err(SendError::NoSession));
    assert_eq!(robot.send(Payload::Enable, &mut b).map(|_| ()), Err(SendError::WrongDirection));
    assert_eq!(robot.drops().total(), 2);
    assert_eq!(gateway.drops().count(DropReason::WrongDirection), 1);
}

#[test]
fn a_hello_with_a_session_or_seq_is_malformed() {
    let mut gateway = GatewayLink::new(ROBOT, key());
    let mut b = buf();
    let header = Header { robot: ROBOT, session: SessionId(3), seq: 0 };
    let f = encode(&Frame { header, payload: Payload::Hello { nonce: NONCE } }, &key(), &mut b).unwrap();
    assert_eq!(gateway.receive(f), Err(DropReason::Malformed));
}
