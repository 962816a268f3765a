//! The poses seam: where the gate's poses come from.
//!
//! Why a trait: the gate judges motion from poses only, and a lab has
//! several ways to see its robots. Today the simulated agents publish
//! their own simulated motion capture on the bus ([`bus::BusPoses`]); a lab
//! has OptiTrack (NatNet, [`mocap::NatNetPoses`]), or its mocap in ROS 2
//! ([`ros2::Ros2Poses`]), and a replay of a recorded session. Each kind
//! implements [`PoseSource`]; the engine holds a `Box<dyn PoseSource>` and
//! knows none of them. A source needs no bus.
//!
//! Contract (checked for every implementation by the one conformance suite,
//! `orchestrator/tests/pose_source_suite.rs`):
//!
//! * [`PoseSource::open_robot`] is called for robot `id` before its agent
//!   is started; from then on every pose of that robot the source sees is
//!   handed over; poses of robots not opened are not;
//! * [`PoseSource::drain`] never waits: it hands every pose that arrived
//!   since the last drain to [`PoseSink::pose`], robots in id order, each
//!   robot's poses in arrival order, tagged with the robot the source saw
//!   it for (the bus: the topic's robot; mocap: the rigid body's robot);
//! * **recording**: a source that reads the bus ([`PoseSource::on_the_bus`]
//!   true) hands every message's bytes to [`PoseSink::raw`] *before*
//!   decoding them, garbage included, so the MCAP file holds exactly what
//!   crossed the bus (as before the seam). For any other source the sink
//!   records each pose it is handed, encoded with the one codec, on the
//!   robot's pose topic (`bycoms/<swarm>/robot/<id>/pose`): the file then
//!   holds what the gate saw, in the same schema, whatever its origin;
//! * what a source cannot use (bytes that do not decode, a bus error that
//!   is not fatal) goes to [`PoseSink::bad`] and is counted, never fatal; a
//!   fatal failure is returned as an error and ends the launch.

pub mod bus;
pub mod mocap;
pub mod ros2;

use super::recording::Recording;
use crate::record::schema;
use bycoms_protocol::bus::BusError;
use bycoms_protocol::msg::Pose;
use bycoms_protocol::{encode, RobotId, Swarm, MAX_MESSAGE_LEN};
use bycoms_runtime::Traffic;

/// The ROS 2 graph a source may read: its settings and session.
pub type Ros2Graph<'a> = (&'a super::ros2::Ros2Config, &'a zenoh::Session);

/// The pose source `mocap` asks for, for a launch of `robots` robots of
/// `swarm` on `bus`: the swarm's own bus, NatNet, or a ROS 2 driver's
/// topics in `ros2`'s graph. The seam's one factory: a new kind of source
/// enters here and nowhere else.
pub fn open(
    mocap: &crate::mocap::MocapConfig,
    robots: u32,
    bus: &super::transport::SharedBus,
    swarm: Swarm,
    ros2: Option<Ros2Graph<'_>>,
) -> anyhow::Result<Box<dyn PoseSource>> {
    use anyhow::Context;
    if let (crate::mocap::MocapSource::Ros2, Some(config)) = (&mocap.source, &mocap.ros2) {
        let (settings, session) =
            ros2.context("mocap.source = \"ros2\" needs a ROS 2 session (ros2.router)")?;
        let source = ros2::Ros2Poses::open(&config.for_robots(robots), settings, session)?;
        return Ok(Box::new(source));
    }
    Ok(match (&mocap.source, &mocap.natnet) {
        (crate::mocap::MocapSource::Natnet, Some(natnet)) => Box::new(
            mocap::NatNetPoses::new(
                crate::mocap::NatNetPoseSource::connect(&natnet.for_robots(robots))
                    .context("cannot use the NatNet mocap")?,
            )
            .with_placement(natnet.placement),
        ),
        _ => Box::new(
            bus::BusPoses::new(std::rc::Rc::clone(bus), swarm, robots)
                .context("cannot read the poses on the bus")?,
        ),
    })
}

/// Why a pose source failed (fatally: the launch ends).
#[derive(Debug, thiserror::Error)]
pub enum PoseError {
    /// The bus failed.
    #[error("pose source: {0}")]
    Bus(#[from] BusError),
    /// Any other failure of a source (its own typed error, boxed).
    #[error(transparent)]
    Other(Box<dyn std::error::Error + Send + Sync>),
}

/// Where the gate's poses come from; see the module docs for the contract.
pub trait PoseSource {
    /// The kind of source (`bus`, `natnet`, `replay`), for logs.
    fn kind(&self) -> &'static str;
    /// Whether the source reads the launch's bus and records the raw bytes
    /// itself ([`PoseSink::raw`]); otherwise the sink records decoded poses.
    fn on_the_bus(&self) -> bool;
    /// Starts handing over robot `id`'s poses (before its agent starts).
    fn open_robot(&mut self, id: u32) -> Result<(), PoseError>;
    /// Hands every pose that arrived since the last call to `sink`; never
    /// waits.
    fn drain(&mut self, sink: &mut PoseSink<'_>) -> Result<(), PoseError>;
    /// Robot `id` is being carried to the start by hand (`true`), or has
    /// been placed there (`false`). While it is carried any speed is
    /// plausible: a source that rejects moves faster than a robot drives
    /// (motion capture's identity-swap check) must hand them over; once it
    /// is placed, that check starts again from where it was placed. Sources
    /// without such a check ignore it (the default).
    fn carried(&mut self, _id: u32, _by_hand: bool) {}
    /// How this source confirms that a robot was placed at the start, when
    /// it has settings of its own for that (NatNet's `[mocap.natnet.placement]`);
    /// `None` (the default): the agents' `[agents.placement]` applies.
    fn placement(&self) -> Option<crate::mocap::PlacementConfig> {
        None
    }
}

/// Where a source hands its poses: the engine's intake, with the recording
/// and the bad-traffic counters of the launch.
pub struct PoseSink<'a> {
    recording: &'a mut Recording,
    traffic: &'a mut Traffic,
    swarm: &'a Swarm,
    poses: &'a mut Vec<(u32, Pose)>,
    record_decoded: bool,
    recorded: u64,
}

const WHO: &str = "launch";

impl<'a> PoseSink<'a> {
    /// A sink appending to `poses`. `record_decoded`: record each handed
    /// pose (for sources that are not on the bus; see the module docs).
    pub fn new(
        recording: &'a mut Recording,
        traffic: &'a mut Traffic,
        swarm: &'a Swarm,
        poses: &'a mut Vec<(u32, Pose)>,
        record_decoded: bool,
    ) -> Self {
        Self { recording, traffic, swarm, poses, record_decoded, recorded: 0 }
    }

    /// One pose of robot `robot` as the source saw it.
    pub fn pose(&mut self, robot: u32, pose: Pose) {
        if self.record_decoded {
            let mut buf = [0u8; MAX_MESSAGE_LEN];
            match encode(&pose, &mut buf) {
                Ok(bytes) => {
                    let topic = self.swarm.pose(RobotId(robot));
                    self.recording.bytes(topic.name().as_str(), schema::POSE, bytes);
                    self.recorded += 1;
                }
                // A pose always fits one message; should it not, it is
                // still judged, and the failure shows in the log.
                Err(e) => tracing::warn!(robot, "cannot record a pose: {e}"),
            }
        }
        self.poses.push((robot, pose));
    }

    /// The bytes of one message as they crossed the bus on `topic`, before
    /// decoding (bus sources only).
    pub fn raw(&mut self, topic: &str, bytes: &[u8]) {
        self.recording.bytes(topic, schema::POSE, bytes);
        self.recorded += 1;
    }

    /// Something the source could not use, from `topic`: counted (and
    /// logged, thinned) if it is bad traffic, returned if it is fatal.
    pub fn bad(&mut self, topic: &str, error: BusError) -> Result<(), PoseError> {
        match self.traffic.absorb(WHO, topic, error) {
            None => Ok(()),
            Some(fatal) => Err(fatal.into()),
        }
    }

    /// Records what a source received that is not a pose — e.g. a mocap
    /// frame's datagram, so a replay can derive the poses again — on
    /// `bycoms/<swarm>/<leaf>` with `schema`. Not counted in
    /// [`PoseSink::recorded`] (which counts poses).
    pub fn record_source_bytes(&mut self, leaf: &str, schema: &str, bytes: &[u8]) {
        let topic = schema::Topics::new(self.swarm.as_str()).leaf(leaf);
        self.recording.bytes(&topic, schema, bytes);
    }

    /// Messages recorded through this sink (raw or decoded).
    pub fn recorded(&self) -> u64 {
        self.recorded
    }
}
