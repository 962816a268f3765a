//! Motion capture in: where every robot is, from a source the gate can trust.
//!
//! Why here and not in `launch`: the launch has a *pose source* seam
//! with four kinds — the simulated mocap the agents publish,
//! OptiTrack NatNet, a ROS 2 driver's topics, and replay of a recording. This module is NatNet's
//! plain types (client, pipeline, tracker, placement) below the launch and
//! knowing nothing of it; the launch's seam adapts them
//! (`launch::poses::mocap`), and the replay kind is `replay::source`
//! (ARCHITECTURE.md, "Crates of the orchestrator").
//!
//! * [`config`]: the launch config's `[mocap]` section;
//! * [`natnet_source`]: NatNet client → pipeline, with what to record;
//! * [`placement`]: the operator places a robot, mocap confirms;
//! * [`client`]: NatNet over UDP (command channel, unicast or multicast);
//! * [`arena`]: axes, origin, scale, heading into the arena frame;
//! * [`names`]: rigid-body name → robot id;
//! * [`tracker`]: occlusion held, identity swaps rejected;
//! * [`pipeline`]: frame → poses, sans-IO (also what a replay runs);
//! * [`topics`]: a ROS 2 driver's `PoseStamped` samples → poses, sans-IO,
//!   through the same tracker.

pub mod arena;
pub mod client;
pub mod config;
pub mod names;
pub mod natnet_source;
pub mod pipeline;
/// Placement, in the gate's crate (`orchestrator/gate/src/placement.rs`).
pub use bycoms_gate::placement;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod topics;
pub mod tracker;

pub use arena::{ArenaPose, ArenaTransform, UpAxis};
pub use client::{ClientConfig, ClientError, NatNetClient};
pub use config::{MocapConfig, MocapSource, NatNetSourceConfig, PlacementConfig, Ros2MocapConfig};
pub use names::BodyMap;
pub use natnet_source::{NatNetPoseSource, SourceError};
pub use pipeline::{FramePipeline, PoseBatch};
pub use placement::PlacementWatch;
pub use topics::TopicPipeline;
pub use tracker::{PoseTracker, Sighting, TrackEvent, TrackerConfig};

#[cfg(test)]
mod tests;
