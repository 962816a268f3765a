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

/// Lockstep clock: run `count` control periods at once, numbered `step`,
/// `step + 1`, …, publishing each one's pose (and a status when the mode
/// changed), then answer
/// once with [`crate::msg::TickDone`] for `step`. If the robot parks on
/// the way (it will never move again), it stops there and says
/// [`crate::msg::Parked`] for that period before the answer.
///
/// Why: a robot judged stuck that still creeps is sent no goal bearing and
/// no beacons any more, so its next periods depend on nothing the
/// orchestrator could still tell it; one message steps many of them, and
/// the orchestrator holds each pose until its tick (parity with
/// `simulate` is kept). A `Ticks` repeated (its answer was lost) is
/// answered again without stepping.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Ticks {
    /// The first step to run.
    pub step: u64,
    /// How many periods to run (0 is taken as 1).
    pub count: u32,
}

/// A beacon of the robot's field: robot `robot` stands at (`x`, `y`).
///
/// Why the orchestrator tells it: a robot senses the robots that stopped
/// before it (the beacons of sequential deployment). The orchestrator
/// knows each one's last pose, so it hands every agent that will move the
/// positions it needs, instead of each agent reading every earlier
/// robot's pose topic (which cost memory and time that grew with the
/// swarm in every agent). A later `Beacon` of the same robot replaces its
/// position. `seq` numbers the beacons sent to this agent (1, 2, …): a gap
/// means one was lost.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Beacon {
    /// The robot that stands there (not the receiving agent's).
    pub robot: RobotId,
    /// Its position x, exactly as its last pose said.
    pub x: f64,
    /// Its position y, exactly as its last pose said.
    pub y: f64,
    /// This beacon message's number among those sent to this agent.
    pub seq: u32,
}

/// Why the orchestrator refused an agent.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Refusal {
    /// Another agent (another `instance`) already holds this robot.
    Duplicate,
    /// The agent was started with other run settings than the launch's
    /// (its [`crate::msg::Register::settings`] fingerprint differs).
    Settings {
        /// The launch's fingerprint.
        launch: u64,
    },
    /// The agent's failsafe grace is shorter than the time the launch
    /// waits for an unreachable agent (its link grace).
    Grace {
        /// The launch's link grace, ms.
        launch_ms: u32,
    },
    /// The robot's voice was taken away (`orchestrator revoke`): the
    /// launch refuses every agent of it from then on. Last, so an older
    /// decoder still reads the other reasons.
    Revoked,
    /// The agent's host clock is off the orchestrator's by more than the
    /// launch's limit (its `FromAgent::Clock`).
    Clock {
        /// The measured offset, ms (the agent's clock minus the
        /// orchestrator's, saturating).
        offset_ms: i32,
        /// The launch's limit, ms.
        limit_ms: u32,
    },
}

impl core::fmt::Display for Refusal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Duplicate => write!(f, "another agent already holds this robot"),
            Self::Settings { launch } => write!(
                f,
                "this agent was started with other run settings than the launch's (the launch's fingerprint is {launch:016x})"
            ),
            Self::Grace { launch_ms } => write!(
                f,
                "this agent's failsafe grace is shorter than the launch's link grace of {launch_ms} ms: start it with --orchestrator-grace of at least {} s",
                f64::from(*launch_ms) / 1000.0
            ),
            Self::Revoked => write!(
                f,
                "this robot was revoked in this launch (orchestrator revoke): it may not take part any more"
            ),
            Self::Clock { offset_ms, limit_ms } => write!(
                f,
                "this host's clock is {} ms {} the orchestrator's, past the launch's limit of {limit_ms} ms: synchronise both hosts' clocks (chrony: `chronyc tracking` shows the offset, `chronyc makestep` steps it; or ntpd / systemd-timesyncd) and start the agent again",
                offset_ms.unsigned_abs(),
                if *offset_ms < 0 { "behind" } else { "ahead of" }
            ),
        }
    }
}

/// The orchestrator refuses an agent. Every agent on the robot's topic
/// hears it; only the one whose [`crate::msg::Register::instance`] matches
/// leaves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Refused {
    /// The robot the agent registered for.
    pub robot: RobotId,
    /// The refused agent's instance.
    pub instance: u64,
    /// Why.
    pub why: Refusal,
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
    /// The agent with this instance is refused: it must exit.
    Refused(Refused),
    /// A robot that stands in the field (a beacon), or its new position.
    Beacon(Beacon),
    /// Advance several lockstep periods at once (a creeping robot judged
    /// stuck).
    Ticks(Ticks),
}
