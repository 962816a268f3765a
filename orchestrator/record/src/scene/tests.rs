//! The scene from messages: what each input produces, and that every output
//! encodes with its schema and decodes back.

use super::*;
use bycoms_protocol::msg::{GateKind, Status};
use bycoms_protocol::RobotId;
use foxglove::messages::scene_entity_deletion;
use foxglove::Decode;
use json::RobotSlot;

fn world() -> SceneWorld {
    let mut terrain = Terrain::new(20, 10);
    for (ix, iy) in [(3, 4), (4, 4), (5, 4), (9, 2), (12, 7), (13, 7)] {
        terrain.set_blocked(ix, iy, true);
    }
    SceneWorld { terrain, eps: 2.5, goal_radius: 0.5, real: Vec::new() }
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
fn a_pose_draws_the_robot_its_path_and_its_frame_and_a_still_pose_sends_nothing() {
    let mut scene = Scene::new("s", world());
    let first = scene.pose(&pose(1, 5.0, 5.0, 0), 1);
    let topics: Vec<&str> = first.iter().map(|o| o.topic.as_str()).collect();
    assert_eq!(topics, ["bycoms/s/robot/1/pose/json", "bycoms/s/scene", "bycoms/s/tf"]);
    assert_eq!(ids(scene_of(&first)[0]), ["robot/1"], "one point is no path yet");
    let second = scene.pose(&pose(1, 5.1, 5.0, 1), 2);
    assert_eq!(ids(scene_of(&second)[0]), ["robot/1", "robot/1/path/0"]);
    let Message::Pose(p) = &second[0].message else { panic!("pose JSON") };
    assert_eq!((p.robot, p.x, p.step), (1, 5.1, 1));
    assert!((p.time_s - 0.1).abs() < 1e-12);
    let still = scene.pose(&pose(1, 5.1, 5.0, 2), 3);
    assert!(still.is_empty(), "a frozen pose changes nothing, so sends nothing: {still:?}");
    let turned = scene.pose(&Pose { heading: 1.0, ..pose(1, 5.1, 5.0, 3) }, 4);
    let topics: Vec<&str> = turned.iter().map(|o| o.topic.as_str()).collect();
    assert_eq!(
        topics,
        ["bycoms/s/robot/1/pose/json", "bycoms/s/scene", "bycoms/s/tf"],
        "turning is a change"
    );
    assert_eq!(ids(scene_of(&turned)[0]), ["robot/1", "robot/1/path/0"]);
}

/// A mixed swarm's scene: a robot with a real body is a box, a simulated
/// one a ball, in every update that draws it (pose, gate decision, snapshot).
#[test]
fn a_real_robot_is_drawn_as_a_box_and_a_simulated_one_as_a_ball() {
    let mut scene = Scene::new("s", SceneWorld { real: vec![2], ..world() });
    let marker = |out: &[Out], k: u32| {
        let id = format!("robot/{k}");
        let update = scene_of(out).into_iter().find(|u| ids(u).contains(&id.as_str())).expect("drawn");
        let e = update.entities.iter().find(|e| e.id == id).expect("its entity");
        (e.cubes.len(), e.spheres.len())
    };
    assert_eq!(marker(&scene.pose(&pose(1, 5.0, 5.0, 0), 1), 1), (0, 1), "simulated: a ball");
    assert_eq!(marker(&scene.pose(&pose(2, 6.0, 5.0, 0), 2), 2), (1, 0), "real: a box");
    let stuck =
        GateEvent { robot: RobotId(2), kind: GateKind::Stopped { arrived: false }, x: 6.0, y: 5.0, step: 9 };
    assert_eq!(marker(&scene.gate(&stuck, 3), 2), (1, 0), "still a box as a beacon");
    let snapshot = scene.snapshot(4);
    assert_eq!((marker(&snapshot, 1), marker(&snapshot, 2)), ((0, 1), (1, 0)));
}

/// A robot's colour is its state as the launch core said it, not the
/// gate's: one revoked or lost before its deployment (no gate decision) is
/// drawn lost, its state goes out as JSON, and a gate decision alone
/// recolours nothing.
#[test]
fn a_robot_is_coloured_by_the_state_the_core_said() {
    let mut scene = Scene::new("s", world());
    let colour = |out: &[Out], k: u32| {
        let id = format!("robot/{k}");
        let update = scene_of(out).into_iter().find(|u| ids(u).contains(&id.as_str())).expect("drawn");
        let e = update.entities.iter().find(|e| e.id == id).expect("its entity");
        e.spheres[0].color
    };
    let first = scene.pose(&pose(1, 5.0, 5.0, 0), 1);
    assert_eq!(colour(&first, 1), Some(palette(1)));
    let lost = scene.state(1, SlotState::Lost, 2);
    assert_eq!(lost[0].topic, "bycoms/s/robot/1/state");
    assert_eq!(lost[0].message, Message::State(RobotSlot { robot: 1, state: SlotState::Lost }));
    assert_eq!(lost[0].message.encode().ok(), Some(br#"{"robot":1,"state":"lost"}"#.to_vec()));
    assert_eq!(colour(&lost, 1), Some(rgba(DIED, 1.0)), "lost before its deployment");
    assert_eq!(colour(&scene.snapshot(3), 1), Some(rgba(DIED, 1.0)));
    let unseen = scene.state(2, SlotState::Stuck, 4);
    assert_eq!(unseen.len(), 1, "its JSON only: robot 2 is not drawn before its first pose");
    let stuck =
        GateEvent { robot: RobotId(2), kind: GateKind::Stopped { arrived: false }, x: 6.0, y: 5.0, step: 9 };
    scene.pose(&pose(2, 6.0, 5.0, 0), 5);
    scene.pose(&pose(3, 7.0, 5.0, 0), 5);
    assert_eq!(colour(&scene.gate(&stuck, 6), 2), Some(rgba(STUCK, 1.0)), "its state, said before");
    let arrived = GateEvent { robot: RobotId(3), kind: GateKind::Stopped { arrived: true }, ..stuck };
    assert_eq!(colour(&scene.gate(&arrived, 7), 3), Some(palette(3)), "the gate's word alone");
    assert_eq!(colour(&scene.state(3, SlotState::Arrived, 8), 3), Some(rgba(ARRIVED, 1.0)));
}

#[test]
fn a_long_path_is_sent_in_pieces_that_join_up() {
    let mut scene = Scene::new("s", world());
    let n = 2 * PATH_PIECE + PATH_PIECE / 2 + 1;
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

/// The ε circle of robot `k`'s beacon in `update`, and whether every point
/// of it lies ε = 2.5 from (`x`, `y`).
fn ring_around(update: &SceneUpdate, k: u32, x: f64, y: f64) -> bool {
    let id = format!("robot/{k}/beacon");
    let Some(e) = update.entities.iter().find(|e| e.id == id) else { return false };
    e.lines[0].points.iter().all(|p| (((p.x - x).powi(2) + (p.y - y).powi(2)).sqrt() - 2.5).abs() < 1e-9)
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
    assert_eq!(ids(scene_of(&out)[0]), ["robot/1"], "the core says where its beacon stands");
    let out = scene.beacon(1, Vec2::new(8.0, 3.0), 9);
    let Message::Beacon(json) = &out[0].message else { panic!("the beacon's JSON") };
    assert_eq!((out[0].topic.as_str(), json.robot, json.x), ("bycoms/s/beacon/json", 1, 8.0));
    let update = scene_of(&out)[0];
    assert_eq!(ids(update), ["robot/1/beacon"]);
    assert!(ring_around(update, 1, 8.0, 3.0), "its ε circle");
    assert!(ring_around(scene_of(&scene.snapshot(10))[1], 1, 8.0, 3.0));

    scene.pose(&pose(2, 17.0, 8.0, 20), 20);
    let won =
        GateEvent { robot: RobotId(2), kind: GateKind::Stopped { arrived: true }, x: 17.0, y: 8.0, step: 21 };
    let out = scene.gate(&won, 21);
    assert_eq!(ids(scene_of(&out)[0]), ["robot/2"]);
    let died = GateEvent { kind: GateKind::Died, ..stuck };
    let Message::Log(line) = &scene.gate(&died, 30)[1].message else { panic!("a log line") };
    assert_eq!(line.level, log::Level::Warning as i32);
}

/// The bug issue 53 names: the scene placed a beacon where the gate judged
/// it and kept it there, while the core's beacon crept on with a robot
/// judged stuck that still crept. Now its circle stands where the core
/// says, bit for bit, in the updates and in a late viewer's snapshot; the
/// same place again sends nothing.
#[test]
fn a_beacon_creeps_as_the_core_says() {
    let mut scene = Scene::new("s", world());
    scene.pose(&pose(1, 8.0, 3.0, 5), 5);
    let stuck =
        GateEvent { robot: RobotId(1), kind: GateKind::Stopped { arrived: false }, x: 8.0, y: 3.0, step: 9 };
    scene.gate(&stuck, 9);
    scene.beacon(1, Vec2::new(8.0, 3.0), 9);
    let crept = Vec2::new(8.0 + 0.1 / 3.0, 3.05);
    scene.pose(&pose(1, crept.x, crept.y, 10), 10);
    let out = scene.beacon(1, crept, 10);
    assert!(ring_around(scene_of(&out)[0], 1, crept.x, crept.y), "the circle moved on");
    let Message::Beacon(json) = &out[0].message else { panic!("the beacon's JSON") };
    assert_eq!((json.x.to_bits(), json.y.to_bits()), (crept.x.to_bits(), crept.y.to_bits()));
    assert!(scene.beacon(1, crept, 11).is_empty(), "standing still sends nothing");
    let snapshot = scene.snapshot(12);
    assert!(ring_around(scene_of(&snapshot)[1], 1, crept.x, crept.y));
    assert!(!ring_around(scene_of(&snapshot)[1], 1, 8.0, 3.0), "not where the gate judged it");
}

#[test]
fn status_reports_give_the_mode_and_telemetry() {
    let mut scene = Scene::new("s", world());
    let out = scene.report(&FromAgent::Status(Status { robot: RobotId(3), mode: 2, step: 40 }), 4);
    let topics: Vec<&str> = out.iter().map(|o| o.topic.as_str()).collect();
    assert_eq!(topics, ["bycoms/s/robot/3/mode", "bycoms/s/robot/3/telemetry"]);
    let Message::Mode(m) = &out[0].message else { panic!("mode") };
    assert_eq!((m.mode, m.name, m.step), (2, "bypass", 40));
    // The mode channel sends changes; telemetry every report but lockstep's
    // tick acknowledgements (their step is in the poses).
    let same = scene.report(&FromAgent::Status(Status { robot: RobotId(3), mode: 2, step: 41 }), 5);
    let topics: Vec<&str> = same.iter().map(|o| o.topic.as_str()).collect();
    assert_eq!(topics, ["bycoms/s/robot/3/telemetry"]);
    let back = scene.report(&FromAgent::Status(Status { robot: RobotId(3), mode: 1, step: 42 }), 6);
    assert_eq!(back.len(), 2, "a new mode: {back:?}");
    let other = scene.report(&FromAgent::Status(Status { robot: RobotId(4), mode: 1, step: 42 }), 6);
    assert_eq!(other.len(), 2, "every robot's first mode: {other:?}");
    let done = FromAgent::TickDone(bycoms_protocol::msg::TickDone { robot: RobotId(3), step: 43 });
    assert!(scene.report(&done, 7).is_empty());
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
    out.extend(scene.beacon(1, Vec2::new(5.5, 5.0), 4));
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
        "bycoms.BeaconAt",
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

/// What a SceneUpdate viewer (Foxglove's 3D panel) holds: entities by id,
/// each replaced whole by an update carrying its id and removed only by a
/// deletion (nothing here expires: lifetime 0). Timestamps are left out: a
/// snapshot stamps everything with its own time, and the picture is what
/// is drawn, not when it was sent.
#[derive(Debug, Default, PartialEq)]
struct Viewer(BTreeMap<String, SceneEntity>);

impl Viewer {
    fn apply(&mut self, outs: &[Out]) {
        for update in scene_of(outs) {
            for d in &update.deletions {
                match scene_entity_deletion::Type::try_from(d.r#type) {
                    Ok(scene_entity_deletion::Type::All) => self.0.clear(),
                    _ => {
                        self.0.remove(&d.id);
                    }
                }
            }
            for e in &update.entities {
                self.0.insert(e.id.clone(), SceneEntity { timestamp: None, ..e.clone() });
            }
        }
    }

    fn of(outs: &[Out]) -> Self {
        let mut v = Viewer::default();
        v.apply(outs);
        v
    }

    /// Robot `k`'s trajectory as drawn: its pieces in order, each joint once.
    fn path(&self, k: u32) -> Vec<(f64, f64)> {
        let mut points: Vec<(f64, f64)> = Vec::new();
        for n in 0.. {
            let Some(piece) = self.0.get(&format!("robot/{k}/path/{n}")) else { break };
            let line = &piece.lines[0].points;
            let skip = usize::from(!points.is_empty());
            points.extend(line.iter().skip(skip).map(|p| (p.x, p.y)));
        }
        points
    }
}

/// A seeded stream of what a launch feeds the scene: robots deployed one
/// after another, moving, turning on the spot, standing still (a beacon's
/// republished pose), reporting, and judged by the gate.
fn inputs(seed: u64, n: usize) -> Vec<Input> {
    let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let mut next = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 33) as u32
    };
    let mut robots: Vec<Pose> = Vec::new();
    // Robots the core made beacons: it tells where each stands, and again
    // whenever one creeps on.
    let mut beacons: Vec<u32> = Vec::new();
    let mut out = Vec::with_capacity(n);
    for step in 0..n as u64 {
        if robots.is_empty() || next() % 97 == 0 {
            let k = robots.len() as u32 + 1;
            robots.push(pose(k, 2.0, 2.0, step));
            out.push(Input::Pose(*robots.last().expect("just pushed")));
            continue;
        }
        let i = next() as usize % robots.len();
        let p = &mut robots[i];
        p.step = step;
        p.time_us = step * 100_000;
        match next() % 10 {
            0..=4 => {
                p.x += f64::from(next() % 100) / 200.0;
                p.y += f64::from(next() % 100) / 300.0;
                out.push(Input::Pose(*p));
                if beacons.contains(&p.robot.0) {
                    out.push(Input::Beacon(p.robot.0, Vec2::new(p.x, p.y)));
                }
            }
            5 => {
                p.heading += 0.25;
                out.push(Input::Pose(*p));
            }
            6 => out.push(Input::Pose(*p)),
            7 => out.push(Input::Report(FromAgent::Status(Status {
                robot: p.robot,
                mode: (next() % 2 + 1) as u8,
                step,
            }))),
            _ => {
                let kind = match next() % 4 {
                    0 => GateKind::Deployed,
                    1 => GateKind::Stopped { arrived: false },
                    2 => GateKind::Stopped { arrived: true },
                    _ => GateKind::Died,
                };
                // As the core puts them out: the state, then the decision.
                out.push(Input::State(p.robot.0, SlotState::of_gate(kind)));
                out.push(Input::Gate(GateEvent { robot: p.robot, kind, x: p.x, y: p.y, step }));
                if matches!(kind, GateKind::Stopped { arrived: false } | GateKind::Died) {
                    if !beacons.contains(&p.robot.0) {
                        beacons.push(p.robot.0);
                    }
                    out.push(Input::Beacon(p.robot.0, Vec2::new(p.x, p.y)));
                }
            }
        }
    }
    out
}

#[derive(Debug, Clone, Copy)]
enum Input {
    Pose(Pose),
    Gate(GateEvent),
    Report(FromAgent),
    Beacon(u32, Vec2),
    State(u32, SlotState),
}

/// Same picture: a viewer that applied every update in order (the
/// recording played from its start, a live viewer there from the start)
/// holds, after every input, exactly the entities of a full snapshot of the
/// scene at that moment (what a late live viewer is sent); and the drawn
/// trajectories are every position each robot took, in order.
#[test]
fn the_updates_applied_in_order_give_the_full_scene_after_every_input() {
    for seed in 0..4 {
        let mut scene = Scene::new("s", world());
        let mut viewer = Viewer::of(&scene.world(0));
        let mut visited: BTreeMap<u32, Vec<(f64, f64)>> = BTreeMap::new();
        let mut updates = 0;
        for (i, input) in inputs(seed, 1500).into_iter().enumerate() {
            let ns = i as u64 * 1_000;
            let outs = match input {
                Input::Pose(p) => {
                    let path = visited.entry(p.robot.0).or_default();
                    if path.last() != Some(&(p.x, p.y)) {
                        path.push((p.x, p.y));
                    }
                    scene.pose(&p, ns)
                }
                Input::Gate(e) => scene.gate(&e, ns),
                Input::Report(r) => scene.report(&r, ns),
                Input::Beacon(k, at) => scene.beacon(k, at, ns),
                Input::State(k, state) => scene.state(k, state, ns),
            };
            updates += scene_of(&outs).len();
            viewer.apply(&outs);
            assert_eq!(viewer, Viewer::of(&scene.snapshot(ns)), "seed {seed}, after input {i}: {input:?}");
        }
        assert!(updates > 500 && visited.len() > 5, "seed {seed}: a stream worth the name");
        for (k, path) in &visited {
            let drawn = if path.len() < 2 { Vec::new() } else { path.clone() };
            assert_eq!(viewer.path(*k), drawn, "seed {seed}: robot {k}'s trajectory");
        }
    }
}
