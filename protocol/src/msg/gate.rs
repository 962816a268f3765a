//! Orchestrator → monitors and recorders: the deployment gate's decisions.
//!
//! Why an event stream: robot k+1 starts only when robot k has stopped
//! (stuck → it becomes a beacon, arrived → the run is won). Publishing each
//! decision with the position it was taken at lets a recorder or a live
//! view explain a run without re-deriving it from poses.

use crate::RobotId;
use serde::{Deserialize, Serialize};

/// What happened to a robot at the gate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum GateKind {
    /// The robot was deployed.
    Deployed,
    /// The robot stopped moving: at the goal (`arrived`) or stuck.
    Stopped {
        /// True when it stopped within the goal radius.
        arrived: bool,
    },
    /// The robot's process or link died; it is treated as stopped where it
    /// was last seen.
    Died,
    /// The run's time limit expired while the robot was moving.
    Timeout,
}

/// One gate decision.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GateEvent {
    /// The robot concerned.
    pub robot: RobotId,
    /// What happened.
    pub kind: GateKind,
    /// Position x where it happened.
    pub x: f64,
    /// Position y where it happened.
    pub y: f64,
    /// The step it happened at.
    pub step: u64,
}
