//! A run's time and a pose as ROS 2 messages, in the one frame of every
//! pose and transform.
//!
//! Why a file of its own: the run's messages (`publish.rs`) and the bridge
//! (`ros2.rs`) both make them, and the bridge uses `publish.rs` (no file
//! cycles).

use bycoms_protocol::msg::Pose;
use bycoms_ros2::msgs::{
    Header, Point, Pose as RosPose, PoseStamped, Quaternion, Time, Transform, TransformStamped, Vector3,
};

/// The frame every pose and transform is in.
pub const WORLD_FRAME: &str = "world";

/// The run's time `time_us` as a ROS time.
pub fn run_time(time_us: u64) -> Time {
    Time::from_nanos(i64::try_from(time_us.saturating_mul(1_000)).unwrap_or(i64::MAX))
}

/// A pose as ROS 2 messages: the robot's `PoseStamped` and its transform.
pub fn ros_messages(pose: &Pose) -> (PoseStamped, TransformStamped) {
    let header = Header { stamp: run_time(pose.time_us), frame_id: WORLD_FRAME.into() };
    let orientation = Quaternion::from_yaw(pose.heading);
    let position = Point { x: pose.x, y: pose.y, z: 0.0 };
    let stamped = PoseStamped { header: header.clone(), pose: RosPose { position, orientation } };
    let transform = TransformStamped {
        header,
        child_frame_id: format!("robot_{}", pose.robot.0),
        transform: Transform { translation: Vector3(position), rotation: orientation },
    };
    (stamped, transform)
}
