//! A lab day's operator: a stop and a revocation at seeded moments.

use super::*;

/// Issue 34: `orchestrator stop --now` at a seeded moment of a drawn
/// schedule (any clock, any faults): the launch ends interrupted, every
/// robot whose agent ran is told `Stop` at once, the agents (the real
/// sim-agent core and gateways) answer it and the launch ends once they
/// did (the harness's `check_stop`), and the summary's record names who
/// asked and why. A graceful stop tells no one (the agents get `Shutdown`
/// as after Ctrl-C).
#[test]
fn a_stop_at_a_seeded_moment_tells_every_running_robot_at_once_and_names_who() {
    use rand::{Rng, SeedableRng};
    let (mut told, mut answered) = (0usize, 0usize);
    for seed in 0..300u64 {
        let case = Case::small(seed);
        let mut schedule = Schedule::draw(seed, case.robots, TICKS);
        schedule.interrupt_at_us = None;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x5709);
        let at_once = seed % 4 != 0;
        schedule.stop_at_us = Some((rng.gen_range(0..3_000_000), at_once));
        let report = harness::run(&case, &schedule);
        harness::check(&report, &schedule).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let ending = report.ending.as_ref().expect("checked");
        let Some(stop) = report.stopped.as_ref() else {
            // The launch ended before the stop came.
            assert_ne!(ending.outcome, Outcome::Interrupted, "seed {seed}");
            continue;
        };
        if ending.outcome == Outcome::Error {
            continue;
        }
        assert_eq!(ending.outcome, Outcome::Interrupted, "seed {seed}");
        assert_eq!((stop.who.as_str(), stop.why.as_str()), (harness::STOP_WHO, harness::STOP_WHY));
        if at_once {
            for id in &report.running_at_end {
                assert!(stop.told.contains(id), "seed {seed}: robot {id} ran and was not told Stop");
            }
            told += stop.told.len();
            answered += stop.answered.len();
        } else {
            assert!(stop.told.is_empty(), "seed {seed}");
        }
    }
    assert!(told > 100, "too few robots were told to stop ({told}): the test tests too little");
    // Lossy buses and partitions silence some; most answer.
    assert!(answered * 4 > told * 3, "only {answered} of {told} robots told answered");
}

/// `orchestrator stop --now` while robot 1 moves (in virtual time): robot
/// 1 answers that it stopped, and the summary says so, as `stop --help`
/// promises: `end: stopped` where it stands, a beacon (it said "still
/// moving", with no beacon).
#[test]
fn a_robot_stopped_now_while_it_moves_ends_stopped_as_a_beacon() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    let time_of = |kind: fn(GateKind) -> bool| {
        let at = clean.gates.iter().position(|g| g.robot.0 == 1 && kind(g.kind));
        at.map(|i| clean.gate_times_us[i])
    };
    let deployed = time_of(|k| k == GateKind::Deployed).expect("robot 1 deployed");
    let decided = time_of(|k| k != GateKind::Deployed).expect("robot 1 judged");
    let mut s = Schedule::clean(1, 3);
    s.stop_at_us = Some(((deployed + decided) / 2, true));
    let report = harness::run(&case, &s);
    harness::check(&report, &s).unwrap_or_else(|e| panic!("{e}"));
    let stop = report.stopped.as_ref().expect("the stop was taken");
    assert!(stop.answered.iter().any(|a| a.robot == 1), "robot 1 answered: {stop:?}");
    let summary = report.decided.as_ref().expect("summary");
    let robot = &summary.robots[0];
    assert_eq!(robot.end, bycoms_launch::RobotEnd::Stopped, "{robot:?}");
    let at = (robot.x.expect("x"), robot.y.expect("y"));
    assert_eq!(
        summary.beacons.iter().map(|b| (b.x, b.y)).collect::<Vec<_>>(),
        [at],
        "a beacon where it stands"
    );
}

/// A robot revoked while it moves (`orchestrator revoke`, in virtual
/// time) is told `Stop` once and becomes a beacon where it stopped, like a
/// robot whose agent died; the launch goes on with the others, never
/// ending in an error for it, and the summary names who revoked it.
#[test]
fn a_robot_revoked_while_it_moves_is_a_beacon_and_the_others_go_on() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    let times = |kind: fn(GateKind) -> bool| {
        clean
            .gates
            .iter()
            .zip(&clean.gate_times_us)
            .find(|(g, _)| g.robot.0 == 1 && kind(g.kind))
            .map(|(_, t)| *t)
    };
    let deployed = times(|k| k == GateKind::Deployed).expect("robot 1 deployed");
    let decided = times(|k| k != GateKind::Deployed).expect("robot 1 judged");
    let mut s = Schedule::clean(1, 3);
    let at = (deployed + decided) / 2;
    s.revoke_at_us = Some((at, 1));
    let report = harness::run(&case, &s);
    harness::check(&report, &s).unwrap_or_else(|e| panic!("{e}"));
    let ending = report.ending.as_ref().expect("ended");
    assert_ne!(ending.outcome, Outcome::Error, "{:?}", ending.error);
    assert_eq!(report.robots[0].0, SlotState::Died, "a beacon where it stopped");
    assert_eq!(report.stop_log.iter().filter(|s| s.1 == 1).count(), 1, "told Stop once");
    assert!(!report.agents_at_end.contains(&1), "its agent was told to end, and did");
    assert!(report.agents_at_end.contains(&2), "robot 2's agent runs to the end: {:?}", report.agents_at_end);
    let shown_after = report.moved.iter().filter(|(t, r, _)| *r == 1 && *t > at).count();
    assert_eq!(shown_after, 0, "nothing of robot 1 shown after its revocation");
    assert!(report.stop_log.iter().any(|&(t, id)| id == 1 && t == at), "told at the revocation");
    let died = report.gates.iter().position(|g| g.robot.0 == 1 && g.kind == GateKind::Died);
    assert!(died.is_some_and(|i| report.gate_times_us[i] == at), "judged at once: {:?}", report.gates);
    assert!(report.gates.iter().any(|g| g.robot.0 == 2 && g.kind == GateKind::Deployed), "robot 2 went on");
    let decided = report.decided.as_ref().expect("summary");
    assert_eq!(decided.robots[0].end, bycoms_launch::RobotEnd::Died);
    let reason = report.deaths[0].as_deref().unwrap_or_default();
    assert_eq!(reason, format!("revoked by {}: {}", harness::STOP_WHO, harness::REVOKE_WHY));
    assert_eq!(report.revoked.iter().map(|r| r.robot).collect::<Vec<_>>(), [1]);
}

/// A revocation at a seeded moment, of a seeded robot, in schedules drawn
/// with every other fault: every property holds (`harness::check`'s
/// `check_revoke`: told `Stop` at most once, nothing from the robot changes
/// the launch afterwards).
#[test]
fn a_revocation_at_a_seeded_moment_keeps_the_properties() {
    use rand::{Rng, SeedableRng};
    let (mut taken, mut moving) = (0, 0);
    for seed in 0..150u64 {
        let case = Case::small(seed);
        let mut schedule = Schedule::draw(seed, case.robots, TICKS);
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x7e0c);
        let robot = rng.gen_range(1..=case.robots);
        schedule.revoke_at_us = Some((rng.gen_range(0..2_000_000), robot));
        let report = harness::run(&case, &schedule);
        harness::check(&report, &schedule).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        if report.revoked.iter().any(|r| r.robot == robot) {
            taken += 1;
            moving += usize::from(report.robots[robot as usize - 1].0 == SlotState::Died);
        }
    }
    assert!(taken > 50 && moving > 5, "too few revocations taken ({taken}) or of moving robots ({moving})");
}
