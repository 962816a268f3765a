//! The `gateway` binary: the gateway between one real robot and the bus
//! (feature `gateway`, default).
//!
//! A real robot (an ESP32 running [`crate::firmware`]) speaks the
//! authenticated UDP link of `protocol/LINK.md`; the orchestrator speaks the
//! bus. One gateway process per robot owns the robot's UDP link and appears
//! on the bus exactly like a `sim-agent`, with kind [`Real`]: it registers,
//! sends heartbeats and the robot's mode, forwards `Deploy` (→ Enable),
//! `GoalBearing` (world frame → the robot's frame, using the robot's heading
//! from motion capture), `Stop` and `Shutdown` (→ Stop) to the robot, and
//! publishes what only a real robot has: its telemetry, and its link's state
//! (lost within 500 ms of silence, restored, frames refused).
//!
//! * [`core`] — the gateway as a sans-IO state machine (datagrams, bus
//!   commands, poses and `now` in; datagrams and bus reports out), the
//!   robot side of its session;
//! * [`session`] — the bus-side rules around it, sans-IO too (register
//!   until heard, heartbeats, the orchestrator-liveliness failsafe,
//!   shutdown and refusal): [`GatewaySession`], a
//!   [`SansIo`](bycoms_protocol::SansIo) core in µs;
//! * [`run`] — the single-threaded loop around them: a UDP socket and the
//!   bus (iceoryx2, or zenoh from a bridge host), moving bytes only;
//! * [`cli`] — the command line and `main`;
//! * [`bench`] — `gateway bench`: the gateway's added latency.
//!
//! Why in `bycoms-agent`, behind a feature: the crate is one robot's
//! agent — its controller, its firmware core (no_std) and this gateway —
//! and the no_std build leaves the gateway out. The process pieces it
//! shares with `sim-agent` (the lifeline that forbids orphans, the bus
//! flags and sizing every process of a swarm must share, the failsafe, the
//! bad-traffic counters) are `bycoms_runtime`'s, not the simulator's:
//! `bycoms-sim` depends on this crate, so the gateway cannot depend on it.
//!
//! [`Real`]: bycoms_protocol::msg::RobotKind::Real

pub mod bench;
pub mod cli;
pub mod core;
pub mod run;
pub mod session;

pub use cli::{main_with, GatewayArgs, GatewayError};
pub use core::{Datagram, GatewayCore, Output, Refused, Timers};
pub use session::{GatewaySession, Input, Rejected, RobotSide, Session};
