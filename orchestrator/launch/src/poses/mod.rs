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
pub mod merged;
pub mod mocap;
pub mod ros2;
mod seam;

pub use seam::{PoseBytes, PoseError, PoseSink, PoseSource};

use bycoms_protocol::Swarm;

/// The ROS 2 graph a source may read: its settings and session.
pub type Ros2Graph<'a> = (&'a super::ros2::Ros2Config, &'a zenoh::Session);

/// The pose source `mocap` asks for, for a launch of `robots` robots of
/// `swarm` on `bus`: the swarm's own bus, NatNet, or a ROS 2 driver's
/// topics in `ros2`'s graph; for a mixed swarm (`simulated` robots beside
/// real ones) seen by motion capture, that motion capture for the real
/// robots and the bus for the simulated ones ([`merged::MergedPoses`]). The
/// seam's one factory: a new kind of source enters here and nowhere else.
pub fn open(
    mocap: &bycoms_mocap::MocapConfig,
    robots: u32,
    bus: &super::transport::SharedBus,
    swarm: Swarm,
    ros2: Option<Ros2Graph<'_>>,
    simulated: &[u32],
) -> anyhow::Result<Box<dyn PoseSource>> {
    use anyhow::Context;
    let on_the_bus = || {
        bus::BusPoses::new(std::rc::Rc::clone(bus), swarm, robots).context("cannot read the poses on the bus")
    };
    Ok(match open_mocap(mocap, robots, ros2)? {
        None => Box::new(on_the_bus()?),
        Some(mocap) if simulated.is_empty() => mocap,
        Some(mocap) => Box::new(merged::MergedPoses::new(mocap, on_the_bus()?, simulated.to_vec())),
    })
}

/// The motion capture `mocap` asks for (none: the poses are on the bus).
fn open_mocap(
    mocap: &bycoms_mocap::MocapConfig,
    robots: u32,
    ros2: Option<Ros2Graph<'_>>,
) -> anyhow::Result<Option<Box<dyn PoseSource>>> {
    use anyhow::Context;
    if let (bycoms_mocap::MocapSource::Ros2, Some(config)) = (&mocap.source, &mocap.ros2) {
        let (settings, session) =
            ros2.context("mocap.source = \"ros2\" needs a ROS 2 session (ros2.router)")?;
        let source = ros2::Ros2Poses::open(&config.for_robots(robots), settings, session)?;
        return Ok(Some(Box::new(source)));
    }
    Ok(match (&mocap.source, &mocap.natnet) {
        (bycoms_mocap::MocapSource::Natnet, Some(natnet)) => Some(Box::new(mocap::NatNetPoses::new(
            bycoms_mocap::NatNetPoseSource::connect(&natnet.for_robots(robots))
                .context("cannot use the NatNet mocap")?,
        ))),
        _ => None,
    })
}
