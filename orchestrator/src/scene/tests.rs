//! The scene from messages: what each input produces, and that every output
//! encodes with its schema and decodes back.

use super::*;
use bycoms_protocol::msg::{GateKind, Status};
use bycoms_protocol::RobotId;
use foxglove::Decode;

fn world() -> SceneWorld {
    let mut terrain = Terrain::new(20, 10);
    for (ix, iy) in [(3, 4), (4, 4), (5, 4), (9, 2), (12, 7), (13, 7)] {
        terrain.set_blocked(ix, iy, true);
    }
    SceneWorld { terrain, eps: 2.5, goal_radius: 0.5 }
}

fn pose(k: u32, x: f64, y: f64, step: u64) -> Pose {
    Pose { robot: RobotId(k), x, y, heading: 0.3, step, time_us: step * 100_000 }
}

fn scene_of(out: &[Out]) -> Vec<&SceneUpdate> {
    out.iter()
        .filter_map(|o| match &o.message {
            Message::Scene(s) => Some(s),
            _ => None,
        })
        .collect()
}

fn ids(update: &SceneUpdate) -> Vec<&str> {
    update.entities.iter().map(|e| e.id.as_str()).collect()
}

#[test]
fn the_world_has_arena_terrain_start_and_goal_and_boxes_cover_exactly_the_blocked_cells() {
    let scene = Scene::new("s", world());
    let out = scene.world(7);
    let updates = scene_of(&out);
    assert_eq!(updates.len(), 1);
    assert_eq!(ids(updates[0]), ["arena", "terrain", "start", "goal"]);
    let terrain = &updates[0].entities[1];
    // Three runs of blocked cells: (3..6, 4), (9, 2), (12..14, 7).
    assert_eq!(terrain.cubes.len(), 3);
    let area: f64 = terrain.cubes.iter().map(|c| c.size.map_or(0.0, |s| s.x * s.y)).sum();
    assert_eq!(area, world().terrain.blocked_count() as f64);
    assert!(updates[0].entities.iter().all(|e| e.frame_id == ARENA_FRAME && e.timestamp == Some(stamp(7))));
}

#[test]
fn a_pose_draws_the_robot_its_path_and_its_frame_and_a_still_pose_only_its_json() {
    let mut scene = Scene::new("s", world());
    let first = scene.pose(&pose(1, 5.0, 5.0, 0), 1);
    let topics: Vec<&str> = first.iter().map(|o| o.topic.as_str()).collect();
    assert_eq!(topics, ["bycoms/s/robot/1/pose/json", "bycoms/s/scene", "bycoms/s/tf"]);
    assert_eq!(ids(scene_of(&first)[0]), ["robot/1"], "one point is no path yet");
    let second = scene.pose(&pose(1, 5.1, 5.0, 1), 2);
    assert_eq!(ids(scene_of(&second)[0]), ["robot/1", "robot/1/path/0"]);
    let still = scene.pose(&pose(1, 5.1, 5.0, 2), 3);
    assert_eq!(still.len(), 1, "a frozen pose moves nothing: {still:?}");
    let Message::Pose(p) = &still[0].message else { panic!("pose JSON") };
    assert_eq!((p.robot, p.x, p.step), (1, 5.1, 2));
    assert!((p.time_s - 0.2).abs() < 1e-12);
}

#[test]
fn a_long_path_is_sent_in_pieces_that_join_up() {
    let mut scene = Scene::new("s", world());
    let n = 2 * PATH_PIECE + 31;
    for i in 0..n {
        let out = scene.pose(&pose(2, 1.0 + i as f64 * 0.01, 1.0, i as u64), i as u64);
        // Each pose re-sends at most one piece.
        let lines: usize = scene_of(&out).iter().flat_map(|u| &u.entities).map(|e| e.lines.len()).sum();
        assert!(lines <= 1, "pose {i}: {lines} lines");
    }
    let snap = scene.snapshot(99);
    let update = scene_of(&snap)[1];
    let pieces: Vec<&SceneEntity> = update.entities.iter().filter(|e| e.id.contains("/path/")).collect();
    assert_eq!(pieces.len(), 3);
    let total: usize = pieces.iter().map(|e| e.lines[0].points.len()).sum();
    assert_eq!(total, n + 2, "every point once, plus the two shared joints");
    for pair in pieces.windows(2) {
        let (a, b) = (pair[0].lines[0].points.last(), pair[1].lines[0].points.first());
        assert_eq!(a, b, "pieces join up");
    }
}

#[test]
fn a_stuck_robot_becomes_a_beacon_with_its_eps_circle_and_an_arrival_does_not() {
    let mut scene = Scene::new("s", world());
    scene.pose(&pose(1, 8.0, 3.0, 5), 5);
    let stuck =
        GateEvent { robot: RobotId(1), kind: GateKind::Stopped { arrived: false }, x: 8.0, y: 3.0, step: 9 };
    let out = scene.gate(&stuck, 9);
    let Message::Log(line) = &out[1].message else { panic!("a log line") };
    assert_eq!(line.level, log::Level::Info as i32);
    assert!(line.message.contains("robot 1 stuck"), "{}", line.message);
    let update = scene_of(&out)[0];
    assert_eq!(ids(update), ["robot/1", "robot/1/beacon"]);
    let ring = &update.entities[1].lines[0];
    for p in &ring.points {
        let r = ((p.x - 8.0).powi(2) + (p.y - 3.0).powi(2)).sqrt();
        assert!((r - 2.5).abs() < 1e-9, "ε circle radius {r}");
    }
    assert!(ids(scene_of(&scene.snapshot(10))[1]).contains(&"robot/1/beacon"));

    scene.pose(&pose(2, 17.0, 8.0, 20), 20);
    let won =
        GateEvent { robot: RobotId(2), kind: GateKind::Stopped { arrived: true }, x: 17.0, y: 8.0, step: 21 };
    let out = scene.gate(&won, 21);
    assert_eq!(ids(scene_of(&out)[0]), ["robot/2"]);
    let died = GateEvent { kind: GateKind::Died, ..stuck };
    let Message::Log(line) = &scene.gate(&died, 30)[1].message else { panic!("a log line") };
    assert_eq!(line.level, log::Level::Warning as i32);
}

#[test]
fn status_reports_give_the_mode_and_telemetry() {
    let mut scene = Scene::new("s", world());
    let out = scene.report(&FromAgent::Status(Status { robot: RobotId(3), mode: 2, step: 40 }), 4);
    let topics: Vec<&str> = out.iter().map(|o| o.topic.as_str()).collect();
    assert_eq!(topics, ["bycoms/s/robot/3/mode", "bycoms/s/robot/3/telemetry"]);
    let Message::Mode(m) = &out[0].message else { panic!("mode") };
    assert_eq!((m.mode, m.name, m.step), (2, "bypass", 40));
}

#[test]
fn every_message_encodes_with_its_schema_and_decodes_back() {
    let mut scene = Scene::new("s", world());
    let mut out = scene.world(1);
    out.extend(scene.pose(&pose(1, 5.0, 5.0, 0), 2));
    out.extend(scene.pose(&pose(1, 5.5, 5.0, 1), 3));
    let event =
        GateEvent { robot: RobotId(1), kind: GateKind::Stopped { arrived: false }, x: 5.5, y: 5.0, step: 1 };
    out.extend(scene.gate(&event, 4));
    out.extend(scene.report(&FromAgent::Status(Status { robot: RobotId(1), mode: 1, step: 1 }), 5));
    let mut schemas = std::collections::BTreeSet::new();
    for o in &out {
        let schema = o.message.schema().expect("every channel has a schema");
        let bytes = o.message.encode().expect("encodes");
        schemas.insert(schema.name.clone());
        match &o.message {
            Message::Scene(s) => {
                assert_eq!(
                    (schema.name.as_str(), o.message.encoding().as_str()),
                    ("foxglove.SceneUpdate", "protobuf")
                );
                assert_eq!(&SceneUpdate::decode(bytes.as_slice()).expect("decodes"), s);
            }
            Message::Transforms(f) => assert_eq!(&FrameTransforms::decode(bytes.as_slice()).expect("tf"), f),
            Message::Log(l) => assert_eq!(&Log::decode(bytes.as_slice()).expect("log"), l),
            _ => {
                assert_eq!((schema.encoding.as_str(), o.message.encoding().as_str()), ("jsonschema", "json"));
                let _: serde_json::Value = serde_json::from_slice(&bytes).expect("JSON");
            }
        }
    }
    let want = [
        "bycoms.GateDecision",
        "bycoms.RobotMode",
        "bycoms.RobotPose",
        "bycoms.Telemetry",
        "foxglove.FrameTransforms",
        "foxglove.Log",
        "foxglove.SceneUpdate",
    ];
    assert_eq!(schemas.into_iter().collect::<Vec<_>>(), want);
}
