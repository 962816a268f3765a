//! Bus codec: any bytes given to `decode` for any message type either fail
//! with a `CodecError` or give a message that re-encodes, within
//! `MAX_MESSAGE_LEN` bytes, to exactly the bytes it was decoded from (one
//! message, one encoding: a non-canonical spelling such as an overlong
//! varint must have been refused), and decodes again to the same bytes.
#![no_main]

use bycoms_protocol::msg::{FromAgent, GateEvent, Pose, Sensor, ToAgent};
use bycoms_protocol::{decode, encode, Message, MAX_MESSAGE_LEN};
use libfuzzer_sys::fuzz_target;

fn round_trip<T: Message>(data: &[u8]) {
    let Ok(msg) = decode::<T>(data) else { return };
    let mut first = [0u8; MAX_MESSAGE_LEN];
    let encoded = encode(&msg, &mut first).expect("a decoded message re-encodes within MAX_MESSAGE_LEN");
    assert_eq!(encoded, data, "decode → encode gives back the input: only canonical bytes decode");
    let again: T = decode(encoded).expect("a re-encoded message decodes");
    let mut second = [0u8; MAX_MESSAGE_LEN];
    let reencoded = encode(&again, &mut second).expect("re-encodes");
    assert_eq!(encoded, reencoded, "decode → encode → decode → encode is stable");
}

fuzz_target!(|data: &[u8]| {
    round_trip::<ToAgent>(data);
    round_trip::<FromAgent>(data);
    round_trip::<Pose>(data);
    round_trip::<Sensor>(data);
    round_trip::<GateEvent>(data);
});
