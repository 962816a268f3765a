//! One message, one encoding: every field kind's non-canonical spellings
//! are refused with [`CodecError::NonCanonical`].
//!
//! Why: postcard's varint reader accepts overlong varints (`82 00` is 2
//! with a zero continuation group), so without this check a pose with robot
//! id `81 00` decoded and replayed as the same pose while its bytes differ
//! from what any encoder writes. Each test below takes a canonical golden
//! message, respells one field, and checks the respelling is refused while
//! the canonical bytes still decode.

use bycoms_protocol::msg::*;
use bycoms_protocol::{decode, encode, CodecError, Message, RobotId, MAX_MESSAGE_LEN};
use core::fmt::Debug;
use proptest::prelude::*;

const V: u8 = 3;
const F1: [u8; 8] = [0, 0, 0, 0, 0, 0, 0xF0, 0x3F];

fn cat(parts: &[&[u8]]) -> Vec<u8> {
    parts.concat()
}

/// `canonical` decodes to `msg` and encodes back to itself; `respelled`
/// (the same value, spelled otherwise) is refused as non-canonical.
fn one_spelling<T: Message + PartialEq + Debug>(msg: T, canonical: &[u8], respelled: &[u8]) {
    assert_eq!(decode::<T>(canonical).as_ref(), Ok(&msg), "canonical bytes decode");
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    assert_eq!(encode(&msg, &mut buf).expect("encodes"), canonical, "golden bytes");
    assert_eq!(decode::<T>(respelled), Err(CodecError::NonCanonical), "{respelled:02X?}");
}

fn pose(robot: &[u8], step: &[u8]) -> Vec<u8> {
    cat(&[robot, &F1, &F1, &F1, step, &[9]])
}

fn the_pose() -> Pose {
    Pose { robot: RobotId(1), x: 1.0, y: 1.0, heading: 1.0, step: 1, time_us: 9 }
}

#[test]
fn envelope_version_u16_varint() {
    let body = pose(&[1], &[1]);
    one_spelling(the_pose(), &cat(&[&[V], &body]), &cat(&[&[0x82, 0x00], &body]));
    one_spelling(the_pose(), &cat(&[&[V], &body]), &cat(&[&[0x82, 0x80, 0x00], &body]));
}

#[test]
fn robot_id_u32_varint() {
    let canonical = cat(&[&[V], &pose(&[1], &[1])]);
    one_spelling(the_pose(), &canonical, &cat(&[&[V], &pose(&[0x81, 0x00], &[1])]));
    let five = cat(&[&[V], &pose(&[0x81, 0x80, 0x80, 0x80, 0x00], &[1])]);
    one_spelling(the_pose(), &canonical, &five);
}

#[test]
fn step_u64_varint() {
    let canonical = cat(&[&[V], &pose(&[1], &[1])]);
    one_spelling(the_pose(), &canonical, &cat(&[&[V], &pose(&[1], &[0x81, 0x80, 0x00])]));
    // The longest a u64 may be spelled (10 bytes), value 1.
    let ten = [0x81, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x00];
    one_spelling(the_pose(), &canonical, &cat(&[&[V], &pose(&[1], &ten)]));
    // A multi-byte value with a zero group appended: 300 = AC 02.
    let hb = FromAgent::Heartbeat(Heartbeat { robot: RobotId(2), seq: 300 });
    one_spelling(hb, &[V, 1, 2, 0xAC, 0x02], &[V, 1, 2, 0xAC, 0x82, 0x00]);
}

#[test]
fn u16_varint_in_a_body() {
    let register = Register {
        robot: RobotId(1),
        kind: RobotKind::Real,
        protocol_version: 3,
        instance: 7,
        settings: 0,
        failsafe_grace_ms: 0,
    };
    let msg = FromAgent::Register(register);
    one_spelling(msg, &[V, 0, 1, 1, 3, 7, 0, 0], &[V, 0, 1, 1, 0x83, 0x00, 7, 0, 0]);
}

#[test]
fn enum_discriminant() {
    // The top-level variant index (Tick = 2) ...
    one_spelling(ToAgent::Tick(Tick { step: 7 }), &[V, 2, 7], &[V, 0x82, 0x00, 7]);
    // ... a unit variant (Stop = 3) ...
    one_spelling(ToAgent::Stop, &[V, 3], &[V, 0x83, 0x00]);
    // ... and an enum field (RobotKind::Real = 1).
    let register = Register {
        robot: RobotId(1),
        kind: RobotKind::Real,
        protocol_version: 3,
        instance: 7,
        settings: 0,
        failsafe_grace_ms: 0,
    };
    let msg = FromAgent::Register(register);
    one_spelling(msg, &[V, 0, 1, 1, 3, 7, 0, 0], &[V, 0, 1, 0x81, 0x00, 3, 7, 0, 0]);
}

/// A `Telemetry` with no gradient, its option tag at byte `TAG`.
fn telemetry_bytes(tag: &[u8]) -> Vec<u8> {
    let zeros4 = [0u8; 4];
    let mics = [0u8; 24];
    cat(&[&[V, 4, 3, 1, 1, 2], &mics, &zeros4, tag, &zeros4, &zeros4, &[0, 2, 0]])
}

#[test]
fn option_tag_and_bool_are_one_byte_each() {
    // An option tag and a bool have exactly two spellings (00, 01), both
    // canonical; any other byte is malformed (postcard checks this itself).
    let telemetry = Telemetry {
        robot: RobotId(3),
        period: 1,
        state: DriveState::Driving,
        mode: 2,
        mics: [0.0; 6],
        v_ave: 0.0,
        gradient: None,
        left: 0.0,
        right: 0.0,
        battery_mv: 0,
        health: 2,
        robot_drops: 0,
    };
    let msg = FromAgent::Telemetry(telemetry);
    assert_eq!(decode::<FromAgent>(&telemetry_bytes(&[0])), Ok(msg));
    assert_eq!(decode::<FromAgent>(&telemetry_bytes(&[2])), Err(CodecError::Malformed));
    let stopped = |arrived: u8| cat(&[&[V, 2, 1, arrived], &[0; 16], &[0]]);
    assert!(decode::<GateEvent>(&stopped(1)).is_ok());
    assert_eq!(decode::<GateEvent>(&stopped(2)), Err(CodecError::Malformed));
}

#[test]
fn no_length_prefixes_exist() {
    // Every field has a fixed size: `[f32; 6]` is six f32 with no length
    // (section 4 of PROTOCOL.md), so there is no length prefix to respell.
    // Pinned here: the mics array occupies exactly 24 bytes after the mode.
    let bytes = telemetry_bytes(&[0]);
    assert!(decode::<FromAgent>(&bytes).is_ok());
    let mut with_a_length = bytes.clone();
    with_a_length.insert(6, 6);
    assert!(decode::<FromAgent>(&with_a_length).is_err());
}

#[test]
fn the_largest_canonical_values_still_decode() {
    let msg = FromAgent::Heartbeat(Heartbeat { robot: RobotId(u32::MAX), seq: u64::MAX });
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    let bytes = encode(&msg, &mut buf).expect("encodes").to_vec();
    assert_eq!(bytes.len(), 2 + 5 + 10);
    assert_eq!(decode::<FromAgent>(&bytes), Ok(msg));
}

/// Bytes that decode as `T` re-encode to exactly themselves (the fuzz
/// target `codec` asserts the same over libFuzzer's inputs).
fn decodes_only_to_itself<T: Message>(bytes: &[u8]) -> Result<(), TestCaseError> {
    if let Ok(msg) = decode::<T>(bytes) {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        let again = encode(&msg, &mut buf).expect("a decoded message re-encodes");
        prop_assert_eq!(again, bytes);
    }
    Ok(())
}

/// A byte biased towards the ones varints are made of (continuation bits,
/// zero groups, small values), so respellings are common.
fn varint_byte() -> impl Strategy<Value = u8> {
    prop_oneof![Just(0x00), Just(0x01), Just(0x02), Just(0x80), Just(0x81), Just(0x82), any::<u8>()]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4096, ..ProptestConfig::default() })]

    #[test]
    fn whatever_decodes_reencodes_to_the_same_bytes(
        head in prop::collection::vec(varint_byte(), 0..8),
        middle in prop::collection::vec(any::<u8>(), 0..40),
        tail in prop::collection::vec(varint_byte(), 0..12),
    ) {
        let bytes = cat(&[&head, &middle, &tail]);
        decodes_only_to_itself::<ToAgent>(&bytes)?;
        decodes_only_to_itself::<FromAgent>(&bytes)?;
        decodes_only_to_itself::<Pose>(&bytes)?;
        decodes_only_to_itself::<Sensor>(&bytes)?;
        decodes_only_to_itself::<GateEvent>(&bytes)?;
    }
}
