//! The forged and foreign traffic a schedule injects: a step from the
//! future, NaN, a jump to the goal, poses at the goal before a robot is
//! deployed or racing its start pose, another robot's pose, another
//! protocol version, an unknown robot. Each must be refused and counted by
//! the core, and change nothing (a differential property of `launch_sim`).

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
                Some(Input::Pose { topic, pose: at_the_goal(robot, goal, tick) })
            }
            Foreign::WrongVersion(id) => {
                let version = bycoms_protocol::PROTOCOL_VERSION + 1;
                Some(register(Register { protocol_version: version, ..forged_register(id, 0xf0e1) }))
            }
            Foreign::ShortGrace(id) => {
                Some(register(Register { failsafe_grace_ms: 1, ..forged_register(id, 0xf0e2) }))
            }
            Foreign::OtherSettings(id) => Some(register(Register {
                settings: !w.launch.settings.fingerprint(),
                ..forged_register(id, 0xf0e3)
            })),
            Foreign::UnknownRobot => {
                Some(Input::Report(FromAgent::Heartbeat(Heartbeat { robot: RobotId(999), seq: 1 })))
            }
            Foreign::GoalSeries { robot, sent } => {
                // Of a moving robot near the goal, the goal is no jump.
                let state = w.core.slots().get(robot as usize - 1)?.state();
                let near = w.true_pose(robot).is_some_and(|p| Vec2::new(p.x, p.y).distance(goal) < 3.0);
                if !series_targets(state) || (state == SlotState::Moving && near) {
                    return None;
                }
                let step = if w.schedule.realtime.is_some() { 5 + u64::from(sent) } else { tick };
                Some(Input::Pose { topic: robot, pose: at_the_goal(robot, goal, step) })
            }
            // Armed now, sent when the robot is told to deploy.
            Foreign::RacesTheDeploy(_) => None,
        }
    }

    /// The forgery that follows this one, 0.1 s later: the next pose of a
    /// series, while its robot is still to be deployed or moves.
    pub(super) fn next(self, w: &World<'_>) -> Option<Foreign> {
        let Foreign::GoalSeries { robot, sent } = self else { return None };
        let state = w.core.slots().get(robot as usize - 1)?.state();
        (series_targets(state) && sent < SERIES).then_some(Foreign::GoalSeries { robot, sent: sent + 1 })
    }
}

/// Whether a series of poses at the goal targets a robot in `state`: one
/// still to be deployed, or moving. A robot the gate judged is a beacon:
/// its poses are not this forger's target (a parked simulated robot is not
/// ticked, so its anchor is as old as its verdict, and a jump of a few
/// units over that long is not too fast).
fn series_targets(state: SlotState) -> bool {
    matches!(
        state,
        SlotState::Waiting
            | SlotState::Spawned
            | SlotState::Registered
            | SlotState::Deploying
            | SlotState::Moving
    )
}

/// A `Register` of robot `id` by a process of `instance`, otherwise as the
/// harness's own agents send it; each forgery changes one field.
fn forged_register(id: u32, instance: u64) -> Register {
    Register {
        robot: RobotId(id),
        kind: bycoms_protocol::msg::RobotKind::Simulated,
        protocol_version: bycoms_protocol::PROTOCOL_VERSION,
        instance,
        settings: 0,
        failsafe_grace_ms: 0,
    }
}

fn register(r: Register) -> Input {
    Input::Report(FromAgent::Register(r))
}

/// Poses in one series of forgeries at the goal.
const SERIES: u32 = 40;

/// A pose of `robot` at `goal` at `step` (its time step × 0.1 s).
pub(super) fn at_the_goal(robot: u32, goal: Vec2, step: u64) -> Pose {
    Pose {
        robot: RobotId(robot),
        x: goal.x,
        y: goal.y,
        heading: 0.0,
        step,
        time_us: step.saturating_mul(100_000),
    }
}
