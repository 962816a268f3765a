//! OptiTrack NatNet as the launch's pose source.
//!
//! Why a layer over the client and the pipeline: the launch needs trusted
//! poses keyed by robot, and the operator and the recording need what went
//! wrong in words (a lost body by its Motive name, a rejected jump), and
//! the exact frames used (so `orchestrator replay` can re-run a lab run).
//! The client keeps the last frame's datagram; the source hands it out
//! with the poses derived from it.

use super::client::{ClientError, NatNetClient};
use super::config::NatNetSourceConfig;
use super::names::BodyMap;
use super::pipeline::{FramePipeline, PoseBatch};
use super::tracker::PoseTracker;
use bycoms_protocol::natnet::{encode_packet, ModelDefinitions, Packet, Version};
use std::time::{Duration, Instant};

/// Why the NatNet source failed.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The NatNet client failed.
    #[error(transparent)]
    Client(#[from] ClientError),
    /// Configured bodies the mocap system does not define.
    #[error("mocap defines no rigid body named {}", .0.join(", "))]
    MissingBodies(Vec<String>),
}

/// OptiTrack NatNet as a pose source.
pub struct NatNetPoseSource {
    client: NatNetClient,
    pipeline: FramePipeline,
    defs: ModelDefinitions,
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
        Ok(Self { client, pipeline: FramePipeline::new(config.arena, bodies, tracker), defs })
    }

    /// The next frame's trusted poses and events, or `None` if no frame
    /// came within `timeout` (zero: only what has already arrived). No
    /// frame is not "stopped": the gate simply sees no pose.
    pub fn poll(&mut self, timeout: Duration) -> Result<Option<PoseBatch>, SourceError> {
        Ok(self.client.next_frame(timeout)?.map(|frame| self.pipeline.on_frame(&frame)))
    }

    /// The datagram of the frame the last [`NatNetPoseSource::poll`]
    /// returned poses for (to record it), and when it was received.
    pub fn last_frame(&self) -> (&[u8], Instant) {
        self.client.last_frame()
    }

    /// The bitstream version the frames are in.
    pub fn version(&self) -> Version {
        self.client.version()
    }

    /// The model definitions as a NatNet packet (to record them: a replay
    /// of the frames needs the names).
    pub fn model_definitions_packet(&self) -> Vec<u8> {
        // Definitions that parsed always encode again (fuzzed round trip).
        encode_packet(&Packet::ModelDef(self.defs.clone()), self.version()).unwrap_or_default()
    }

    /// The pipeline (e.g. to anchor a robot placed at the start).
    pub fn pipeline_mut(&mut self) -> &mut FramePipeline {
        &mut self.pipeline
    }
}
