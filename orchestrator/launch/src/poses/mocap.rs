//! The NatNet source behind the launch's poses seam ([`PoseSource`]).
//!
//! Why an adapter and not the type itself: the seam's contract is
//! "hand every pose since the last drain, never wait, only opened robots,
//! tagged with the robot", while [`NatNetPoseSource`] (`bycoms_mocap`) is
//! usable on its own (placement, the benchmark). The replay source is
//! behind the seam in `replay::source`.
//!
//! Why here and not in `mocap/`: the seam is the launch's; motion capture
//! (client, pipeline, tracker, placement) sits below the launch and knows
//! nothing of it (ARCHITECTURE.md, "Crates of the orchestrator"). NatNet
//! also records what it used: the model
//! definitions once and every frame's datagram (`mocap/natnet_modeldef`,
//! `mocap/natnet`), besides the trusted poses the sink records on the
//! robots' pose topics — so a lab run replays from its poses and its
//! frames alike.

use super::{PoseError, PoseSink, PoseSource};
use bycoms_mocap::{ArenaPose, NatNetPoseSource, PoseTracker};
use bycoms_protocol::msg::Pose;
use bycoms_protocol::RobotId;
use bycoms_record::schema::{NATNET_FRAME, NATNET_MODELDEF};
use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

/// Recording leaf of the frames.
pub const FRAME_LEAF: &str = bycoms_record::schema::NATNET_FRAME_LEAF;
/// Recording leaf of the model definitions.
pub const MODELDEF_LEAF: &str = bycoms_record::schema::NATNET_MODELDEF_LEAF;

/// NatNet behind the seam.
pub struct NatNetPoses {
    source: NatNetPoseSource,
    opened: BTreeSet<u32>,
    carried: Carried,
    defs_recorded: bool,
}

impl NatNetPoses {
    /// Wraps a connected source.
    pub fn new(source: NatNetPoseSource) -> Self {
        Self { source, opened: BTreeSet::new(), carried: Carried::default(), defs_recorded: false }
    }

    /// The source.
    pub fn source_mut(&mut self) -> &mut NatNetPoseSource {
        &mut self.source
    }

    fn forget_carried(&mut self) {
        self.carried.forget_in(self.source.pipeline_mut().tracker_mut());
    }
}

/// Robots the operator is carrying to the start, with the last pose
/// handed over for each: their track is forgotten before every frame (or
/// sample), so no hand-speed move is taken for an identity swap, and
/// anchored at that last pose once the robot is placed. One rule for every
/// source with a tracker (NatNet, ROS 2).
#[derive(Debug, Default)]
pub struct Carried(BTreeMap<u32, Option<Pose>>);

impl Carried {
    /// Forgets every carried robot's track in `tracker` (before a frame).
    pub fn forget_in(&self, tracker: &mut PoseTracker) {
        for &id in self.0.keys() {
            tracker.forget(RobotId(id));
        }
    }

    /// A pose handed over: the last one of its robot, if carried.
    pub fn seen(&mut self, pose: &Pose) {
        if let Some(last) = self.0.get_mut(&pose.robot.0) {
            *last = Some(*pose);
        }
    }

    /// [`PoseSource::carried`]: robot `id` carried (`by_hand`) or placed,
    /// then anchored in `tracker` where it was last seen.
    pub fn set(&mut self, id: u32, by_hand: bool, tracker: &mut PoseTracker) {
        if by_hand {
            self.0.insert(id, None);
        } else if let Some(Some(p)) = self.0.remove(&id) {
            tracker.anchor(RobotId(id), ArenaPose { x: p.x, y: p.y, heading: p.heading }, p.time_us);
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
                self.carried.seen(pose);
                sink.pose(pose.robot.0, *pose);
            }
        }
        Ok(())
    }

    fn carried(&mut self, id: u32, by_hand: bool) {
        self.carried.set(id, by_hand, self.source.pipeline_mut().tracker_mut());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_mocap::testing::{lab, udp_source};
    use bycoms_natnet_server::{BodyPose, Faults};
    use bycoms_sim::Vec2;

    /// Drains `source` for `wait` (or until `until` holds for a handed pose)
    /// and returns the poses it handed over.
    fn drain_for(source: &mut NatNetPoses, wait: Duration, until: impl Fn(&Pose) -> bool) -> Vec<Pose> {
        use crate::recording::Recording;
        let swarm = bycoms_protocol::Swarm::new("carried").unwrap();
        let (mut recording, mut traffic) = (Recording::off(), bycoms_runtime::Traffic::default());
        let (mut got, began) = (Vec::new(), std::time::Instant::now());
        while began.elapsed() < wait {
            let mut batch = Vec::new();
            let mut sink = PoseSink::new(&mut recording, &mut traffic, &swarm, &mut batch, false);
            source.drain(&mut sink).unwrap();
            let done = batch.iter().any(|(_, p)| until(p));
            got.extend(batch.into_iter().map(|(_, p)| p));
            if done {
                break;
            }
            // Polled: a pose source is drained without waiting; it has no
            // event to block on.
            std::thread::sleep(Duration::from_millis(5));
        }
        got
    }

    /// Over real sockets: robot 2 stands tracked at (20, 0); the operator
    /// lifts it to the start (5, −3), far faster than a robot drives. Not
    /// carried, that move is an identity swap and rejected for good (the
    /// robot would never be seen at the start); carried
    /// (`PoseSource::carried`), it is handed over, and once placed the track
    /// starts from the start again: a jump away is rejected.
    #[test]
    fn a_robot_carried_to_the_start_is_seen_there_and_tracked_from_there() {
        use bycoms_natnet_server::NatNetServer;
        use std::net::Ipv4Addr;
        let server =
            NatNetServer::start_any_port(lab(Faults::default()), Ipv4Addr::LOCALHOST.into()).unwrap();
        let mut source = NatNetPoses::new(udp_source(&server));
        source.open_robot(2).unwrap();
        let (start, wait) = (Vec2::new(5.0, -3.0), Duration::from_secs(5));
        let near = |p: &Pose, at: Vec2| Vec2::new(p.x, p.y).distance(at) < 1e-3;
        let home = Vec2::new(20.0, 0.0);
        assert!(
            drain_for(&mut source, wait, |p| near(p, home)).iter().any(|p| near(p, home)),
            "tracked at home"
        );

        // Arena (x, y) = (10 X, −10 Z): lifted to X = 0.5, Z = 0.3 at once.
        server.set_pose(12, BodyPose::yawed([0.5, 0.0, 0.3], 0.0));
        let naive = drain_for(&mut source, Duration::from_millis(300), |_| false);
        assert!(!naive.iter().any(|p| near(p, start)), "not carried: the move is rejected as a swap");

        source.carried(2, true);
        let carried = drain_for(&mut source, wait, |p| near(p, start));
        assert!(carried.iter().any(|p| near(p, start)), "carried: seen at the start: {:?}", carried.last());

        source.carried(2, false);
        server.set_pose(12, BodyPose::yawed([2.0, 0.0, 0.0], 0.0));
        let after = drain_for(&mut source, Duration::from_millis(300), |_| false);
        assert!(
            !after.iter().any(|p| near(p, home)),
            "placed: a jump back home is rejected again: {:?}",
            after.iter().map(|p| (p.x, p.y, p.time_us)).collect::<Vec<_>>()
        );
    }
}

/// Moved with the NatNet source from `mocap/config.rs`: a launch config
/// is the launch's.
#[cfg(test)]
mod documented {
    use crate::LaunchConfig;

    /// The commented-out `[mocap.natnet]` example of `deploy/launch.toml`,
    /// uncommented, is a valid 3-robot lab config.
    #[test]
    fn the_documented_natnet_example_is_valid() {
        let file = include_str!("../../../../deploy/launch.toml");
        let start = file.find("# The NatNet source").expect("the example is documented");
        let end = file.find(super::super::ros2::DOCUMENTED).unwrap_or(file.len());
        let example: String = file[start..end]
            .lines()
            .skip(1)
            .map(|l| l.strip_prefix("# ").or_else(|| l.strip_prefix('#')).unwrap_or(l))
            .collect::<Vec<_>>()
            .join("\n");
        let text = format!("robots = 3\n[mocap]\nsource = \"natnet\"\n{example}");
        let cfg = LaunchConfig::parse(&text).unwrap_or_else(|e| panic!("{e:#}\n{text}"));
        cfg.validate().expect("valid");
        let natnet = cfg.mocap.natnet.expect("natnet section");
        assert_eq!(natnet.bodies.len(), 3);
        assert_eq!(natnet.arena.scale, 10.0);
    }
}
