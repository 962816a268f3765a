//! The emulated lab's OptiTrack: a NatNet 4.1 server for its bodies.
//!
//! Why: a lab run must go end to end through real sockets, with the
//! orchestrator unable to tell the emulator from Motive. The server speaks
//! the real binary format (`bycoms_protocol::natnet`), answers the command
//! channel (connect → server info, model definitions with the bodies'
//! names, keep-alive, single frames), streams at a configurable rate by
//! unicast (and to a multicast group if configured), and injects seeded
//! faults: lost frames, occlusion windows, marker noise, swapped ids.
//!
//! Why a crate of its own: the emulated lab (`sim-agent lab --natnet`), the
//! `natnet-serve` binary and the orchestrator's motion-capture tests all
//! serve bodies with it, and it needs nothing of the simulated world.
//!
//! * [`config`]: the TOML configuration;
//! * [`frames`]: sans-IO frame maker with the faults;
//! * [`server`]: the sockets and threads.

pub mod config;
pub mod frames;
pub mod server;

pub use config::{BodyConfig, Faults, Occlusion, OcclusionMode, ServerConfig, Swap};
pub use frames::{model_definitions, BodyPose, FrameMaker, MARKER_OFFSETS};
pub use server::{NatNetServer, ServerError, SERVED_VERSION};

#[cfg(test)]
mod tests;
