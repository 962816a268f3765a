//! bycoms' own ROS 2 messages, the `bycoms_msgs` package a lab builds with
//! colcon from `deploy/ros2/bycoms_msgs/` (`msg/*.msg`): gate events and
//! robot states.
//!
//! Why described here as well as in the `.msg` files: the launch needs the
//! type hash and the CDR without a ROS install. The two cannot drift:
//! `tests/python/ros2_golden.py` reads the `.msg` files with PyPI
//! `rosbags` and `tests/golden.rs` pins its hashes and bytes against ours.

use crate::cdr::CdrWriter;
use crate::msgs::{Header, RosMessage, Time, HEADER, TIME};
use crate::types::{Field, Primitive as P, TypeDescription};

description!(
    GATE_EVENT,
    "bycoms_msgs/msg/GateEvent",
    [
        Field::nested("stamp", &TIME),
        Field::prim("robot", P::Uint32),
        Field::prim("kind", P::Uint8),
        Field::prim("arrived", P::Bool),
        Field::prim("x", P::Float64),
        Field::prim("y", P::Float64),
        Field::prim("step", P::Uint64)
    ]
);
description!(
    ROBOT_STATE,
    "bycoms_msgs/msg/RobotState",
    [
        Field::nested("header", &HEADER),
        Field::prim("robot", P::Uint32),
        Field::prim("state", P::Uint8),
        Field::prim("x", P::Float64),
        Field::prim("y", P::Float64),
        Field::prim("heading", P::Float64),
        Field::prim("step", P::Uint64),
        Field::prim("real", P::Bool)
    ]
);

/// `GateEvent.kind`'s constants.
pub mod gate_kind {
    /// The robot was deployed.
    pub const DEPLOYED: u8 = 0;
    /// It stopped (`arrived` says where).
    pub const STOPPED: u8 = 1;
    /// Its process or link died.
    pub const DIED: u8 = 2;
    /// The run's time limit expired while it moved.
    pub const TIMEOUT: u8 = 3;
}

/// `RobotState.state`'s constants.
pub mod robot_state {
    /// Not deployed yet.
    pub const WAITING: u8 = 0;
    /// Deployed and moving.
    pub const MOVING: u8 = 1;
    /// Stopped short of the goal: a beacon.
    pub const BEACON: u8 = 2;
    /// Stopped within the goal radius.
    pub const ARRIVED: u8 = 3;
    /// Died (process or link).
    pub const LOST: u8 = 4;
    /// Still moving when the run's time ran out.
    pub const TIMED_OUT: u8 = 5;
}

/// `bycoms_msgs/msg/GateEvent`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GateEvent {
    /// The run's time of the decision.
    pub stamp: Time,
    /// The robot.
    pub robot: u32,
    /// [`gate_kind`].
    pub kind: u8,
    /// Stopped within the goal radius.
    pub arrived: bool,
    /// Where, x.
    pub x: f64,
    /// Where, y.
    pub y: f64,
    /// The run's step.
    pub step: u64,
}

impl RosMessage for GateEvent {
    const DESCRIPTION: &'static TypeDescription = &GATE_EVENT;
    fn write(&self, w: &mut CdrWriter) {
        self.stamp.write(w);
        w.u32(self.robot);
        w.u8(self.kind);
        w.bool(self.arrived);
        w.f64(self.x);
        w.f64(self.y);
        w.u64(self.step);
    }
}

/// `bycoms_msgs/msg/RobotState`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RobotState {
    /// The run's time and the world frame.
    pub header: Header,
    /// The robot.
    pub robot: u32,
    /// [`robot_state`].
    pub state: u8,
    /// Its last position, x.
    pub x: f64,
    /// Its last position, y.
    pub y: f64,
    /// Its last heading, rad.
    pub heading: f64,
    /// The step of that pose.
    pub step: u64,
    /// Whether the robot has a real body (false: simulated).
    pub real: bool,
}

impl RosMessage for RobotState {
    const DESCRIPTION: &'static TypeDescription = &ROBOT_STATE;
    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        w.u32(self.robot);
        w.u8(self.state);
        w.f64(self.x);
        w.f64(self.y);
        w.f64(self.heading);
        w.u64(self.step);
        w.bool(self.real);
    }
}
