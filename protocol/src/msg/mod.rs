//! The wire messages, one module per direction of travel.
//!
//! Why split by direction (as dora-rs does): a process can only send what
//! its topic's type allows, so an agent cannot accidentally emit an
//! orchestrator command, and each topic carries exactly one enum:
//!
//! | module | from → to | topic (see [`crate::naming`]) | type |
//! |---|---|---|---|
//! | [`to_agent`] | orchestrator → one agent | `robot/<id>/to_agent` | [`ToAgent`] |
//! | [`from_agent`] | agents → orchestrator | `from_agents` | [`FromAgent`] |
//! | [`mocap`] | mocap (real or simulated) → orchestrator | `robot/<id>/pose` | [`Pose`] |
//! | [`sensor`] | world/sensor → one agent | `robot/<id>/sensor` | [`Sensor`] |
//! | [`gate`] | orchestrator → monitors, recorders | `gate` | [`GateEvent`] |
//!
//! Every field has a fixed size (no strings, no vectors), so the types are
//! `no_std` without `alloc` and every encoding fits in
//! [`crate::MAX_MESSAGE_LEN`] bytes. Angles are radians in the world frame,
//! positions are grid units, `step` counts control periods (lockstep) or
//! mocap frames (real time).

pub mod from_agent;
pub mod gate;
pub mod mocap;
pub mod sensor;
pub mod to_agent;

pub use from_agent::{
    ClockOffset, Commanded, DriveState, FailsafeFired, FromAgent, Heartbeat, LinkStatus, Parked, Register,
    RobotKind, Sensed, Status, StopDone, Telemetry, TickDone, HEARTBEAT_MS,
};
pub use gate::{GateEvent, GateKind};
pub use mocap::Pose;
pub use sensor::{FieldSample, Sensor};
pub use to_agent::{Beacon, Deploy, GoalBearing, Refusal, Refused, Tick, Ticks, ToAgent};

impl crate::Message for ToAgent {}
impl crate::Message for FromAgent {}
impl crate::Message for Pose {}
impl crate::Message for Sensor {}
impl crate::Message for GateEvent {}
/// On its own (topic `operator`): a request to place a robot at a pose.
impl crate::Message for Deploy {}
