//! NatNet packets (`protocol::natnet`): any datagram, read as NatNet 4.0 or
//! 4.1 (first input byte), is either refused with a typed error or parses
//! to a packet that encodes, parses again and re-encodes to the same bytes
//! (compared as bytes, so NaN coordinates do not break equality).
#![no_main]

use bycoms_protocol::natnet::{encode_packet, parse_packet_versioned, Version};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&which, bytes)) = data.split_first() else { return };
    let version = if which & 1 == 0 { Version::V4_1 } else { Version::V4_0 };
    let Ok(packet) = parse_packet_versioned(bytes, version) else { return };
    let encoded = encode_packet(&packet, version).expect("a parsed packet encodes");
    let again = parse_packet_versioned(&encoded, version).expect("an encoded packet parses");
    let reencoded = encode_packet(&again, version).expect("encodes again");
    assert_eq!(encoded, reencoded, "parse → encode → parse → encode is stable");
});
