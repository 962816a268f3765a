//! One ROS 2 ground robot (a TurtleBot, an e-puck2, any differential drive
//! that takes `cmd_vel`) as a BYCOMS robot.
//!
//! Why its own crate: the robot's agent needs the simulation's field
//! (`bycoms-sim`, which depends on `bycoms-agent`, so it cannot live there),
//! the gateway's session rules and the drive law (`bycoms-agent`), and a ROS 2
//! publisher on zenoh. It is one process per robot, as the card says, and
//! appears on the bus like a gateway (kind `Real`): the launch tells it
//! `Deploy`, the goal bearing and the beacons, and forwards its trusted pose
//! from motion capture.
//!
//! * [`core`] — the agent as a sans-IO state machine: commands, beacons,
//!   its own pose and `now` in; velocity commands and reports out; a
//!   [`RobotSide`](bycoms_agent::gateway::RobotSide) of the gateway's
//!   session.
//! * [`run`] — the loop: the bus side (the gateway's), the session, and
//!   the robot's `cmd_vel` behind the [`run::CmdVel`] seam.
//! * [`cmd_vel`] — that seam on the ROS 2 graph: a `Twist` or
//!   `TwistStamped` publisher over rmw_zenoh.
//! * [`cli`] — the command line (`Ros2RobotArgs`, whose `to_flags` a
//!   launcher starts it with) and `main`.

pub mod cli;
pub mod cmd_vel;
pub mod core;
pub mod run;

pub use core::{Output, Ros2RobotCore, Settings};
