//! Hand-built terrains whose outcome we know (issue: "Tests that must hold").

use bycoms_sim::runner::RobotRunEnd;
use bycoms_sim::sensing::NoiseModel;
use bycoms_sim::terrain::{parse, Terrain};
use bycoms_sim::{run, RunConfig, RunOutcome, Vec2};

/// 60 × 60, a 2-cell-thick wall across the arena at rows 34–35 with a
/// 3-cell gap at x = 35..38, just beside the start→goal diagonal: robot 1
/// gets stuck at the gap's edge, and its field either leaves the gap open
/// (ε = 1) or covers it (ε = 4), after which beacons pile up along the wall.
fn wall_with_gap(gap: std::ops::Range<usize>) -> Terrain {
    let mut t = Terrain::paper();
    for ix in 0..60 {
        if !gap.contains(&ix) {
            t.set_blocked(ix, 34, true);
            t.set_blocked(ix, 35, true);
        }
    }
    t
}

#[test]
fn gap_of_three_is_crossed_with_eps_one() {
    let t = wall_with_gap(35..38);
    let mut cfg = RunConfig::paper(1.0);
    let r = run(&t, &cfg);
    assert!(r.success, "{:?} after {} robots", r.outcome, r.robots_used);
    assert!(r.robots_used > 1, "the gap is off the diagonal: someone must get stuck first");
    cfg.noise = Some(NoiseModel::paper());
    for seed in 0..4 {
        cfg.seed = seed;
        let r = run(&t, &cfg);
        assert!(r.success, "seed {seed}: {:?} after {} robots", r.outcome, r.robots_used);
    }
}

#[test]
fn gap_of_three_is_never_crossed_with_eps_four() {
    let t = wall_with_gap(35..38);
    // Noiseless: the run is deterministic, so "never" is this one run to the
    // time limit. (With sensing noise a robot occasionally slips through —
    // the paper's §V-B observation that noise can raise the success rate.)
    let cfg = RunConfig::paper(4.0);
    let r = run(&t, &cfg);
    assert!(!r.success, "crossed after {} robots", r.robots_used);
    assert_eq!(r.outcome, RunOutcome::TimeLimit);
    assert!(r.beacons.len() >= 2, "beacons on both sides of the gap close it");
    assert!(r.beacons.iter().all(|b| b.y < 36.0), "nobody got past the wall");
}

#[test]
fn clear_straight_line_takes_exactly_one_robot() {
    let t = Terrain::paper();
    let r = run(&t, &RunConfig::paper(2.0));
    assert!(r.success);
    assert_eq!(r.outcome, RunOutcome::Arrived);
    assert_eq!(r.robots_used, 1);
    assert!(r.beacons.is_empty());
    // Distance 29·√2 ≈ 41.01 at 1 unit/s, stopping within 0.5: 40.6 s ≤ t ≤ 41.1 s.
    assert!(r.time > 40.5 && r.time < 41.1, "{}", r.time);
}

#[test]
fn robot_entering_an_impassable_cell_stops_there() {
    // One blocked cell right on the diagonal.
    let mut t = Terrain::paper();
    t.set_blocked(25, 25, true);
    let mut cfg = RunConfig::paper(1.0);
    cfg.max_robots = Some(1);
    cfg.record_trajectories = true;
    let r = run(&t, &cfg);
    assert_eq!(r.outcome, RunOutcome::RobotsExhausted);
    let robot = &r.robots[0];
    assert_eq!(robot.end, RobotRunEnd::Stuck);
    let p = robot.position;
    assert!(p.x >= 25.0 && p.x < 26.0 && p.y >= 25.0 && p.y < 26.0, "{p:?}");
    assert_eq!(r.beacons, vec![p]);
    // It stopped on the first step inside: the previous point is outside the cell.
    let prev = robot.trajectory[robot.trajectory.len() - 2];
    assert!(!t.is_blocked_at(prev));
    assert_eq!(*robot.trajectory.last().unwrap(), p);
}

#[test]
fn leaving_the_arena_is_stuck() {
    // A goal beyond the west edge: the robot walks straight out of the arena.
    let mut t = parse("S....\n.....\n....G\n").unwrap();
    t.set_goal(Vec2::new(-5.0, 2.5));
    let mut cfg = RunConfig::paper(1.0);
    cfg.max_robots = Some(1);
    let r = run(&t, &cfg);
    assert_eq!(r.outcome, RunOutcome::RobotsExhausted);
    assert_eq!(r.robots[0].end, RobotRunEnd::Stuck);
    let p = r.beacons[0];
    assert!(p.x < 0.0 && p.x > -0.11, "stopped on the first step outside: {p:?}");
}

#[test]
fn same_inputs_same_result_bits() {
    let t = wall_with_gap(35..38);
    let mut cfg = RunConfig::paper(2.0);
    cfg.noise = Some(NoiseModel::paper());
    cfg.seed = 99;
    let a = run(&t, &cfg);
    let b = run(&t, &cfg);
    assert_eq!(a, b);
    let bits = |r: &bycoms_sim::RunResult| -> Vec<(u64, u64)> {
        r.beacons.iter().map(|p| (p.x.to_bits(), p.y.to_bits())).collect()
    };
    assert_eq!(bits(&a), bits(&b));
}

#[test]
fn invalid_configurations_are_named() {
    use bycoms_sim::runner::ConfigError;
    let ok = RunConfig::paper(1.0);
    assert_eq!(ok.validate(), Ok(()));
    assert_eq!(RunConfig::paper(0.0).validate(), Err(ConfigError::Eps(0.0)));
    let mut c = ok.clone();
    c.max_robots = Some(0);
    assert_eq!(c.validate(), Err(ConfigError::NoRobots));
    let mut c = ok.clone();
    c.kinematics.turn_rate = 1.0;
    assert_eq!(c.validate(), Err(ConfigError::Kinematics));
    let mut c = ok;
    c.time_limit = f64::NAN;
    assert!(matches!(c.validate(), Err(ConfigError::TimeLimit(_))));
}
