//! Mocap frame received → trusted arena poses out: the NatNet bytes of a
//! 50-body frame parsed, names mapped, converted and tracked.
//!
//! Run: `cargo bench -p bycoms-orchestrator --bench mocap_frame`.

use bycoms_mocap::{ArenaTransform, BodyMap, FramePipeline, PoseTracker, TrackerConfig};
use bycoms_natnet_server::{model_definitions, BodyConfig, BodyPose, Faults, FrameMaker, ServerConfig};
use bycoms_protocol::natnet::{encode_packet, parse_packet, Packet, Version};
use bycoms_protocol::RobotId;
use std::collections::BTreeMap;

fn main() {
    divan::main();
}

const BODIES: usize = 50;

fn lab() -> ServerConfig {
    ServerConfig {
        rate_hz: 120.0,
        app_name: "bench".into(),
        multicast: None,
        bodies: (0..BODIES)
            .map(|k| BodyConfig {
                name: format!("robot{}", k + 1),
                id: k as i32 + 1,
                position: [0.1 * k as f32, 0.0, 0.0],
                yaw_deg: 0.0,
            })
            .collect(),
        faults: Faults::default(),
    }
}

#[divan::bench]
fn frame_bytes_to_trusted_arena_poses_50_bodies(bencher: divan::Bencher) {
    let config = lab();
    let defs = model_definitions(&config);
    let robots: BTreeMap<String, RobotId> =
        (0..BODIES).map(|k| (format!("robot{}", k + 1), RobotId(k as u32 + 1))).collect();
    let tracker = TrackerConfig { max_speed: 1.5, jump_slack: 0.2, lost_after_us: 500_000 };
    let mut pipeline = FramePipeline::new(
        ArenaTransform { scale: 10.0, ..ArenaTransform::default() },
        BodyMap::resolve(&defs, &robots),
        PoseTracker::new(tracker, robots.values().copied()),
    );
    let mut maker = FrameMaker::new(config.clone());
    let poses: Vec<BodyPose> = config.bodies.iter().map(|b| BodyPose::yawed(b.position, 0.3)).collect();
    // A stream of distinct frames (advancing timestamps), encoded once.
    let frames: Vec<Vec<u8>> = (0..1024)
        .map(|_| {
            encode_packet(&Packet::FrameOfData(maker.next_frame(&poses).unwrap()), Version::V4_1).unwrap()
        })
        .collect();
    let mut k = 0;
    bencher.bench_local(|| {
        let bytes = &frames[k % frames.len()];
        k += 1;
        let Ok(Packet::FrameOfData(frame)) = parse_packet(divan::black_box(bytes)) else {
            panic!("bad frame")
        };
        let batch = pipeline.on_frame(&frame);
        assert_eq!(batch.poses.len(), BODIES);
        batch
    });
}
