//! The NatNet and replay sources behind the launch's poses seam
//! (`launch::poses::PoseSource`).
//!
//! Why an adapter and not the types themselves: the seam's contract is
//! "hand every pose since the last drain, never wait, only opened robots,
//! tagged with the robot", while [`NatNetPoseSource`] and
//! [`ReplayPoseSource`] are usable on their own (placement, the benchmark,
//! `orchestrator replay`). NatNet also records what it used: the model
//! definitions once and every frame's datagram (`mocap/natnet_modeldef`,
//! `mocap/natnet`), besides the trusted poses the sink records on the
//! robots' pose topics — so a lab run replays from its poses and its
//! frames alike.

use super::natnet_source::NatNetPoseSource;
use super::replay_source::ReplayPoseSource;
use super::ArenaPose;
use crate::launch::poses::{PoseError, PoseSink, PoseSource};
use crate::mocap::PlacementConfig;
use crate::record::schema::{NATNET_FRAME, NATNET_MODELDEF};
use bycoms_protocol::msg::Pose;
use bycoms_protocol::RobotId;
use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

/// Recording leaf of the frames.
pub const FRAME_LEAF: &str = crate::record::schema::NATNET_FRAME_LEAF;
/// Recording leaf of the model definitions.
pub const MODELDEF_LEAF: &str = crate::record::schema::NATNET_MODELDEF_LEAF;

/// NatNet behind the seam.
pub struct NatNetPoses {
    source: NatNetPoseSource,
    opened: BTreeSet<u32>,
    /// Robots the operator is carrying to the start, with the last pose
    /// handed over for each: their track is forgotten before every frame,
    /// so no hand-speed move is taken for an identity swap, and anchored at
    /// that last pose once the robot is placed.
    carried: BTreeMap<u32, Option<Pose>>,
    defs_recorded: bool,
    placement: Option<PlacementConfig>,
}

impl NatNetPoses {
    /// Wraps a connected source.
    pub fn new(source: NatNetPoseSource) -> Self {
        Self {
            source,
            opened: BTreeSet::new(),
            carried: BTreeMap::new(),
            defs_recorded: false,
            placement: None,
        }
    }

    /// Robots are confirmed at the start with `placement` (the section
    /// `[mocap.natnet.placement]`), not with the agents' settings.
    pub fn with_placement(mut self, placement: PlacementConfig) -> Self {
        self.placement = Some(placement);
        self
    }

    /// The source.
    pub fn source_mut(&mut self) -> &mut NatNetPoseSource {
        &mut self.source
    }

    fn forget_carried(&mut self) {
        let tracker = self.source.pipeline_mut().tracker_mut();
        for &id in self.carried.keys() {
            tracker.forget(RobotId(id));
        }
    }
}

impl PoseSource for NatNetPoses {
    fn kind(&self) -> &'static str {
        "natnet"
    }

    fn on_the_bus(&self) -> bool {
        false
    }

    fn placement(&self) -> Option<PlacementConfig> {
        self.placement
    }

    fn open_robot(&mut self, id: u32) -> Result<(), PoseError> {
        self.opened.insert(id);
        Ok(())
    }

    fn drain(&mut self, sink: &mut PoseSink<'_>) -> Result<(), PoseError> {
        if !self.defs_recorded {
            self.defs_recorded = true;
            sink.record_source_bytes(MODELDEF_LEAF, NATNET_MODELDEF, &self.source.model_definitions_packet());
        }
        loop {
            self.forget_carried();
            let Some(batch) = self.source.poll(Duration::ZERO).map_err(|e| PoseError::Other(Box::new(e)))?
            else {
                break;
            };
            sink.record_source_bytes(FRAME_LEAF, NATNET_FRAME, self.source.last_frame().0);
            for pose in batch.poses.iter().filter(|p| self.opened.contains(&p.robot.0)) {
                if let Some(last) = self.carried.get_mut(&pose.robot.0) {
                    *last = Some(*pose);
                }
                sink.pose(pose.robot.0, *pose);
            }
        }
        Ok(())
    }

    fn carried(&mut self, id: u32, by_hand: bool) {
        if by_hand {
            self.carried.insert(id, None);
        } else if let Some(Some(p)) = self.carried.remove(&id) {
            let at = ArenaPose { x: p.x, y: p.y, heading: p.heading };
            self.source.pipeline_mut().tracker_mut().anchor(RobotId(id), at, p.time_us);
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
