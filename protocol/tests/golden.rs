//! Golden bytes: the wire format of every message, pinned.
//!
//! Why hard-coded arrays: a change to a field's type or order, to the enum
//! order, or to the envelope must break a test here, and then bump
//! `PROTOCOL_VERSION`. Layout: `[version varint][variant index varint]`
//! then the fields in order; integers are varints, f64 is 8 little-endian
//! bytes, bool is one byte.

use bycoms_protocol::msg::*;
use bycoms_protocol::{decode, encode, encode_vec, Message, RobotId, PROTOCOL_VERSION};
use core::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use core::fmt::Debug;

/// The envelope's first byte: `PROTOCOL_VERSION` as a varint.
const V: u8 = 3;

const F15_5: [u8; 8] = [0, 0, 0, 0, 0, 0, 0x2F, 0x40];
const F0: [u8; 8] = [0; 8];
const F_PI_4: [u8; 8] = [0x18, 0x2D, 0x44, 0x54, 0xFB, 0x21, 0xE9, 0x3F];
const F_PI: [u8; 8] = [0x18, 0x2D, 0x44, 0x54, 0xFB, 0x21, 0x09, 0x40];
const F_NEG_PI_2: [u8; 8] = [0x18, 0x2D, 0x44, 0x54, 0xFB, 0x21, 0xF9, 0xBF];
const F1: [u8; 8] = [0, 0, 0, 0, 0, 0, 0xF0, 0x3F];
const F_NEG_2_5: [u8; 8] = [0, 0, 0, 0, 0, 0, 0x04, 0xC0];
const F0_25: [u8; 8] = [0, 0, 0, 0, 0, 0, 0xD0, 0x3F];
const F44_5: [u8; 8] = [0, 0, 0, 0, 0, 0x40, 0x46, 0x40];
const F44_25: [u8; 8] = [0, 0, 0, 0, 0, 0x20, 0x46, 0x40];

fn cat(parts: &[&[u8]]) -> Vec<u8> {
    parts.concat()
}

fn check<T: Message + PartialEq + Debug>(msg: T, expected: &[u8]) {
    let mut buf = [0u8; 64];
    let bytes = encode(&msg, &mut buf).expect("encodes");
    assert_eq!(bytes, expected, "encoding of {msg:?}");
    assert_eq!(encode_vec(&msg).expect("encodes"), expected, "encode_vec of {msg:?}");
    assert_eq!(decode::<T>(expected).expect("decodes"), msg);
}

#[test]
fn envelope_starts_with_the_version() {
    assert_eq!(PROTOCOL_VERSION, 3, "bumping the version must update these tests");
}

#[test]
fn to_agent() {
    let deploy = Deploy { robot: RobotId(1), x: 15.5, y: 15.5, heading: 0.0 };
    check(ToAgent::Deploy(deploy), &cat(&[&[V, 0, 1], &F15_5, &F15_5, &F0]));
    let bearing = GoalBearing { robot: RobotId(2), bearing: FRAC_PI_4, step: 300 };
    check(ToAgent::GoalBearing(bearing), &cat(&[&[V, 1, 2], &F_PI_4, &[0xAC, 0x02]]));
    check(ToAgent::Tick(Tick { step: 7 }), &[V, 2, 7]);
    check(ToAgent::Stop, &[V, 3]);
    check(ToAgent::Shutdown, &[V, 4]);
    let refused = Refused { robot: RobotId(3), instance: 300, why: Refusal::Duplicate };
    check(ToAgent::Refused(refused), &[V, 5, 3, 0xAC, 0x02, 0]);
    let refused = Refused { robot: RobotId(3), instance: 300, why: Refusal::Settings { launch: 0x1234 } };
    check(ToAgent::Refused(refused), &[V, 5, 3, 0xAC, 0x02, 1, 0xB4, 0x24]);
    let refused = Refused { robot: RobotId(3), instance: 300, why: Refusal::Grace { launch_ms: 2000 } };
    check(ToAgent::Refused(refused), &[V, 5, 3, 0xAC, 0x02, 2, 0xD0, 0x0F]);
    let refused = Refused { robot: RobotId(3), instance: 300, why: Refusal::Revoked };
    check(ToAgent::Refused(refused), &[V, 5, 3, 0xAC, 0x02, 3]);
    let why = Refusal::Clock { offset_ms: -2000, limit_ms: 500 };
    let refused = Refused { robot: RobotId(3), instance: 300, why };
    check(ToAgent::Refused(refused), &[V, 5, 3, 0xAC, 0x02, 4, 0x9F, 0x1F, 0xF4, 0x03]);
    let beacon = Beacon { robot: RobotId(2), x: 44.5, y: 44.25, seq: 300 };
    check(ToAgent::Beacon(beacon), &cat(&[&[V, 6, 2], &F44_5, &F44_25, &[0xAC, 0x02]]));
    check(ToAgent::Ticks(Ticks { step: 300, count: 32 }), &[V, 7, 0xAC, 0x02, 32]);
}

#[test]
fn from_agent() {
    let register = Register {
        robot: RobotId(1),
        kind: RobotKind::Real,
        protocol_version: 3,
        instance: 7,
        settings: 0,
        failsafe_grace_ms: 0,
    };
    check(FromAgent::Register(register), &[V, 0, 1, 1, 3, 7, 0, 0]);
    let instance = 0x0123_4567_89AB_CDEF;
    let register = Register {
        robot: RobotId(1),
        kind: RobotKind::Simulated,
        protocol_version: 3,
        instance,
        settings: instance,
        failsafe_grace_ms: 2000,
    };
    let instance_varint = [0xEF, 0x9B, 0xAF, 0xCD, 0xF8, 0xAC, 0xD1, 0x91, 0x01];
    let grace = [0xD0, 0x0F];
    check(
        FromAgent::Register(register),
        &cat(&[&[V, 0, 1, 0, 3], &instance_varint, &instance_varint, &grace]),
    );
    check(FromAgent::Heartbeat(Heartbeat { robot: RobotId(2), seq: 128 }), &[V, 1, 2, 0x80, 0x01]);
    check(FromAgent::Status(Status { robot: RobotId(3), mode: 2, step: 10 }), &[V, 2, 3, 2, 10]);
    check(FromAgent::TickDone(TickDone { robot: RobotId(4), step: 65_535 }), &[V, 3, 4, 0xFF, 0xFF, 0x03]);
    let link = LinkStatus { robot: RobotId(2), up: false, silent_ms: 300, refused: 7 };
    check(FromAgent::Link(link), &[V, 5, 2, 0, 0xAC, 0x02, 7]);
    let link = LinkStatus { robot: RobotId(2), up: true, silent_ms: 0, refused: 0 };
    check(FromAgent::Link(link), &[V, 5, 2, 1, 0, 0]);
    let fired = FailsafeFired { robot: RobotId(2), silent_ms: 2100 };
    check(FromAgent::Failsafe(fired), &[V, 6, 2, 0xB4, 0x10]);
    check(FromAgent::Parked(Parked { robot: RobotId(5), step: 300 }), &[V, 7, 5, 0xAC, 0x02]);
    let clock = ClockOffset { robot: RobotId(2), offset_us: -1500, round_trip_us: 800 };
    check(FromAgent::Clock(clock), &[V, 8, 2, 0xB7, 0x17, 0xA0, 0x06]);
    check(FromAgent::StopDone(StopDone { robot: RobotId(4), on_link: true }), &[V, 9, 4, 1]);
}

#[test]
fn commanded() {
    let sensed = Sensed { intensity: 1.0, gradient: Some(PI) };
    let driven =
        Commanded { robot: RobotId(2), step: 300, linear: 0.25, angular: -FRAC_PI_2, sensed: Some(sensed) };
    let head: &[u8] = &[V, 10, 2, 0xAC, 0x02];
    check(FromAgent::Commanded(driven), &cat(&[head, &F0_25, &F_NEG_PI_2, &[1], &F1, &[1], &F_PI]));
    let no_beacon = Sensed { intensity: 0.0, gradient: None };
    let alone = Commanded { sensed: Some(no_beacon), ..driven };
    check(FromAgent::Commanded(alone), &cat(&[head, &F0_25, &F_NEG_PI_2, &[1], &F0, &[0]]));
    let zero = Commanded { robot: RobotId(2), step: 0, linear: 0.0, angular: 0.0, sensed: None };
    check(FromAgent::Commanded(zero), &cat(&[&[V, 10, 2, 0], &F0, &F0, &[0]]));
}

/// f32 little-endian: 0.5, 1.0, 0.25, -0.5.
const G0_5: [u8; 4] = [0, 0, 0, 0x3F];
const G1: [u8; 4] = [0, 0, 0x80, 0x3F];
const G0_25: [u8; 4] = [0, 0, 0x80, 0x3E];
const G_NEG_0_5: [u8; 4] = [0, 0, 0, 0xBF];

fn telemetry(gradient: Option<f32>) -> Telemetry {
    Telemetry {
        robot: RobotId(3),
        period: 200,
        state: DriveState::Driving,
        mode: 2,
        mics: [0.5, 1.0, 0.5, 0.25, 0.5, 1.0],
        v_ave: 0.5,
        gradient,
        left: 1.0,
        right: -0.5,
        battery_mv: 7400,
        health: 2,
        robot_drops: 1,
    }
}

#[test]
fn telemetry_of_a_real_robot() {
    let mics = cat(&[&G0_5, &G1, &G0_5, &G0_25, &G0_5, &G1]);
    let head = [V, 4, 3, 0xC8, 0x01, 1, 2];
    let tail = cat(&[&G1, &G_NEG_0_5, &[0xE8, 0x39], &[2], &[1]]);
    let with = cat(&[&head, &mics, &G0_5, &[1], &G0_25, &tail]);
    check(FromAgent::Telemetry(telemetry(Some(0.25))), &with);
    let without = cat(&[&head, &mics, &G0_5, &[0], &tail]);
    check(FromAgent::Telemetry(telemetry(None)), &without);
    let state = |s, b: u8| {
        let t = Telemetry { state: s, ..telemetry(None) };
        let mut bytes = without.clone();
        bytes[5] = b;
        check(FromAgent::Telemetry(t), &bytes);
    };
    state(DriveState::Idle, 0);
    state(DriveState::Failsafe, 2);
    state(DriveState::Stopped, 3);
}

fn pose() -> (Pose, Vec<u8>) {
    let pose = Pose { robot: RobotId(1), x: 1.0, y: -2.5, heading: PI, step: 5, time_us: 500_000 };
    let body = cat(&[&[1], &F1, &F_NEG_2_5, &F_PI, &[5], &[0xA0, 0xC2, 0x1E]]);
    (pose, body)
}

#[test]
fn mocap() {
    let (pose, body) = pose();
    check(pose, &cat(&[&[V], &body]));
}

#[test]
fn sensor() {
    let field = FieldSample { robot: RobotId(2), intensity: 0.25, direction: -FRAC_PI_2, step: 1 };
    check(Sensor::Field(field), &cat(&[&[V, 0, 2], &F0_25, &F_NEG_PI_2, &[1]]));
    let (pose, body) = pose();
    check(Sensor::Pose(pose), &cat(&[&[V, 1], &body]));
}

#[test]
fn gate() {
    let event = |kind| GateEvent { robot: RobotId(2), kind, x: 44.5, y: 44.25, step: 1234 };
    let tail = cat(&[&F44_5, &F44_25, &[0xD2, 0x09]]);
    check(event(GateKind::Deployed), &cat(&[&[V, 2, 0], &tail]));
    check(event(GateKind::Stopped { arrived: true }), &cat(&[&[V, 2, 1, 1], &tail]));
    check(event(GateKind::Stopped { arrived: false }), &cat(&[&[V, 2, 1, 0], &tail]));
    check(event(GateKind::Died), &cat(&[&[V, 2, 2], &tail]));
    check(event(GateKind::Timeout), &cat(&[&[V, 2, 3], &tail]));
}

#[test]
fn operator_placement_request() {
    // A bare `Deploy` (topic `operator`): envelope version 2, then the struct.
    let request = Deploy { robot: RobotId(2), x: 15.5, y: 1.0, heading: 0.0 };
    check(request, &cat(&[&[V, 2], &F15_5, &F1, &F0]));
}
