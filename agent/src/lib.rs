//! One BYCOMS robot's agent: the controller, as one piece of code for every
//! shell, the real robot's firmware core, and (feature `gateway`) the
//! `gateway` binary, the real robot's gateway to the bus.
//!
//! The controller and the firmware core are sans-IO: inputs (and, where
//! needed, time as an argument) go in, commands come out. No clocks, no
//! randomness, no allocation, no `std`. The in-process simulator and the
//! `sim-agent` process call the same controller, which is what makes a
//! lockstep run over processes bit-identical to the in-process simulator;
//! the real robot's firmware core (ESP32, and the host under QEMU replay)
//! calls the same functions on the robot. The gateway runs no controller:
//! it relays between the robot's link and the bus.
//!
//! * [`point`] — the point-robot controller of the paper's simulation (§IV):
//!   mode 1 (head for the goal) / mode 2 (walk along a companion's field),
//!   three motions (straight, turn cw, turn ccw).
//! * [`acoustic`] — the pieces of the physical robot (§VI): gradient
//!   estimation from a microphone ring, integer DFT tone isolation, and the
//!   differential-drive controller.
//! * [`firmware`] — the real robot's firmware core: link frames and
//!   microphone frames in, motor commands, its tone and link frames out.
//! * [`wheeled`] — the same drive law on a wheeled robot that takes velocity
//!   commands (a ROS 2 robot's `cmd_vel`) and senses the field virtually
//!   from motion capture: a field sample in, (v, ω) out.
//! * [`angle`] — the angle arithmetic both share.
//! * `gateway` (feature `gateway`, std) — the `gateway` binary: one real
//!   robot's gateway between its authenticated UDP link and the bus.
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]
#![warn(clippy::std_instead_of_core, clippy::alloc_instead_of_core)]

pub mod acoustic;
pub mod angle;
pub mod firmware;
// A std program (sockets, threads, the bus): the core's no_std lints do not apply.
#[cfg(feature = "gateway")]
#[allow(clippy::std_instead_of_core, clippy::alloc_instead_of_core)]
pub mod gateway;
pub mod point;
pub mod wheeled;

pub use point::{Controller, ControllerConfig, FieldGoal, Input, Mode, Motion, Output};
