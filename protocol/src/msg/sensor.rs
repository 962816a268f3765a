//! World/sensor → agent: what one robot senses.
//!
//! Why a separate direction: in simulation the world process computes the
//! field at the robot's position; on a real robot the microphones do. Either
//! way the agent sees the same [`FieldSample`], and, where it has no
//! compass of its own, its own [`Pose`] (heading θ) from mocap.

use crate::msg::Pose;
use crate::RobotId;
use serde::{Deserialize, Serialize};

/// The field sensed at the robot's position.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FieldSample {
    /// The sensing robot.
    pub robot: RobotId,
    /// Field intensity g (sum over the other robots).
    pub intensity: f64,
    /// Direction φf of the field gradient (towards the sources), rad.
    pub direction: f64,
    /// The step the sample was taken at.
    pub step: u64,
}

/// Everything the world or the sensors tell one agent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Sensor {
    /// A field sample.
    Field(FieldSample),
    /// The robot's own pose (heading θ), e.g. relayed from mocap.
    Pose(Pose),
}
