//! The forged and foreign traffic a schedule injects: a step from the
//! future, NaN, a jump to the goal, another robot's pose, another protocol
//! version, an unknown robot. Each must be refused and counted by the core,
//! and change nothing (a differential property of `launch_sim`).

use super::*;

use super::world::World;

impl Foreign {
    /// The forged input at the world's current state (none if it makes no
    /// sense now, e.g. a pose of a robot never seen).
    pub(super) fn input(self, w: &World<'_>) -> Option<Input> {
        let goal = w.case.terrain.goal();
        let tick = w.core.ticks();
        match self {
            Foreign::StepFromTheFuture(id) => {
                let mut p = w.true_pose(id)?;
                p.step = u64::MAX;
                p.time_us = u64::MAX;
                Some(Input::Pose { topic: id, pose: p })
            }
            Foreign::HugeStep(id) => {
                let mut p = w.true_pose(id)?;
                p.step = u64::MAX;
                Some(Input::Pose { topic: id, pose: p })
            }
            Foreign::NotFinite(id) => {
                let mut p = w.true_pose(id)?;
                p.x = f64::NAN;
                p.step += 1;
                Some(Input::Pose { topic: id, pose: p })
            }
            Foreign::AtTheGoal(id) => {
                let p = w.true_pose(id)?;
                // Only a jump no robot could drive is a forgery.
                if Vec2::new(p.x, p.y).distance(goal) < 3.0 {
                    return None;
                }
                let forged =
                    Pose { x: goal.x, y: goal.y, step: p.step + 1, time_us: p.time_us + 100_000, ..p };
                Some(Input::Pose { topic: id, pose: forged })
            }
            Foreign::OtherRobotsPose { topic, robot } => {
                let p = Pose {
                    robot: RobotId(robot),
                    x: goal.x,
                    y: goal.y,
                    heading: 0.0,
                    step: tick,
                    time_us: tick * 100_000,
                };
                Some(Input::Pose { topic, pose: p })
            }
            Foreign::WrongVersion(id) => Some(Input::Report(FromAgent::Register(Register {
                robot: RobotId(id),
                kind: bycoms_protocol::msg::RobotKind::Simulated,
                protocol_version: bycoms_protocol::PROTOCOL_VERSION + 1,
                instance: 0xf0e1,
                settings: 0,
                failsafe_grace_ms: 0,
            }))),
            Foreign::ShortGrace(id) => Some(Input::Report(FromAgent::Register(Register {
                robot: RobotId(id),
                kind: bycoms_protocol::msg::RobotKind::Simulated,
                protocol_version: bycoms_protocol::PROTOCOL_VERSION,
                instance: 0xf0e2,
                settings: 0,
                failsafe_grace_ms: 1,
            }))),
            Foreign::OtherSettings(id) => Some(Input::Report(FromAgent::Register(Register {
                robot: RobotId(id),
                kind: bycoms_protocol::msg::RobotKind::Simulated,
                protocol_version: bycoms_protocol::PROTOCOL_VERSION,
                instance: 0xf0e3,
                settings: !SETTINGS,
                failsafe_grace_ms: 0,
            }))),
            Foreign::UnknownRobot => {
                Some(Input::Report(FromAgent::Heartbeat(Heartbeat { robot: RobotId(999), seq: 1 })))
            }
        }
    }
}
