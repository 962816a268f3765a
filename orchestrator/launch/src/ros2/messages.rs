//! A run's time and a pose as ROS 2 messages, in the one frame of every
//! pose and transform.
//!
//! Why a file of its own: the run's messages (`publish.rs`) and the bridge
//! (`ros2.rs`) both make them, and the bridge uses `publish.rs` (no file
//! cycles).

use bycoms_mocap::arena::{ArenaTransform, UpAxis};
use bycoms_protocol::msg::Pose;
use bycoms_ros2::msgs::{
    Header, Point, Pose as RosPose, PoseStamped, Quaternion, Time, Transform, TransformStamped, Vector3,
};

/// The frame every pose and transform is in.
pub const WORLD_FRAME: &str = "world";
/// The arena's (the terrain's) frame: `world` itself, published on
/// `/tf_static` so that `world` is in a late joiner's TF tree before any
/// robot moved.
pub const ARENA_FRAME: &str = "arena";
/// The motion-capture system's own frame, where the arena's transform
/// (`[mocap.*.arena]`) puts it.
pub const MOCAP_FRAME: &str = "mocap";

/// The static frames (`/tf_static`, stamped at time 0): `world` →
/// [`ARENA_FRAME`] (identity), and, when the poses come from motion capture
/// whose frame differs from the arena's (`arena` = the mocap → arena
/// transform) by a rigid motion (scale 1), `world` → [`MOCAP_FRAME`]. A
/// scaled arena has no TF transform (TF has no scale): none is published.
pub fn static_frames(arena: Option<&ArenaTransform>) -> Vec<TransformStamped> {
    let header = Header { stamp: Time::default(), frame_id: WORLD_FRAME.into() };
    let frame = |child: &str, translation: Point, rotation: Quaternion| TransformStamped {
        header: header.clone(),
        child_frame_id: child.into(),
        transform: Transform { translation: Vector3(translation), rotation },
    };
    let mut frames = vec![frame(ARENA_FRAME, Point::default(), Quaternion::default())];
    if let Some(t) = arena.filter(|t| t.scale == 1.0) {
        // world = M (p - origin): the mocap origin is at -M origin in world.
        let [ox, oy, oz] = t.origin;
        let (translation, rotation) = match t.up {
            UpAxis::Z => (Point { x: -ox, y: -oy, z: -oz }, Quaternion::default()),
            // M (x, y, z) = (x, -z, y): +90° about x.
            UpAxis::Y => {
                let half = std::f64::consts::FRAC_1_SQRT_2;
                (Point { x: -ox, y: oz, z: -oy }, Quaternion { x: half, y: 0.0, z: 0.0, w: half })
            }
        };
        if t.up != UpAxis::Z || t.origin != [0.0; 3] {
            frames.push(frame(MOCAP_FRAME, translation, rotation));
        }
    }
    frames
}

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

/// The `state` of a `RobotState` in [`WORLD_FRAME`], read from its CDR
/// bytes as the launch writes them: after the CDR header (4), the
/// header's stamp and frame (8 + 4 + 6, padded to 20) and the robot (4).
/// `RobotState` has no decoder; the tests of what is sent read it here.
#[cfg(test)]
pub(crate) fn robot_state_in(cdr: &[u8]) -> u8 {
    cdr[4 + 24]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn world_has_the_arena_and_a_rigid_mocap_frame_where_the_arena_transform_puts_it() {
        let children = |arena: Option<&ArenaTransform>| -> Vec<String> {
            static_frames(arena).into_iter().map(|f| f.child_frame_id).collect()
        };
        assert_eq!(children(None), ["arena"], "no motion capture: the arena is world");
        let same = ArenaTransform { up: UpAxis::Z, origin: [0.0; 3], scale: 1.0 };
        assert_eq!(children(Some(&same)), ["arena"], "a mocap frame that is world's");
        let scaled = ArenaTransform { scale: 10.0, ..ArenaTransform::default() };
        assert_eq!(children(Some(&scaled)), ["arena"], "TF has no scale");
        // Motive's Y up, arena origin (1, 2, 3) in mocap metres: a mocap
        // point p is M (p - origin) in world; its origin is -M origin.
        let motive = ArenaTransform { up: UpAxis::Y, origin: [1.0, 2.0, 3.0], scale: 1.0 };
        let frames = static_frames(Some(&motive));
        let mocap = &frames[1];
        assert_eq!((mocap.header.frame_id.as_str(), mocap.child_frame_id.as_str()), ("world", "mocap"));
        assert_eq!(mocap.transform.translation.0, Point { x: -1.0, y: 3.0, z: -2.0 });
        // The rotation takes mocap's up (y) to world's up (z) and mocap's z to world's -y.
        let q = mocap.transform.rotation;
        let rotate = |v: [f64; 3]| {
            let (x, w) = (q.x, q.w);
            // About x only: (vx, vy cos - vz sin, vy sin + vz cos), angle 2 atan2(x, w).
            let a = 2.0 * x.atan2(w);
            [v[0], v[1] * a.cos() - v[2] * a.sin(), v[1] * a.sin() + v[2] * a.cos()]
        };
        let near = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(a, b)| (a - b).abs() < 1e-12);
        assert!(
            near(rotate([0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]) && near(rotate([0.0, 0.0, 1.0]), [0.0, -1.0, 0.0])
        );
        let arena = motive.to_arena_f64([4.0, 2.0, 1.0], [0.0, 0.0, 0.0, 1.0]).expect("a pose");
        let world = rotate([4.0, 2.0, 1.0]);
        let t = mocap.transform.translation.0;
        assert!(near([world[0] + t.x, world[1] + t.y, 0.0], [arena.x, arena.y, 0.0]), "{arena:?}");
    }
}
