//! The agent core, driven message by message the way the lockstep
//! orchestrator drives it, reproduces `runner::run` bit for bit.

use super::*;
use bycoms_sim::runner::{arrived, run, RobotRunEnd};
use bycoms_sim::sensing::NoiseModel;
use bycoms_sim::terrain::Terrain;

/// The lockstep protocol without the bus: deploy at the start facing the
/// goal, hand each robot the stuck robots' poses and, every period, the goal
/// bearing from its latest pose.
fn drive(terrain: &Terrain, cfg: &RunConfig) -> Vec<(RobotRunEnd, Vec2, u64)> {
    let (start, goal) = (terrain.start(), terrain.goal());
    let mut stuck: Vec<Pose> = Vec::new();
    let mut out = Vec::new();
    let mut total = 0;
    for id in 1..=cfg.max_robots.unwrap_or(u32::MAX) {
        let mut core = RobotCore::new(RobotId(id), terrain.clone(), cfg.clone());
        for (i, p) in stuck.iter().enumerate() {
            core.beacon(&Beacon { robot: p.robot, x: p.x, y: p.y, seq: i as u32 + 1 }).unwrap();
        }
        let deploy = Deploy { robot: RobotId(id), x: start.x, y: start.y, heading: start.bearing_to(goal) };
        core.deploy(&deploy).unwrap();
        let mut pose = core.pose(0, 0).unwrap();
        let end = loop {
            if total >= cfg.step_limit() {
                break RobotRunEnd::Moving;
            }
            let bearing = Vec2::new(pose.x, pose.y).bearing_to(goal);
            core.set_bearing(&GoalBearing { robot: RobotId(id), bearing, step: total }).unwrap();
            assert!(core.step());
            total += 1;
            pose = core.pose(total, 0).unwrap();
            if core.phase() == RobotPhase::Frozen {
                break RobotRunEnd::Stuck;
            }
            if arrived(Vec2::new(pose.x, pose.y), goal, cfg.success_radius) {
                break RobotRunEnd::Arrived;
            }
        };
        out.push((end, Vec2::new(pose.x, pose.y), core.steps()));
        match end {
            RobotRunEnd::Stuck => stuck.push(pose),
            _ => break,
        }
    }
    out
}

fn wall() -> Terrain {
    let mut t = Terrain::paper();
    for i in 0..12 {
        t.set_blocked(24 + i, 35 - i, true);
        t.set_blocked(25 + i, 35 - i, true);
    }
    t
}

#[test]
fn matches_the_runner_bit_for_bit() {
    let mut beacons = 0;
    for noise in [None, Some(NoiseModel::paper())] {
        for eps in [1.0, 2.5, 4.0] {
            let mut cfg = RunConfig::paper(eps);
            cfg.noise = noise;
            cfg.seed = 11;
            cfg.max_robots = Some(6);
            cfg.time_limit = 2_000.0;
            let expected = run(&wall(), &cfg);
            let got = drive(&wall(), &cfg);
            assert_eq!(got.len(), expected.robots.len(), "ε {eps}, noise {noise:?}");
            beacons += expected.beacons.len();
            for ((end, pos, steps), r) in got.iter().zip(&expected.robots) {
                assert_eq!(*end, r.end, "robot {}", r.id);
                assert_eq!(pos.x.to_bits(), r.position.x.to_bits(), "robot {}", r.id);
                assert_eq!(pos.y.to_bits(), r.position.y.to_bits(), "robot {}", r.id);
                assert_eq!(*steps, r.steps, "robot {}", r.id);
            }
        }
    }
    assert!(beacons >= 6, "the cases exercise the field of stuck robots ({beacons} beacons)");
}

#[test]
fn refuses_foreign_and_malformed_messages() {
    let mut core = RobotCore::new(RobotId(2), Terrain::paper(), RunConfig::paper(2.0));
    let other = Deploy { robot: RobotId(3), x: 1.0, y: 1.0, heading: 0.0 };
    assert_eq!(core.deploy(&other), Err(Reject::WrongRobot { got: RobotId(3) }));
    let nan = Deploy { robot: RobotId(2), x: f64::NAN, y: 1.0, heading: 0.0 };
    assert_eq!(core.deploy(&nan), Err(Reject::NotFinite));
    assert_eq!(core.phase(), RobotPhase::Idle);
    assert!(!core.step(), "an idle robot does not move");
    let own = Beacon { robot: RobotId(2), x: 3.0, y: 3.0, seq: 1 };
    assert_eq!(core.beacon(&own), Err(Reject::WrongRobot { got: RobotId(2) }));
    let nan = Beacon { robot: RobotId(1), x: f64::NAN, y: 3.0, seq: 1 };
    assert_eq!(core.beacon(&nan), Err(Reject::NotFinite));
    let first = Beacon { robot: RobotId(1), x: 3.0, y: 3.0, seq: 1 };
    assert_eq!(core.beacon(&first), Ok(()));
    // Beacon 2 lost: 3 is taken (its position counts) and the gap reported.
    let third = Beacon { robot: RobotId(4), x: 5.0, y: 3.0, seq: 3 };
    assert_eq!(core.beacon(&third), Err(Reject::BeaconOutOfOrder { expected: 2, got: 3 }));
    // A new position of robot 1 replaces the old one.
    let moved = Beacon { robot: RobotId(1), x: 3.5, y: 3.0, seq: 4 };
    assert_eq!(core.beacon(&moved), Ok(()));
    // A repeat (re-sent with a tick that was lost) is taken quietly; an old
    // number with a new position is still reported.
    assert_eq!(core.beacon(&moved), Ok(()));
    let stale = Beacon { robot: RobotId(1), x: 3.25, y: 3.0, seq: 4 };
    assert_eq!(core.beacon(&stale), Err(Reject::BeaconOutOfOrder { expected: 5, got: 4 }));
    assert_eq!(core.beacon(&moved), Err(Reject::BeaconOutOfOrder { expected: 5, got: 4 }));
    assert_eq!(core.beacons().collect::<Vec<_>>(), [(1, Vec2::new(3.5, 3.0)), (4, Vec2::new(5.0, 3.0))]);
    let ok = Deploy { robot: RobotId(2), x: 15.5, y: 15.5, heading: 0.5 };
    core.deploy(&ok).unwrap();
    assert_eq!(core.deploy(&ok), Err(Reject::AlreadyDeployed));
    assert!(!core.step(), "no goal bearing yet: hold still");
    core.set_bearing(&GoalBearing { robot: RobotId(2), bearing: 0.5, step: 1 }).unwrap();
    assert!(core.step());
    core.stop();
    assert_eq!(core.phase(), RobotPhase::Stopped);
    assert!(!core.step(), "a stopped robot stays put");
}
