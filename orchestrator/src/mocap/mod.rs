//! Motion capture in: where every robot is, from a source the gate can trust.
//!
//! Why one narrow trait: the launch has a *pose source* seam (design §5)
//! with three kinds — the simulated mocap the agents publish, OptiTrack
//! NatNet, and replay of a recording. The launch engine only ever asks
//! [`PoseSource::next_batch`] for the next frame's trusted poses; this
//! module provides the trait and the NatNet kind (the other two come with
//! the launch refactor and fit the same shape: a [`PoseBatch`] per frame).
//!
//! * [`client`]: NatNet over UDP (command channel, unicast or multicast);
//! * [`arena`]: axes, origin, scale, heading into the arena frame;
//! * [`names`]: rigid-body name → robot id;
//! * [`tracker`]: occlusion held, identity swaps rejected;
//! * [`pipeline`]: frame → poses, sans-IO (also what a replay runs).

pub mod arena;
pub mod client;
pub mod names;
pub mod pipeline;
pub mod tracker;

pub use arena::{ArenaPose, ArenaTransform, UpAxis};
pub use client::{ClientConfig, ClientError, NatNetClient};
pub use names::BodyMap;
pub use pipeline::{FramePipeline, PoseBatch};
pub use tracker::{PoseTracker, Sighting, TrackEvent, TrackerConfig};

use bycoms_protocol::RobotId;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::time::Duration;

/// Why a pose source failed.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The NatNet client failed.
    #[error(transparent)]
    Client(#[from] ClientError),
    /// Configured bodies the mocap system does not define.
    #[error("mocap defines no rigid body named {}", .0.join(", "))]
    MissingBodies(Vec<String>),
}

/// Where robots' poses come from, frame by frame.
pub trait PoseSource {
    /// The next frame's trusted poses, or `None` if no frame came within
    /// `timeout` (the gate then simply waits: no pose is not "stopped").
    fn next_batch(&mut self, timeout: Duration) -> Result<Option<PoseBatch>, SourceError>;
}

/// The NatNet source's configuration (part of a launch config).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NatNetSourceConfig {
    /// How to reach the server.
    pub client: ClientConfig,
    /// Mocap → arena.
    #[serde(default)]
    pub arena: ArenaTransform,
    /// Rigid-body name → robot id.
    pub bodies: BTreeMap<String, RobotId>,
    /// The tracker's limits.
    pub tracker: TrackerConfig,
}

/// OptiTrack NatNet as a pose source.
pub struct NatNetPoseSource {
    client: NatNetClient,
    pipeline: FramePipeline,
}

impl NatNetPoseSource {
    /// Connects, reads the model definitions and maps names to robots;
    /// fails naming any configured body the server does not define.
    pub fn connect(config: &NatNetSourceConfig) -> Result<Self, SourceError> {
        let mut client = NatNetClient::connect(&config.client)?;
        let defs = client.model_definitions()?;
        let bodies = BodyMap::resolve(&defs, &config.bodies);
        if !bodies.missing.is_empty() {
            return Err(SourceError::MissingBodies(bodies.missing));
        }
        let tracker = PoseTracker::new(config.tracker, config.bodies.values().copied());
        Ok(Self { client, pipeline: FramePipeline::new(config.arena, bodies, tracker) })
    }

    /// The pipeline (e.g. to anchor a robot placed at the start).
    pub fn pipeline_mut(&mut self) -> &mut FramePipeline {
        &mut self.pipeline
    }
}

impl PoseSource for NatNetPoseSource {
    fn next_batch(&mut self, timeout: Duration) -> Result<Option<PoseBatch>, SourceError> {
        Ok(self.client.next_frame(timeout)?.map(|frame| self.pipeline.on_frame(&frame)))
    }
}

#[cfg(test)]
mod tests;
