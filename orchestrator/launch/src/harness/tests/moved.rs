use crate::core::log::Call;
use crate::core::view::{BeaconAt, StateChange};
use crate::core::{LaunchCore, Output, SlotState};
use crate::harness::{self, Case, Foreign, NetFaults, Report, Schedule};
use bycoms_protocol::msg::{GateKind, Pose};
use bycoms_record::scene::{Message, Scene, SceneWorld};
use bycoms_sim::terrain::Terrain;
use bycoms_sim::Vec2;
use std::collections::BTreeMap;

/// Three robots, robot 1 moving for a while first (a wall far away).
fn case() -> Case {
    Case { robots: 3, ..Case::small(0) }
}

/// The poses shown of robot `id`.
fn shown(report: &Report, id: u32) -> Vec<Pose> {
    report.moved.iter().filter(|(_, r, _)| *r == id).map(|(_, _, p)| *p).collect()
}

/// On either clock, over a link that delivers a third of the poses
/// twice, with forged poses (at the goal, from the future, not finite,
/// another robot's, a series at the goal before robot 2 is deployed, one
/// racing its `Deploy`): every robot that moved is shown moving, each
/// pose once and in step order, and no forged pose is shown
/// (`harness::check`'s views property), while the run is the clean one.
#[test]
fn only_the_poses_the_core_applies_are_shown() {
    for realtime in [None, Some(5.0)] {
        let duplicates = NetFaults { duplicate: 0.3, ..NetFaults::perfect(2_000) };
        let clean = Schedule { realtime, net_faults: duplicates, ..Schedule::clean(1, 3) };
        let base = harness::run(&case(), &clean);
        harness::check(&base, &clean).unwrap_or_else(|e| panic!("{realtime:?}: {e}"));
        let at = base.end_us / 10;
        let mut forged = clean.clone();
        forged.foreign = vec![
            (0, Foreign::GoalSeries { robot: 2, sent: 0 }),
            (0, Foreign::RacesTheDeploy(2)),
            (at, Foreign::AtTheGoal(1)),
            (at + 1, Foreign::StepFromTheFuture(1)),
            (at + 2, Foreign::NotFinite(1)),
            (at + 3, Foreign::OtherRobotsPose { topic: 1, robot: 2 }),
        ];
        let report = harness::run(&case(), &forged);
        harness::check(&report, &forged).unwrap_or_else(|e| panic!("{realtime:?}: {e}"));
        assert!(report.forged.len() > 5, "{realtime:?}: the forgeries were handed in: {:?}", report.forged);
        assert!(report.forged.iter().all(|(_, taken)| !taken), "{realtime:?}: none was plausible");
        assert!(shown(&report, 1).len() > 10, "{realtime:?}: robot 1 is shown moving");
        let deployed = report.gates.iter().filter(|g| g.kind == GateKind::Deployed).count();
        let moving = (1..=3).filter(|&id| !shown(&report, id).is_empty()).count();
        assert_eq!(moving, deployed, "{realtime:?}: every robot deployed is shown, no other");
        for id in 1..=3 {
            assert_eq!(shown(&report, id), shown(&base, id), "{realtime:?}: robot {id} as without forgeries");
        }
    }
}

/// A robot revoked while it moves: shown up to its revocation, never
/// after (its agent, told `Stop`, still sends poses until it ends).
#[test]
fn a_revoked_robot_is_not_shown_after_its_revocation() {
    let clean = Schedule::clean(1, 3);
    let base = harness::run(&case(), &clean);
    let deployed = base.gates.iter().zip(&base.gate_times_us).find(|(g, _)| g.robot.0 == 1);
    let at = deployed.map(|(_, t)| *t).expect("robot 1 deployed") + 500_000;
    let revoked = Schedule { revoke_at_us: Some((at, 1)), ..clean };
    let report = harness::run(&case(), &revoked);
    harness::check(&report, &revoked).unwrap_or_else(|e| panic!("{e}"));
    let times: Vec<u64> = report.moved.iter().filter(|(_, r, _)| *r == 1).map(|(t, _, _)| *t).collect();
    assert!(!times.is_empty(), "robot 1 was shown moving before");
    assert!(times.iter().all(|&t| t <= at), "robot 1 shown at {times:?}, revoked at {at} µs");
}

/// The bug issue 53 names ("the scene's has no creep"): the core's own
/// outputs, replayed from a logged harness launch in which beacons creep,
/// fed to the recording's scene as the driver feeds it (applied poses, gate
/// events, beacon and state changes). After every call the scene's beacons
/// (its `beacon/json`) stand exactly where the core's table has them, bit
/// for bit, and its robots' states (`robot/<k>/state`) are the core's
/// slots'; at the end a late viewer's snapshot draws each ε circle there.
#[test]
fn the_scenes_beacons_creep_as_the_cores_table_and_its_states_are_the_cores() {
    let walled: Terrain = ".....\n..G..\n.###.\n.#S#.\n.###.\n".parse().expect("terrain");
    let case =
        Case { terrain: walled, robots: 12, time_limit: 120.0, noise: None, stop_turn_rate: 0.0, ..case() };
    let (report, setup, calls) = harness::run_logged(&case, &Schedule::clean(0, case.robots));
    harness::check(&report, &Schedule::clean(0, case.robots)).unwrap_or_else(|e| panic!("{e}"));
    let mut core = LaunchCore::new(setup);
    let world =
        SceneWorld { terrain: case.terrain.clone(), eps: case.eps, goal_radius: 0.5, real: Vec::new() };
    let mut scene = Scene::new("s", world);
    let bits = |at: Vec2| (at.x.to_bits(), at.y.to_bits());
    let (mut told, mut crept) = (BTreeMap::new(), 0);
    // Each robot's state as the scene said it (`Waiting` until it says one).
    let mut states: BTreeMap<u32, SlotState> = (1..=case.robots).map(|k| (k, SlotState::Waiting)).collect();
    for call in &calls {
        match call {
            Call::Handle(now, input) => core.handle(*now, input.clone()),
            Call::Advance(now) => core.advance(*now),
            Call::HandleRecordedPose { .. } => continue,
        }
        while let Some(out) = core.poll() {
            let outs = match out {
                Output::Moved { pose, .. } => scene.pose(&pose, 0),
                Output::Gate(event) => scene.gate(&event, 0),
                Output::Beacon(BeaconAt { robot, at }) => scene.beacon(robot, at, 0),
                Output::State(StateChange { robot, state }) => scene.state(robot, state, 0),
                _ => continue,
            };
            for slot in outs.iter().filter_map(|o| match &o.message {
                Message::State(slot) => Some(*slot),
                _ => None,
            }) {
                states.insert(slot.robot, slot.state);
            }
            for beacon in outs.iter().filter_map(|o| match &o.message {
                Message::Beacon(b) => Some(*b),
                _ => None,
            }) {
                let was = told.insert(beacon.robot, bits(Vec2::new(beacon.x, beacon.y)));
                crept += usize::from(was.is_some());
            }
        }
        let table: BTreeMap<u32, (u64, u64)> =
            core.beacons().into_iter().map(|(id, at)| (id, bits(at))).collect();
        assert_eq!(told, table, "the scene's beacons are the core's");
        let slots: BTreeMap<u32, SlotState> = core.slots().iter().map(|s| (s.id(), s.state())).collect();
        assert_eq!(states, slots, "the scene's states are the core's");
    }
    let ended = states.values().filter(|s| matches!(s, SlotState::Stuck | SlotState::Arrived)).count();
    assert!(ended > 1, "robots ended stuck or arrived, as the scene said: {states:?}");
    assert!(told.len() > 1 && crept > 10, "{} beacons crept {crept} times: a run worth the name", told.len());
    let snapshot = scene.snapshot(1);
    let circles: BTreeMap<u32, (u64, u64)> = snapshot
        .iter()
        .filter_map(|o| match &o.message {
            Message::Scene(update) => Some(update.entities.iter()),
            _ => None,
        })
        .flatten()
        .filter_map(|e| {
            let id = e.id.strip_prefix("robot/")?.strip_suffix("/beacon")?.parse().ok()?;
            let at = e.cylinders.first()?.pose.as_ref()?.position.as_ref()?;
            Some((id, bits(Vec2::new(at.x, at.y))))
        })
        .collect();
    assert_eq!(circles, told, "a late viewer sees every circle where the core's beacon stands");
}
