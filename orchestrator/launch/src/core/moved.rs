//! The poses the core applies, as an output ([`Output::Moved`]).
//!
//! Why an output: what shows the run (the live view, ROS 2, the
//! recording's scene and `core/moved`, the `--svg` trace, and the bag
//! `record export --ros2` makes) used to be handed every pose the pose
//! source delivered, before the core judged it. So a robot revoked by
//! `orchestrator revoke` went on moving in Foxglove and on ROS 2, and a
//! forged pose at the goal, refused by the core, was drawn there (issue
//! 53). The core knows which poses it applies; it says so once, for each
//! pose it makes a robot's latest, and the driver shows only those. A pose
//! refused as implausible (`plausible.rs`), of another robot's topic, a
//! repeat or a late sample, one held back for a later tick (`ahead.rs`, it
//! is moved when its tick comes), or of a robot dead, revoked or not
//! deployed yet is never moved. Not even while an operator places it: the
//! placement check reads those poses, but with no start pose to judge
//! them against the core cannot tell the robot's own from a forger's at
//! the goal; a robot is shown from its start pose on. The bus's
//! pose topics are still recorded byte for byte: `orchestrator replay`
//! hands the core the poses it was handed (`log.rs`).

use super::*;

impl LaunchCore {
    /// Robot `id`'s `pose` was applied: the views show it.
    pub(super) fn moved(&mut self, id: u32, pose: Pose) {
        self.outputs.push_back(Output::Moved { robot: id, pose });
    }
}

#[cfg(test)]
mod tests {
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
            assert!(
                report.forged.len() > 5,
                "{realtime:?}: the forgeries were handed in: {:?}",
                report.forged
            );
            assert!(report.forged.iter().all(|(_, taken)| !taken), "{realtime:?}: none was plausible");
            assert!(shown(&report, 1).len() > 10, "{realtime:?}: robot 1 is shown moving");
            let deployed = report.gates.iter().filter(|g| g.kind == GateKind::Deployed).count();
            let moving = (1..=3).filter(|&id| !shown(&report, id).is_empty()).count();
            assert_eq!(moving, deployed, "{realtime:?}: every robot deployed is shown, no other");
            for id in 1..=3 {
                assert_eq!(
                    shown(&report, id),
                    shown(&base, id),
                    "{realtime:?}: robot {id} as without forgeries"
                );
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
}
