//! Agent → orchestrator: registration, liveness and lockstep replies.
//!
//! Why no pose here: the orchestrator learns where a robot is from motion
//! capture ([`crate::msg::Pose`]), exactly as a lab would; an agent only
//! says that it exists, that it is alive, which mode it is in, and that it
//! has finished a lockstep tick. All agents share one `from_agents` topic,
//! so every message carries the sender's [`RobotId`].

use crate::RobotId;
use serde::{Deserialize, Serialize};

/// What kind of robot stands behind an agent process.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum AgentKind {
    /// A simulated body (`sim-agent`).
    Simulated,
    /// A real robot bridged over WiFi (`agent`).
    Real,
}

/// First message of an agent: who it is and which protocol it speaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Register {
    /// The agent's robot.
    pub robot: RobotId,
    /// Simulated or real.
    pub kind: AgentKind,
    /// The agent's [`crate::PROTOCOL_VERSION`], so a mismatch is reported
    /// by name even when the envelope check already passed.
    pub protocol_version: u16,
}

/// Periodic liveness signal; `seq` increases by one per heartbeat.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Heartbeat {
    /// The agent's robot.
    pub robot: RobotId,
    /// Heartbeat sequence number.
    pub seq: u64,
}

/// The controller's mode after a step (1 = goal, 2 = bypass).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Status {
    /// The agent's robot.
    pub robot: RobotId,
    /// Controller mode: 1 or 2 as in the paper.
    pub mode: u8,
    /// The step this status belongs to.
    pub step: u64,
}

/// Lockstep reply: the agent has finished `step`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TickDone {
    /// The agent's robot.
    pub robot: RobotId,
    /// The step that was completed.
    pub step: u64,
}

/// Everything an agent tells the orchestrator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum FromAgent {
    /// Announce the agent.
    Register(Register),
    /// Liveness.
    Heartbeat(Heartbeat),
    /// Mode report.
    Status(Status),
    /// Lockstep reply.
    TickDone(TickDone),
}

impl FromAgent {
    /// The robot that sent this message.
    pub fn robot(&self) -> RobotId {
        match self {
            Self::Register(m) => m.robot,
            Self::Heartbeat(m) => m.robot,
            Self::Status(m) => m.robot,
            Self::TickDone(m) => m.robot,
        }
    }
}
