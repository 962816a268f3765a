//! Poses read back from a launch recording, as a pose source (behind the
//! launch's poses seam, [`PoseSource`]).
//!
//! Why in `replay` and not in `mocap/`: it reads a recording with the
//! replay's reader ([`Recorded`]), which knows the launch core's log, so it
//! sits above the launch, as the replay does; motion capture sits below
//! (ARCHITECTURE.md, "Crates of the orchestrator"). It re-runs the NatNet
//! pipeline (`bycoms_mocap`) on recorded frames.
//!
//! Why two ways: every pose the gate saw is in the recording on its
//! robot's pose topic (whatever the source), so those are replayed as
//! they are. A NatNet run also holds the raw frames and the model
//! definitions; [`ReplayPoseSource::from_natnet_frames`] runs them through
//! the same pipeline (names, axes, tracker) again, which shows the trusted
//! poses follow from the frames.
//!
//! Why a channel inside: the poses can be fed while the source is in use
//! (a reader thread pacing a recording, a test emitting one by one) or all
//! at once ([`ReplayPoseSource::from_recorded_poses`]); draining never
//! waits. Poses of robots not opened are dropped, as a live source would
//! never have handed them over.

use super::{Entry, Recorded};
use bycoms_launch::poses::{PoseError, PoseSink, PoseSource};
use bycoms_mocap::{BodyMap, FramePipeline, NatNetSourceConfig, PoseTracker};
use bycoms_protocol::msg::Pose;
use bycoms_protocol::natnet::{parse_packet_versioned, Error as NatNetError, Packet, Version};
use std::collections::BTreeSet;
use std::sync::mpsc::{channel, Receiver, Sender};

/// Why a recording's frames cannot be replayed.
#[derive(Debug, thiserror::Error)]
pub enum ReplaySourceError {
    /// No model definitions before the first frame.
    #[error("the recording has mocap frames but no model definitions before them")]
    NoModelDefinitions,
    /// A recorded NatNet packet does not parse.
    #[error("recorded NatNet packet {index} does not parse: {source}")]
    BadPacket {
        /// Its index among the recorded NatNet packets.
        index: usize,
        /// The codec's error.
        source: NatNetError,
    },
}

/// Recorded poses, handed out in order.
pub struct ReplayPoseSource {
    rx: Receiver<Pose>,
    opened: BTreeSet<u32>,
}

impl ReplayPoseSource {
    /// An empty source and the sender that feeds it.
    pub fn channel() -> (Sender<Pose>, Self) {
        let (tx, rx) = channel();
        (tx, Self { rx, opened: BTreeSet::new() })
    }

    /// The poses on the recording's pose topics, in recorded order.
    pub fn from_recorded_poses(recorded: &Recorded) -> Self {
        let poses = recorded.entries.iter().filter_map(|e| match e {
            Entry::Pose(p) => Some(*p),
            _ => None,
        });
        Self::from_poses(poses)
    }

    /// The trusted poses the NatNet pipeline derives again from the
    /// recording's frames, with `config` (the run's `[mocap.natnet]`).
    pub fn from_natnet_frames(
        recorded: &Recorded,
        config: &NatNetSourceConfig,
        version: Version,
    ) -> Result<Self, ReplaySourceError> {
        let mut pipeline: Option<FramePipeline> = None;
        let mut poses = Vec::new();
        let mut index = 0;
        for entry in &recorded.entries {
            let bytes = match entry {
                Entry::MocapFrame(b) | Entry::MocapModelDef(b) => b,
                _ => continue,
            };
            let packet = parse_packet_versioned(bytes, version)
                .map_err(|source| ReplaySourceError::BadPacket { index, source })?;
            index += 1;
            match packet {
                Packet::ModelDef(defs) => {
                    let bodies = BodyMap::resolve(&defs, &config.bodies);
                    let tracker = PoseTracker::new(config.tracker, config.bodies.values().copied());
                    pipeline = Some(FramePipeline::new(config.arena, bodies, tracker));
                }
                Packet::FrameOfData(frame) => {
                    let p = pipeline.as_mut().ok_or(ReplaySourceError::NoModelDefinitions)?;
                    poses.extend(p.on_frame(&frame).poses);
                }
                _ => {}
            }
        }
        Ok(Self::from_poses(poses))
    }

    fn from_poses(poses: impl IntoIterator<Item = Pose>) -> Self {
        let (tx, source) = Self::channel();
        for p in poses {
            // The receiver is alive (held by `source`).
            let _ = tx.send(p);
        }
        source
    }

    /// Hands over robot `id`'s poses from now on.
    pub fn open(&mut self, id: u32) {
        self.opened.insert(id);
    }

    /// The next pose of an opened robot, without waiting.
    pub fn next_opened(&mut self) -> Option<Pose> {
        loop {
            let pose = self.rx.try_recv().ok()?;
            if self.opened.contains(&pose.robot.0) {
                return Some(pose);
            }
        }
    }
}

impl PoseSource for ReplayPoseSource {
    fn kind(&self) -> &'static str {
        "replay"
    }

    fn on_the_bus(&self) -> bool {
        false
    }

    fn open_robot(&mut self, id: u32) -> Result<(), PoseError> {
        self.open(id);
        Ok(())
    }

    fn drain(&mut self, sink: &mut PoseSink<'_>) -> Result<(), PoseError> {
        while let Some(pose) = self.next_opened() {
            sink.pose(pose.robot.0, pose);
        }
        Ok(())
    }
}
