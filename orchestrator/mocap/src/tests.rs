//! The required cases, through the real bytes: the emulated lab's
//! frame maker (with its seeded faults) → NatNet encode → parse → pipeline
//! → the deployment gate's `Watch`. Each case also runs the naive path
//! (every streamed pose believed) to show the trap is real.

use super::testing::{lab, udp_config, RATE, SCALE};
use super::*;
use bycoms_natnet_server::{model_definitions, BodyPose, Faults, FrameMaker, Occlusion, OcclusionMode, Swap};
use bycoms_protocol::msg::Pose;
use bycoms_protocol::natnet::{
    encode_packet, parse_packet, DataDescription, ModelDefinitions, Packet, Version,
};
use bycoms_protocol::RobotId;
use bycoms_sim::Vec2;
use bycoms_study::gate::{GateParams, Verdict, Watch};
use std::collections::BTreeMap;
use std::time::Duration;

fn pipeline(defs: &ModelDefinitions) -> FramePipeline {
    let robots = BTreeMap::from([("robot1".to_string(), RobotId(1)), ("robot2".to_string(), RobotId(2))]);
    let tracker = TrackerConfig { max_speed: 1.5, jump_slack: 0.2, lost_after_us: 500_000 };
    let bodies = BodyMap::resolve(defs, &robots);
    let transform = ArenaTransform { scale: SCALE, ..ArenaTransform::default() };
    FramePipeline::new(transform, bodies, PoseTracker::new(tracker, [RobotId(1), RobotId(2)]))
}

/// Streams `seconds` of the lab with true poses from `motion(t)`, returns
/// the pipeline's batches and the naive poses (every body believed).
fn run(faults: Faults, seconds: f64, motion: impl Fn(f64) -> [BodyPose; 2]) -> (Vec<PoseBatch>, Vec<Pose>) {
    let config = lab(faults);
    let defs = model_definitions(&config);
    let mut pipe = pipeline(&defs);
    let mut maker = FrameMaker::new(config);
    let naive_transform = ArenaTransform { scale: SCALE, ..ArenaTransform::default() };
    let (mut batches, mut naive) = (Vec::new(), Vec::new());
    for k in 0..(seconds * RATE) as u64 {
        let t = k as f64 / RATE;
        let Some(frame) = maker.next_frame(&motion(t)) else { continue };
        let bytes = encode_packet(&Packet::FrameOfData(frame), Version::V4_1).unwrap();
        let Ok(Packet::FrameOfData(frame)) = parse_packet(&bytes) else { panic!("frame does not parse") };
        for b in &frame.rigid_bodies {
            let robot = RobotId(u32::try_from(b.id - 10).unwrap());
            let p = naive_transform.to_arena(b.position, b.orientation).unwrap_or(ArenaPose {
                x: 0.0,
                y: 0.0,
                heading: 0.0,
            });
            naive.push(Pose {
                robot,
                x: p.x,
                y: p.y,
                heading: p.heading,
                step: k,
                time_us: (t * 1e6).round() as u64,
            });
        }
        batches.push(pipe.on_frame(&frame));
    }
    (batches, naive)
}

fn gate() -> GateParams {
    GateParams {
        goal: Vec2::new(100.0, 0.0),
        goal_radius: 0.5,
        stop_speed: 0.2,
        stop_turn_rate: 0.0,
        dwell_us: 500_000,
        period_us: 100_000,
    }
}

/// Feeds one robot's poses to a gate watch; the verdict and its time.
fn judge(poses: impl Iterator<Item = Pose>, robot: RobotId) -> Option<(Verdict, u64)> {
    let mut poses = poses.filter(|p| p.robot == robot);
    let mut watch = Watch::new(gate(), poses.next()?);
    poses.find_map(|p| watch.observe(p).map(|v| (v, p.time_us)))
}

/// Robot 1 drives +X at 0.1 m/s (1 unit/s) for 6 s, then stops; robot 2 stands.
fn drive_then_stop(t: f64) -> [BodyPose; 2] {
    [BodyPose::yawed([0.1 * t.min(6.0) as f32, 0.0, 0.0], 0.0), BodyPose::yawed([2.0, 0.0, 0.0], 0.0)]
}

#[test]
fn twenty_percent_loss_and_a_one_second_occlusion_of_the_moving_robot_give_no_false_stop() {
    let (clean, _) = run(Faults::default(), 9.0, drive_then_stop);
    let (Verdict::Stuck(clean_at), clean_us) =
        judge(clean.iter().flat_map(|b| b.poses.clone()), RobotId(1)).unwrap()
    else {
        panic!("the clean run must end stuck")
    };
    assert!((6_500_000..6_520_000).contains(&clean_us), "stopped at 6 s + 0.5 s dwell, judged at {clean_us}");
    for mode in [OcclusionMode::Invalid, OcclusionMode::Missing] {
        let faults = Faults {
            seed: 42,
            frame_loss: 0.2,
            occlusions: vec![Occlusion { id: 11, from_s: 2.0, to_s: 3.0, mode }],
            ..Faults::default()
        };
        let (batches, naive) = run(faults, 9.0, drive_then_stop);
        let lost = batches.iter().filter(|b| b.step > 0).count() as f64 / (9.0 * RATE);
        assert!((0.75..0.85).contains(&lost), "{mode:?}: {lost} of frames kept");
        let verdict = judge(batches.iter().flat_map(|b| b.poses.clone()), RobotId(1));
        let Some((Verdict::Stuck(at), us)) = verdict else { panic!("{mode:?}: {verdict:?}") };
        assert!(
            (6_500_000..6_600_000).contains(&us),
            "{mode:?}: judged at {us} µs, not during the occlusion"
        );
        assert!(
            (at.x - clean_at.x).abs() < 1e-6 && (at.y - clean_at.y).abs() < 1e-6,
            "same outcome: stuck at 6.0"
        );
        let events: Vec<_> = batches.iter().flat_map(|b| b.events.clone()).collect();
        assert!(
            matches!(events.first(), Some(TrackEvent::Lost { robot: RobotId(1), since_us }) if (1_950_000..2_000_000).contains(since_us)),
            "{events:?}"
        );
        assert!(
            matches!(events.get(1), Some(TrackEvent::Recovered { robot: RobotId(1), at_us }) if (3_000_000..3_100_000).contains(at_us)),
            "{events:?}"
        );
        // The trap is real: believing every streamed pose stops the robot mid-occlusion.
        if mode == OcclusionMode::Invalid {
            let naive_verdict = judge(naive.iter().copied(), RobotId(1));
            assert!(
                matches!(naive_verdict, Some((Verdict::Stuck(_), us)) if (2_000_000..3_000_000).contains(&us)),
                "{naive_verdict:?}"
            );
        }
    }
}

/// Robot 1 is stuck at the origin; robot 2 drives −Z (arena +y) at 0.1 m/s
/// until 7 s; their ids are swapped from 3 s to 5 s.
fn one_stuck_one_driving(t: f64) -> [BodyPose; 2] {
    [BodyPose::yawed([0.0; 3], 0.0), BodyPose::yawed([2.0, 0.0, -0.1 * t.min(7.0) as f32], 0.0)]
}

#[test]
fn an_injected_swap_of_two_bodies_never_feeds_one_robot_the_others_pose() {
    let faults = Faults { swaps: vec![Swap { a: 11, b: 12, from_s: 3.0, to_s: 5.0 }], ..Faults::default() };
    let (batches, naive) = run(faults, 9.0, one_stuck_one_driving);
    let truth = |robot: RobotId, time_us: u64| {
        let [a, b] = one_stuck_one_driving(time_us as f64 * 1e-6);
        let p = if robot == RobotId(1) { a.position } else { b.position };
        (f64::from(p[0]) * SCALE, -f64::from(p[2]) * SCALE)
    };
    let poses: Vec<Pose> = batches.iter().flat_map(|b| b.poses.clone()).collect();
    for p in &poses {
        let (x, y) = truth(p.robot, p.time_us);
        assert!(
            (p.x - x).hypot(p.y - y) < 1e-3,
            "robot {} judged from another pose at {} µs",
            p.robot,
            p.time_us
        );
    }
    let rejected: Vec<_> = batches
        .iter()
        .flat_map(|b| b.events.clone())
        .filter_map(|e| match e {
            TrackEvent::JumpRejected { robot, at_us, .. } => Some((robot, at_us)),
            _ => None,
        })
        .collect();
    for robot in [RobotId(1), RobotId(2)] {
        assert!(
            rejected.iter().any(|&(r, at)| r == robot && (3_000_000..5_000_000).contains(&at)),
            "{robot}: {rejected:?}"
        );
    }
    assert!(rejected.iter().all(|&(_, at)| (3_000_000..5_000_000).contains(&at)), "only inside the swap");
    // Robot 2 keeps driving through the swap: no stop until it really stops at 7 s.
    let r2 = judge(poses.iter().copied(), RobotId(2));
    assert!(matches!(r2, Some((Verdict::Stuck(_), us)) if us >= 7_500_000), "{r2:?}");
    // The trap is real: believed naively, robot 1 was seen at robot 2's place.
    assert!(naive.iter().any(|p| p.robot == RobotId(1) && p.x > 19.0));
}

#[test]
fn model_definitions_of_the_lab_resolve_all_robots() {
    let defs = model_definitions(&lab(Faults::default()));
    assert_eq!(defs.descriptions.iter().filter(|d| matches!(d, DataDescription::RigidBody(_))).count(), 2);
    let robots = BTreeMap::from([("robot1".to_string(), RobotId(1)), ("robot9".to_string(), RobotId(9))]);
    let map = BodyMap::resolve(&defs, &robots);
    assert_eq!(map.missing, ["robot9"]);
}

#[test]
fn the_natnet_source_reads_the_emulated_lab_over_udp() {
    use bycoms_natnet_server::NatNetServer;
    use std::net::Ipv4Addr;
    let server = NatNetServer::start_any_port(lab(Faults::default()), Ipv4Addr::LOCALHOST.into()).unwrap();
    let config = udp_config(&server);
    let mut source = NatNetPoseSource::connect(&config).unwrap();
    let batch = (0..50)
        .find_map(|_| source.poll(Duration::from_millis(200)).unwrap().filter(|b| b.poses.len() == 2))
        .expect("a frame with both robots within 10 s");
    assert_eq!((batch.poses[0].robot, batch.poses[0].x, batch.poses[0].y), (RobotId(1), 0.0, 0.0));
    assert_eq!((batch.poses[1].robot, batch.poses[1].x), (RobotId(2), 20.0));
    let missing =
        NatNetSourceConfig { bodies: BTreeMap::from([("robot7".to_string(), RobotId(7))]), ..config };
    let err = NatNetPoseSource::connect(&missing).err().expect("robot7 is not defined");
    assert!(err.to_string().contains("robot7"), "{err}");
}
