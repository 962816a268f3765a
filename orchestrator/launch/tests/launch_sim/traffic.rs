//! Forged and foreign traffic, and partitions shorter than the link grace,
//! change nothing; the defects found by hand in poses and registrations.

use super::*;

#[test]
fn forged_and_foreign_traffic_changes_nothing_and_is_counted() {
    let mut counted = 0;
    for seed in 0..300 {
        let case = Case::small(seed);
        // Every other seed on the real-time clock (at 5×).
        let realtime = (seed % 2 == 1).then_some(5.0);
        let clean_schedule = Schedule { realtime, ..Schedule::clean(seed, case.robots) };
        let clean = harness::run(&case, &clean_schedule);
        let forged = Schedule { realtime, ..Schedule::forgeries(seed, case.robots, clean.end_us) };
        let report = harness::run(&case, &forged);
        harness::check(&report, &forged).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        same_run_and_views(&clean, &report, &format!("seed {seed}, {:?}", forged.foreign));
        counted += report.bad;
    }
    assert!(counted > 300, "forgeries were delivered and counted: {counted}");
}

#[test]
fn a_partition_shorter_than_the_unreachable_grace_ends_as_without_it() {
    for seed in 0..200 {
        let case = Case::small(seed);
        let mut clean = Schedule::clean(seed, case.robots);
        clean.remote = true;
        clean.net_faults = harness::NetFaults::perfect(20_000);
        let base = harness::run(&case, &clean);
        let mut cut = clean.clone();
        let robot = 1 + (seed % u64::from(case.robots)) as u32;
        let from_us = base.end_us * (seed % 7 + 1) / 9;
        cut.partitions = vec![Partition { robot, from_us, until_us: from_us + 1_500_000 }];
        let report = harness::run(&case, &cut);
        harness::check(&report, &cut).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        same_run(&base, &report, &format!("seed {seed}, robot {robot} cut at {from_us} µs"));
    }
}

#[test]
fn a_pose_with_step_u64_max_neither_stalls_nor_changes_the_run() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    for forgery in [Foreign::StepFromTheFuture(1), Foreign::HugeStep(1)] {
        let mut s = Schedule::clean(1, 3);
        s.foreign = vec![(clean.end_us / 10, forgery)];
        let report = harness::run(&case, &s);
        harness::check(&report, &s).unwrap();
        same_run_and_views(&clean, &report, &format!("{forgery:?}"));
        assert_eq!(report.bad, 1, "refused and counted");
    }
}

#[test]
fn a_forged_pose_at_the_goal_does_not_win() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    let mut s = Schedule::clean(1, 3);
    s.foreign = vec![(clean.end_us / 10, Foreign::AtTheGoal(1))];
    let report = harness::run(&case, &s);
    same_run_and_views(&clean, &report, "forged pose at the goal");
    assert_eq!(report.bad, 1);
}

/// Issue 31: poses of robot 2 at the goal, one every 0.1 s from halfway
/// to its deployment on (steps 5, 6, … in real time, behind its agent's
/// clock), and a forger who answers robot 2's `Deploy` with a pose at the
/// goal before its agent does. On either clock the run is the clean one:
/// robot 2 starts where it was deployed, and its agent's poses are judged
/// against that start, not against a forgery ("ahead of the launch's
/// clock").
#[test]
fn poses_at_the_goal_before_a_robot_is_deployed_neither_start_it_nor_refuse_its_own() {
    let case = long_case();
    for realtime in [Some(1.0), Some(5.0), None] {
        // Lockstep ticks of 20 ms: robot 1 moves for about a second.
        let net_faults = harness::NetFaults::perfect(10_000);
        let clean_schedule = Schedule { realtime, net_faults, ..Schedule::clean(1, 3) };
        let clean = harness::run(&case, &clean_schedule);
        let deployed_us =
            clean.gates.iter().zip(&clean.gate_times_us).find(|(g, _)| g.robot.0 == 2).map(|(_, t)| *t);
        let Some(deployed_us) = deployed_us.filter(|&t| t > 500_000) else {
            panic!("{realtime:?}: robot 2 is deployed late in the clean run: {deployed_us:?} µs");
        };
        for forgery in [Foreign::GoalSeries { robot: 2, sent: 0 }, Foreign::RacesTheDeploy(2)] {
            let what = format!("{forgery:?} on the {realtime:?} clock");
            let mut s = clean_schedule.clone();
            s.foreign = vec![(deployed_us / 2, forgery)];
            let report = harness::run(&case, &s);
            harness::check(&report, &s).unwrap_or_else(|e| panic!("{what}: {e}"));
            same_run_and_views(&clean, &report, &what);
            assert!(report.bad >= 1, "{what}: refused and counted");
        }
    }
}

#[test]
fn a_stray_register_of_another_protocol_is_counted_and_never_fatal() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    let mut s = Schedule::clean(1, 3);
    s.foreign =
        vec![(clean.end_us / 10, Foreign::WrongVersion(1)), (clean.end_us / 5, Foreign::WrongVersion(3))];
    let report = harness::run(&case, &s);
    same_run_and_views(&clean, &report, "stray registers");
    assert_eq!(report.bad, 2);
}
