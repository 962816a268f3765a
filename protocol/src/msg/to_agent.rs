//! Orchestrator → agent: the commands that drive one robot.
//!
//! Why these and no more: the paper's robot is given only its goal bearing
//! and a field sample; everything else (when to start, the lockstep clock,
//! when to stop) is the orchestrator's job. Each robot has its own
//! `to_agent` topic, so [`Tick`], [`ToAgent::Stop`] and
//! [`ToAgent::Shutdown`] need no robot id.

use crate::RobotId;
use serde::{Deserialize, Serialize};

/// Deploy (start) a robot at its start pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Deploy {
    /// The robot being deployed.
    pub robot: RobotId,
    /// Start position x.
    pub x: f64,
    /// Start position y.
    pub y: f64,
    /// Initial heading θ, rad.
    pub heading: f64,
}

/// The goal bearing φg for the robot's next control period.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GoalBearing {
    /// The robot the bearing is for.
    pub robot: RobotId,
    /// Goal bearing φg in the world frame, rad.
    pub bearing: f64,
    /// The step the bearing was computed for.
    pub step: u64,
}

/// Lockstep clock: run control period `step`, then answer with
/// [`crate::msg::TickDone`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Tick {
    /// The step to run.
    pub step: u64,
}

/// The orchestrator refuses an agent: another agent (another `instance`)
/// already holds this robot. Every agent on the robot's topic hears it;
/// only the one whose [`crate::msg::Register::instance`] matches leaves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Refused {
    /// The robot the agent registered for.
    pub robot: RobotId,
    /// The refused agent's instance.
    pub instance: u64,
}

/// Everything the orchestrator tells one agent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum ToAgent {
    /// Start moving from the given pose.
    Deploy(Deploy),
    /// A new goal bearing.
    GoalBearing(GoalBearing),
    /// Advance one lockstep period.
    Tick(Tick),
    /// Stop moving and stay put (the robot becomes a beacon).
    Stop,
    /// Exit the agent process.
    Shutdown,
    /// The agent with this instance is refused (a duplicate): it must exit.
    Refused(Refused),
}
