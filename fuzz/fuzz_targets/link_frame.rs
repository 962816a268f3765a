//! Robot-link frames (`protocol::link::decode`): any datagram is either
//! dropped with a reason or decodes to a frame that encodes back to exactly
//! the same bytes, and that the other side, or another key, refuses.
//!
//! The fuzzer cannot forge HMAC tags, so for half of the inputs (first byte
//! odd) the target signs the body itself, with the RustCrypto `hmac` crate
//! directly (an independent check of `LinkKey`'s construction), and takes
//! the robot id from the frame: that lets the fuzzer reach the payload
//! parsing behind the tag check.
#![no_main]

use bycoms_protocol::link::{
    decode, encode, Direction, DropReason, LinkKey, HEADER_LEN, MAX_FRAME_LEN, TAG_LEN,
};
use bycoms_protocol::RobotId;
use hmac::{Hmac, Mac};
use libfuzzer_sys::fuzz_target;
use sha2::Sha256;

const KEY: [u8; 32] = [0x5a; 32];

fn sign(frame: &mut [u8]) {
    let body_len = frame.len() - TAG_LEN;
    let mut mac = <Hmac<Sha256> as Mac>::new_from_slice(&KEY).expect("any key length");
    mac.update(&frame[..body_len]);
    let tag = mac.finalize().into_bytes();
    frame[body_len..].copy_from_slice(&tag[..TAG_LEN]);
}

fuzz_target!(|data: &[u8]| {
    let Some((&control, rest)) = data.split_first() else { return };
    let mut bytes = rest.to_vec();
    let to = if control & 2 == 0 { Direction::ToGateway } else { Direction::ToRobot };
    let mut robot = RobotId(1);
    if control & 1 == 1 && bytes.len() >= HEADER_LEN + TAG_LEN {
        sign(&mut bytes);
        robot = RobotId(u32::from_le_bytes([bytes[2], bytes[3], bytes[4], bytes[5]]));
    }
    let key = LinkKey::new(&KEY);
    let Ok(frame) = decode(&bytes, &key, robot, to) else { return };
    let mut buf = [0u8; MAX_FRAME_LEN];
    let encoded = encode(&frame, &key, &mut buf).expect("a decoded frame encodes");
    assert_eq!(encoded, &bytes[..], "decode → encode gives the same bytes");
    let other_side = if to == Direction::ToGateway { Direction::ToRobot } else { Direction::ToGateway };
    assert_eq!(decode(&bytes, &key, robot, other_side), Err(DropReason::WrongDirection));
    let other_key = LinkKey::new(&[0xa5; 32]);
    assert_eq!(decode(&bytes, &other_key, robot, to), Err(DropReason::BadTag));
});
