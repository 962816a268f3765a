//! NatNet frame parsing: ns per frame with 50 rigid bodies (and their
//! 5-marker marker sets, as Motive streams them).
//!
//! Run: `cargo bench -p bycoms-protocol --features natnet --bench natnet_parse`.

use bycoms_protocol::natnet::{
    encode_packet, parse_packet, FrameOfData, MarkerSet, Packet, RigidBody, Version, TRACKING_VALID,
};

fn main() {
    divan::main();
}

fn frame(bodies: usize, with_markers: bool) -> Vec<u8> {
    let frame = FrameOfData {
        frame_number: 1234,
        rigid_bodies: (0..bodies)
            .map(|k| RigidBody {
                id: k as i32 + 1,
                position: [k as f32 * 0.1, 0.05, -1.0],
                orientation: [0.0, 0.38, 0.0, 0.92],
                mean_error: 0.0003,
                params: TRACKING_VALID,
            })
            .collect(),
        marker_sets: if with_markers {
            (0..bodies)
                .map(|k| MarkerSet { name: format!("robot{k}"), markers: vec![[0.1, 0.2, 0.3]; 5] })
                .collect()
        } else {
            Vec::new()
        },
        ..FrameOfData::default()
    };
    encode_packet(&Packet::FrameOfData(frame), Version::V4_1).unwrap()
}

#[divan::bench(args = [false, true])]
fn parse_frame_50_rigid_bodies(bencher: divan::Bencher, with_marker_sets: bool) {
    let bytes = frame(50, with_marker_sets);
    bencher
        .counter(divan::counter::BytesCount::new(bytes.len()))
        .bench(|| parse_packet(divan::black_box(&bytes)).unwrap());
}
