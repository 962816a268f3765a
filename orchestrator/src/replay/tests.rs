//! The replay's gate on hand-made recordings whose decisions are known, and
//! the comparison's verdicts. (`tests/tests/replay.rs` replays real launch
//! recordings.)

use super::*;
use bycoms_launch::LaunchConfig;
use bycoms_protocol::msg::{Deploy, GoalBearing, Pose, Tick, ToAgent};
use bycoms_protocol::RobotId;
use bycoms_sim::Vec2;

fn run_meta(config: LaunchConfig) -> RunMeta {
    RunMeta { terrain: "test".into(), start: Vec2::new(0.0, 0.0), goal: Vec2::new(10.0, 0.0), config }
}

fn pose(robot: u32, step: u64, x: f64) -> Entry {
    Entry::Pose(Pose { robot: RobotId(robot), x, y: 0.0, heading: 0.0, step, time_us: step * 100_000 })
}

fn cmd(robot: u32, command: ToAgent) -> Entry {
    Entry::Command { robot: RobotId(robot), command }
}

fn tick(robots: &[u32], t: u64, out: &mut Vec<Entry>) {
    for &r in robots {
        out.push(cmd(r, ToAgent::Tick(Tick { step: t })));
    }
}

fn deploy(robot: u32) -> Entry {
    cmd(robot, ToAgent::Deploy(Deploy { robot: RobotId(robot), x: 0.0, y: 0.0, heading: 0.0 }))
}

fn event(robot: u32, kind: GateKind, x: f64, step: u64) -> GateEvent {
    GateEvent { robot: RobotId(robot), kind, x, y: 0.0, step }
}

/// Lockstep as the launch drives it: robot 1 drives 1.0 then stands (stuck
/// after the 2 s dwell); robot 2 drives straight to the goal.
fn two_robots() -> Recorded {
    let config = LaunchConfig {
        gate: bycoms_launch::config::GateConfig { dwell: 2.0, ..Default::default() },
        ..LaunchConfig::default()
    };
    let mut e = Vec::new();
    tick(&[1], 1, &mut e); // settle tick
    e.push(deploy(1));
    e.push(pose(1, 1, 0.0)); // start pose: step = ticks sent = 1
    for t in 2..=31 {
        e.push(cmd(1, ToAgent::GoalBearing(GoalBearing { robot: RobotId(1), bearing: 0.0, step: t })));
        tick(&[1], t, &mut e);
        e.push(pose(1, t, (0.1 * (t - 1) as f64).min(1.0)));
    }
    tick(&[1, 2], 32, &mut e); // settle tick of robot 2
    e.push(pose(1, 32, 1.0));
    e.push(deploy(2));
    e.push(pose(2, 0, 0.0)); // its agent's own step number: replaced by the tick count
    for t in 33..=42 {
        tick(&[1, 2], t, &mut e);
        e.push(pose(1, t, 1.0));
        e.push(pose(2, t, (t - 32) as f64));
    }
    Recorded {
        run: run_meta(config),
        entries: e,
        poses_on: Default::default(),
        stopped_by: None,
        partial: None,
    }
}

#[test]
fn the_gate_reaches_the_known_decisions_of_a_hand_made_run() {
    let got = rejudge(&two_robots());
    let arrived = GateKind::Stopped { arrived: true };
    let stuck = GateKind::Stopped { arrived: false };
    assert_eq!(
        got,
        vec![
            event(1, GateKind::Deployed, 0.0, 1),
            event(1, stuck, 1.0, 31), // still since step 11, + 20 periods
            event(2, GateKind::Deployed, 0.0, 32),
            event(2, arrived, 10.0, 42),
        ]
    );
}

#[test]
fn the_time_budget_ends_a_robot_at_its_pose_at_the_limit() {
    let config = LaunchConfig { time_limit: 0.5, ..LaunchConfig::default() };
    let mut e = vec![cmd(1, ToAgent::Tick(Tick { step: 1 })), deploy(1), pose(1, 1, 0.0)];
    for t in 2..=10 {
        tick(&[1], t, &mut e);
        e.push(pose(1, t, 0.1 * (t - 1) as f64));
    }
    let got = rejudge(&Recorded {
        run: run_meta(config),
        entries: e,
        poses_on: Default::default(),
        stopped_by: None,
        partial: None,
    });
    // 5 periods of budget: the 6th change (step 7) is one past it, so the
    // pose at the limit is the one before (step 6).
    assert_eq!(got[1], event(1, GateKind::Timeout, 0.5, 6), "{got:?}");
    assert_eq!(got.len(), 2);
}

#[test]
fn a_recorded_death_closes_the_watch_where_the_robot_was_last_seen() {
    let mut rec = two_robots();
    // Robot 1's agent dies after step 5 instead of freezing.
    let cut = rec.entries.iter().position(|e| matches!(e, Entry::Pose(p) if p.step == 6)).unwrap();
    rec.entries.truncate(cut);
    rec.entries.push(Entry::Gate(event(1, GateKind::Died, 0.4, 5)));
    let got = rejudge(&rec);
    assert_eq!(got.last(), Some(&event(1, GateKind::Died, 0.4, 5)), "{got:?}");
}

#[test]
fn the_comparison_names_every_difference() {
    let recorded = rejudge(&two_robots());
    assert!(Comparison::new(&recorded, &recorded).matches());
    let mut later = recorded.clone();
    later[1].step += 1;
    let c = Comparison::new(&recorded, &later);
    assert!(!c.matches());
    assert_eq!(c.mismatches(), 1);
    assert!(c.lines[1].to_string().contains("MISMATCH"), "{}", c.lines[1]);
    let c = Comparison::new(&recorded, &recorded[..3]);
    assert_eq!(c.lines[3], Line::OnlyRecorded(recorded[3]));
    let mut moved = recorded.clone();
    moved[3].x = f64::from_bits(moved[3].x.to_bits() + 1);
    assert_eq!(Comparison::new(&recorded, &moved).mismatches(), 1, "positions compare bit for bit");
}
