//! Motion capture → orchestrator: where a robot is.
//!
//! Why f64: in lockstep the simulated mocap reports the body's exact pose,
//! and the multi-process run must reproduce the in-process simulator's
//! trajectory bit for bit; f32 would round it. Real mocap (NatNet) sends
//! f32, which widens losslessly.

use crate::RobotId;
use serde::{Deserialize, Serialize};

/// One robot's pose at one instant.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// The robot observed.
    pub robot: RobotId,
    /// Position x, grid units.
    pub x: f64,
    /// Position y, grid units.
    pub y: f64,
    /// Heading θ in the world frame, rad.
    pub heading: f64,
    /// Lockstep step, or the mocap frame number in real time.
    pub step: u64,
    /// Time of the observation, µs since the run started (in lockstep:
    /// `step × dt`).
    pub time_us: u64,
}
