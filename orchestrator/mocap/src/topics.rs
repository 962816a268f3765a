//! ROS 2 motion capture → the robots' trusted arena poses (sans-IO).
//!
//! Why beside the NatNet pipeline and not a second tracker: a ROS 2 driver
//! (vrpn_mocap, motion_capture_tracking, mocap4r2, natnet_ros2) publishes
//! one `geometry_msgs/msg/PoseStamped` per body and sample, where Motive
//! sends one frame of every body; both fail the same ways (an occluded
//! body, an identity swap), so each sample goes through the same
//! [`PoseTracker`] and the same words ([`super::pipeline::report`], the
//! body named by its topic). A sample is a frame in which only its robot
//! is seen: the others are simply absent (held, reported lost in time).
//!
//! Units and time: positions are metres in the driver's frame (REP-103:
//! Z up), mapped into the arena by the same [`ArenaTransform`] as NatNet
//! (origin, up axis, arena units per metre); the heading is the yaw of the
//! orientation. A pose's time is its `header.stamp` (the driver's clock:
//! its node's ROS time, or the mocap system's) less the first stamp the
//! source saw, so all robots share one clock; its step counts the robot's
//! samples, from 1 (increasing, as the launch's plausibility check asks).

use super::arena::ArenaTransform;
use super::config::Ros2MocapConfig;
use super::pipeline::report;
use super::tracker::{PoseTracker, Sighting};
use bycoms_protocol::msg::Pose;
use bycoms_protocol::RobotId;
use bycoms_ros2::msgs::PoseStamped;
use std::collections::BTreeMap;

/// Axes and tracker, applied sample by sample.
#[derive(Clone, Debug)]
pub struct TopicPipeline {
    transform: ArenaTransform,
    names: BTreeMap<RobotId, String>,
    tracker: PoseTracker,
    first_stamp_ns: Option<i128>,
    steps: BTreeMap<RobotId, u64>,
}

impl TopicPipeline {
    /// A pipeline for the topics of `config`.
    pub fn new(config: &Ros2MocapConfig) -> Self {
        let names = config.topics.iter().map(|(topic, robot)| (*robot, topic.clone())).collect();
        let tracker = PoseTracker::new(config.tracker, config.topics.values().copied());
        Self { transform: config.arena, names, tracker, first_stamp_ns: None, steps: BTreeMap::new() }
    }

    /// The tracker (to forget a carried robot, anchor a placed one).
    pub fn tracker_mut(&mut self) -> &mut PoseTracker {
        &mut self.tracker
    }

    /// The topic `robot` is tracked by ("?" if none).
    pub fn topic(&self, robot: RobotId) -> &str {
        self.names.get(&robot).map_or("?", String::as_str)
    }

    /// One sample of `robot`'s topic: its trusted pose, or `None` (an
    /// unusable orientation, a rejected jump); lost bodies and rejected
    /// jumps are reported by name.
    pub fn on_sample(&mut self, robot: RobotId, msg: &PoseStamped) -> Option<Pose> {
        let stamp = i128::from(msg.header.stamp.sec) * 1_000_000_000 + i128::from(msg.header.stamp.nanosec);
        let t0 = *self.first_stamp_ns.get_or_insert(stamp);
        let time_us = u64::try_from((stamp - t0).max(0) / 1000).unwrap_or(u64::MAX);
        let step = self.steps.entry(robot).or_default();
        *step += 1;
        let (p, q) = (msg.pose.position, msg.pose.orientation);
        let sighting = match self.transform.to_arena_f64([p.x, p.y, p.z], [q.x, q.y, q.z, q.w]) {
            Some(pose) => Sighting::Tracked(pose),
            None => Sighting::Untracked,
        };
        let trusted = self.tracker.frame(*step, time_us, &[(robot, sighting)]);
        for event in self.tracker.drain_events() {
            report(&event, self.topic(event.robot()));
        }
        trusted.into_iter().find(|pose| pose.robot == robot)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{TrackerConfig, UpAxis};
    use bycoms_ros2::msgs::{Header, Point, Pose as RosPose, Quaternion, Time};

    fn config() -> Ros2MocapConfig {
        Ros2MocapConfig {
            topics: [("/vrpn_mocap/robot1/pose".to_string(), RobotId(1)), ("/r2".to_string(), RobotId(2))]
                .into(),
            arena: ArenaTransform { up: UpAxis::Z, origin: [1.0, 0.0, 0.0], scale: 10.0 },
            tracker: TrackerConfig { max_speed: 1.0, jump_slack: 0.1, lost_after_us: 500_000 },
            graph_timeout: 5.0,
        }
    }

    fn sample(ms: i64, x: f64, y: f64, yaw: f64) -> PoseStamped {
        let stamp = Time::from_nanos(1_700_000_000_000_000_000 + ms * 1_000_000);
        PoseStamped {
            header: Header { stamp, frame_id: "world".into() },
            pose: RosPose { position: Point { x, y, z: 0.3 }, orientation: Quaternion::from_yaw(yaw) },
        }
    }

    /// Z up: (x, y) metres → arena units, yaw → heading, the stamp less
    /// the first one → time, steps counted per robot.
    #[test]
    fn a_sample_becomes_an_arena_pose_on_the_drivers_clock() {
        let mut p = TopicPipeline::new(&config());
        let first = p.on_sample(RobotId(1), &sample(0, 1.5, 2.0, 0.5)).expect("first sighting");
        assert!((first.x - 5.0).abs() < 1e-9 && (first.y - 20.0).abs() < 1e-9, "{first:?}");
        assert!((first.heading - 0.5).abs() < 1e-9, "{first:?}");
        assert_eq!((first.robot, first.step, first.time_us), (RobotId(1), 1, 0));
        // 0.2 arena units (2 cm) in 0.25 s: within 1 unit/s and 0.1 of slack.
        let next = p.on_sample(RobotId(1), &sample(250, 1.52, 2.0, 0.5)).expect("plausible");
        assert_eq!((next.step, next.time_us), (2, 250_000));
        let other = p.on_sample(RobotId(2), &sample(300, 0.0, 0.0, 0.0)).expect("robot 2's first");
        assert_eq!((other.robot, other.step, other.time_us), (RobotId(2), 1, 300_000));
        assert_eq!(p.topic(RobotId(1)), "/vrpn_mocap/robot1/pose");
    }

    /// The NatNet tracker's safety, sample by sample: a jump farther than
    /// the robot drives is rejected (an identity swap), a zero quaternion
    /// (no orientation: an untracked body) yields no pose, and a robot
    /// carried (forgotten) is trusted anywhere again.
    #[test]
    fn swaps_are_rejected_and_occlusions_yield_no_pose() {
        let mut p = TopicPipeline::new(&config());
        assert!(p.on_sample(RobotId(1), &sample(0, 1.0, 1.0, 0.0)).is_some());
        assert_eq!(p.on_sample(RobotId(1), &sample(100, 3.0, 1.0, 0.0)), None, "2 m in 0.1 s: a swap");
        let mut untracked = sample(200, 1.0, 1.0, 0.0);
        untracked.pose.orientation = Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 0.0 };
        assert_eq!(p.on_sample(RobotId(1), &untracked), None, "no orientation: untracked");
        assert!(p.on_sample(RobotId(1), &sample(300, 1.02, 1.0, 0.0)).is_some(), "tracked on from the last");
        p.tracker_mut().forget(RobotId(1));
        assert!(p.on_sample(RobotId(1), &sample(400, 3.0, 1.0, 0.0)).is_some(), "carried: anywhere");
    }
}
