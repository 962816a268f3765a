//! Every codec error kind, provoked on purpose.

use bycoms_protocol::msg::*;
use bycoms_protocol::{decode, encode, CodecError, RobotId, PROTOCOL_VERSION};

/// The envelope's first byte: `PROTOCOL_VERSION` as a varint.
const V: u8 = 3;

fn tick_bytes() -> Vec<u8> {
    vec![V, 2, 7] // ToAgent::Tick { step: 7 }
}

#[test]
fn buffer_too_small() {
    let msg = ToAgent::Deploy(Deploy { robot: RobotId(1), x: 1.0, y: 2.0, heading: 3.0 });
    let mut buf = [0u8; 8];
    assert_eq!(encode(&msg, &mut buf), Err(CodecError::BufferTooSmall));
}

#[test]
fn truncated() {
    assert_eq!(decode::<ToAgent>(&[]), Err(CodecError::Truncated));
    assert_eq!(decode::<ToAgent>(&[V]), Err(CodecError::Truncated));
    let bearing = [V, 1, 2, 0, 0, 0, 0]; // GoalBearing cut inside the f64
    assert_eq!(decode::<ToAgent>(&bearing), Err(CodecError::Truncated));
}

#[test]
fn trailing_bytes() {
    let mut bytes = tick_bytes();
    bytes.extend_from_slice(&[0, 0]);
    assert_eq!(decode::<ToAgent>(&bytes), Err(CodecError::TrailingBytes { extra: 2 }));
}

#[test]
fn unsupported_version() {
    let supported = PROTOCOL_VERSION;
    assert_eq!(decode::<ToAgent>(&[1, 2, 7]), Err(CodecError::UnsupportedVersion { found: 1, supported }));
    assert_eq!(
        decode::<ToAgent>(&[0x80, 0x01, 2, 7]),
        Err(CodecError::UnsupportedVersion { found: 128, supported })
    );
    assert_eq!(decode::<ToAgent>(&[0, 2, 7]), Err(CodecError::UnsupportedVersion { found: 0, supported }));
}

#[test]
fn unknown_variant() {
    assert_eq!(decode::<ToAgent>(&[V, 9]), Err(CodecError::UnknownVariant));
    assert_eq!(decode::<FromAgent>(&[V, 11, 1, 1]), Err(CodecError::UnknownVariant));
    // Telemetry with DriveState 4.
    let mut telemetry = vec![V, 4, 1, 1, 4, 1];
    telemetry.extend_from_slice(&[0; 40]);
    assert_eq!(decode::<FromAgent>(&telemetry), Err(CodecError::UnknownVariant));
    assert_eq!(decode::<FromAgent>(&[V, 0, 1, 7, 2, 0]), Err(CodecError::UnknownVariant)); // RobotKind 7
    let mut gate = vec![V, 1, 9]; // GateKind 9
    gate.extend_from_slice(&[0; 17]);
    assert_eq!(decode::<GateEvent>(&gate), Err(CodecError::UnknownVariant));
}

#[test]
fn malformed() {
    // Stopped { arrived } with a bool byte of 2.
    let mut gate = vec![V, 1, 1, 2];
    gate.extend_from_slice(&[0; 17]);
    assert_eq!(decode::<GateEvent>(&gate), Err(CodecError::Malformed));
    // A version varint that never terminates within a u16.
    assert_eq!(decode::<ToAgent>(&[0xFF, 0xFF, 0xFF, 0xFF]), Err(CodecError::Malformed));
    // A robot id varint that overflows u32.
    let too_big = [V, 1, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x7F];
    assert_eq!(decode::<FromAgent>(&too_big), Err(CodecError::Malformed));
}

#[test]
fn errors_explain_themselves() {
    let err: &dyn core::error::Error =
        &CodecError::UnsupportedVersion { found: 1, supported: PROTOCOL_VERSION };
    assert_eq!(err.to_string(), "unsupported protocol version 1 (this build speaks 3)");
    for e in [
        CodecError::BufferTooSmall,
        CodecError::Truncated,
        CodecError::TrailingBytes { extra: 1 },
        CodecError::UnknownVariant,
        CodecError::Malformed,
        CodecError::NonCanonical,
        CodecError::Serialize,
    ] {
        assert!(!e.to_string().is_empty());
    }
}
