//! The `agent` binary: the gateway between one real robot and the bus.
//!
//! A real robot (an ESP32 running `bycoms_agent::firmware`) speaks the
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
//!   commands, poses and `now` in; datagrams and bus reports out);
//! * [`run`] — the single-threaded loop around it: a UDP socket and the
//!   iceoryx2 bus;
//! * [`cli`] — the command line and `main`;
//! * [`bench`] — `agent bench`: the gateway's added latency.
//!
//! Why a crate of its own and not a `std` feature of `bycoms-agent`: the
//! agent crate is the no_std firmware core and `bycoms-sim` depends on it,
//! while the gateway reuses `sim-agent`'s process pieces (the lifeline that
//! forbids orphans, the bus sizing every process of a swarm must share, the
//! bad-traffic counters) from `bycoms-sim`; inside `bycoms-agent` that would
//! be a dependency cycle.
//!
//! [`Real`]: bycoms_protocol::msg::AgentKind::Real

pub mod bench;
pub mod cli;
pub mod core;
pub mod run;

pub use cli::{main_with, GatewayArgs, GatewayError};
pub use core::{GatewayCore, Output, Timers};
