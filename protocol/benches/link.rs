//! Cost of one robot-link frame: encode (tag) and decode (checks + tag
//! verify) of the largest frame (telemetry, 88 bytes) and a goal (38 bytes),
//! and a whole gateway `receive` (decode + session checks).
//!
//! Run: `cargo bench -p bycoms-protocol --bench link`.

use bycoms_protocol::link::{
    decode, encode, Direction, Frame, GatewayLink, Header, Health, LinkKey, Payload, RobotLink, RobotState,
    SessionId, Telemetry, MAX_FRAME_LEN,
};
use bycoms_protocol::RobotId;
use divan::black_box;

fn main() {
    divan::main();
}

const ROBOT: RobotId = RobotId(1);

fn telemetry() -> Payload {
    Payload::Telemetry(Telemetry {
        step: 1,
        state: RobotState::Driving,
        mode: 2,
        mics: [21000.0; 6],
        v_ave: 21000.0,
        gradient: Some(0.3),
        left: 140.0,
        right: 100.0,
        battery_mv: 5000,
        health: Health(0),
        link_drops: 0,
    })
}

fn frame(payload: Payload) -> Frame {
    Frame { header: Header { robot: ROBOT, session: SessionId(9), seq: 7 }, payload }
}

#[divan::bench(args = ["telemetry", "goal"])]
fn encode_frame(bencher: divan::Bencher, kind: &str) {
    let key = LinkKey::new(&[3; 32]);
    let f = frame(if kind == "goal" { Payload::Goal { bearing: 0.4 } } else { telemetry() });
    let mut buf = [0u8; MAX_FRAME_LEN];
    bencher.bench_local(|| encode(black_box(&f), &key, &mut buf).map(|b| b.len()));
}

#[divan::bench(args = ["telemetry", "goal"])]
fn decode_frame(bencher: divan::Bencher, kind: &str) {
    let key = LinkKey::new(&[3; 32]);
    let (f, to) = if kind == "goal" {
        (frame(Payload::Goal { bearing: 0.4 }), Direction::ToRobot)
    } else {
        (frame(telemetry()), Direction::ToGateway)
    };
    let mut buf = [0u8; MAX_FRAME_LEN];
    let bytes = encode(&f, &key, &mut buf).map(<[u8]>::to_vec).unwrap_or_default();
    bencher.bench_local(|| decode(black_box(&bytes), &key, ROBOT, to).is_ok());
}

/// A forged frame is refused after the tag check: the cost an attacker
/// can impose per datagram.
#[divan::bench]
fn decode_forged_telemetry(bencher: divan::Bencher) {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let bytes = encode(&frame(telemetry()), &LinkKey::new(&[4; 32]), &mut buf)
        .map(<[u8]>::to_vec)
        .unwrap_or_default();
    let key = LinkKey::new(&[3; 32]);
    bencher.bench_local(|| decode(black_box(&bytes), &key, ROBOT, Direction::ToGateway).is_err());
}

/// Robot encodes telemetry in session, gateway receives it (all checks).
#[divan::bench]
fn session_telemetry_round_trip(bencher: divan::Bencher) {
    let key = LinkKey::new(&[3; 32]);
    let mut robot = RobotLink::new(ROBOT, key.clone());
    let mut gateway = GatewayLink::new(ROBOT, key);
    let (mut a, mut b) = ([0u8; MAX_FRAME_LEN], [0u8; MAX_FRAME_LEN]);
    let nonce = [1; 16];
    let ok = robot.hello(nonce, &mut a).is_ok()
        && gateway.receive(&a[..50]).is_ok()
        && gateway.welcome(nonce, SessionId(5), &mut b).is_ok()
        && robot.receive(&b[..50]).is_ok();
    assert!(ok, "handshake");
    let t = telemetry();
    bencher.bench_local(|| {
        let n = robot.send(t, &mut a).map(|f| f.len()).unwrap_or(0);
        gateway.receive(black_box(&a[..n])).is_ok()
    });
}
