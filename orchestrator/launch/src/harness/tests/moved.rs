use crate::harness::{self, Case, Foreign, NetFaults, Report, Schedule};
use bycoms_protocol::msg::{GateKind, Pose};

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
