//! The ROS 2 messages bycoms publishes, each with its type description (for
//! its hash) and its CDR encoding; [`PoseStamped`] also decodes, for a pose
//! source fed by a ROS 2 motion-capture driver, and so do [`Twist`] and
//! [`TwistStamped`], a ground robot's velocity commands, so what was
//! commanded can be read back.
//!
//! `Twist` and `TwistStamped` are what a ROS 2 mobile base takes on
//! `cmd_vel`: `Twist` for most (TurtleBot's), `TwistStamped` for ROS 2
//! Jazzy's `diff_drive_controller` by default.
//!
//! The field lists are those of ROS 2 Jazzy and Kilted (unchanged since
//! Humble for these types); `tests/python/ros2_golden.py` checks hashes and
//! bytes against PyPI `rosbags`' Jazzy type store.

use crate::cdr::{CdrError, CdrReader, CdrWriter};
use crate::types::{Field, Primitive as P, TypeDescription};

/// A message: its description and its CDR.
pub trait RosMessage {
    /// Its type description (its full name is `DESCRIPTION.name`).
    const DESCRIPTION: &'static TypeDescription;

    /// Writes its fields in order.
    fn write(&self, w: &mut CdrWriter);

    /// The whole CDR message, encapsulation header included.
    fn to_cdr(&self) -> Vec<u8> {
        let mut w = CdrWriter::new();
        self.write(&mut w);
        w.finish()
    }
}

description!(
    TIME,
    "builtin_interfaces/msg/Time",
    [Field::prim("sec", P::Int32), Field::prim("nanosec", P::Uint32)]
);
description!(STRING, "std_msgs/msg/String", [Field::prim("data", P::String)]);
description!(
    HEADER,
    "std_msgs/msg/Header",
    [Field::nested("stamp", &TIME), Field::prim("frame_id", P::String)]
);
description!(
    POINT,
    "geometry_msgs/msg/Point",
    [Field::prim("x", P::Float64), Field::prim("y", P::Float64), Field::prim("z", P::Float64)]
);
description!(
    VECTOR3,
    "geometry_msgs/msg/Vector3",
    [Field::prim("x", P::Float64), Field::prim("y", P::Float64), Field::prim("z", P::Float64)]
);
description!(
    QUATERNION,
    "geometry_msgs/msg/Quaternion",
    [
        Field::prim("x", P::Float64),
        Field::prim("y", P::Float64),
        Field::prim("z", P::Float64),
        Field::prim("w", P::Float64)
    ]
);
description!(
    POSE,
    "geometry_msgs/msg/Pose",
    [Field::nested("position", &POINT), Field::nested("orientation", &QUATERNION)]
);
description!(
    POSE_STAMPED,
    "geometry_msgs/msg/PoseStamped",
    [Field::nested("header", &HEADER), Field::nested("pose", &POSE)]
);
description!(
    TWIST,
    "geometry_msgs/msg/Twist",
    [Field::nested("linear", &VECTOR3), Field::nested("angular", &VECTOR3)]
);
description!(
    TWIST_STAMPED,
    "geometry_msgs/msg/TwistStamped",
    [Field::nested("header", &HEADER), Field::nested("twist", &TWIST)]
);
description!(
    TRANSFORM,
    "geometry_msgs/msg/Transform",
    [Field::nested("translation", &VECTOR3), Field::nested("rotation", &QUATERNION)]
);
description!(
    TRANSFORM_STAMPED,
    "geometry_msgs/msg/TransformStamped",
    [
        Field::nested("header", &HEADER),
        Field::prim("child_frame_id", P::String),
        Field::nested("transform", &TRANSFORM)
    ]
);
description!(TF_MESSAGE, "tf2_msgs/msg/TFMessage", [Field::sequence("transforms", &TRANSFORM_STAMPED)]);
description!(
    PATH,
    "nav_msgs/msg/Path",
    [Field::nested("header", &HEADER), Field::sequence("poses", &POSE_STAMPED)]
);
description!(CLOCK, "rosgraph_msgs/msg/Clock", [Field::nested("clock", &TIME)]);
// A service's hash is that of a type with its request, its response and its
// event message (`service_msgs/msg/ServiceEventInfo` and the request and
// response each as a sequence of at most one). The event's `client_gid` is
// `char[16]` in its .msg, which rosidl maps to `uint8[16]` (type id 3):
// with `char` (13) the hash of rmw_zenoh's documented `AddTwoInts` example
// does not come out (rosbags 0.11.9's Jazzy store has `char`, hence its
// own `hash_rihs01` of this type is not ROS 2's).
description!(
    SERVICE_EVENT_INFO,
    "service_msgs/msg/ServiceEventInfo",
    [
        Field::prim("event_type", P::Uint8),
        Field::nested("stamp", &TIME),
        Field::array("client_gid", P::Uint8, 16),
        Field::prim("sequence_number", P::Int64)
    ]
);
description!(TRIGGER_REQUEST, "std_srvs/srv/Trigger_Request", []);
description!(
    TRIGGER_RESPONSE,
    "std_srvs/srv/Trigger_Response",
    [Field::prim("success", P::Bool), Field::prim("message", P::String)]
);
description!(
    TRIGGER_EVENT,
    "std_srvs/srv/Trigger_Event",
    [
        Field::nested("info", &SERVICE_EVENT_INFO),
        Field::bounded("request", &TRIGGER_REQUEST, 1),
        Field::bounded("response", &TRIGGER_RESPONSE, 1)
    ]
);
description!(
    TRIGGER,
    "std_srvs/srv/Trigger",
    [
        Field::nested("request_message", &TRIGGER_REQUEST),
        Field::nested("response_message", &TRIGGER_RESPONSE),
        Field::nested("event_message", &TRIGGER_EVENT)
    ]
);

/// `builtin_interfaces/msg/Time`: seconds and nanoseconds (`0..1e9`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Time {
    /// Whole seconds (ROS 2 keeps them in an `int32`).
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// The time `ns` nanoseconds after the epoch (floored to whole seconds;
    /// seconds past `i32` saturate).
    pub fn from_nanos(ns: i64) -> Self {
        let sec = ns.div_euclid(1_000_000_000);
        let nanosec = ns.rem_euclid(1_000_000_000) as u32;
        Self { sec: sec.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32, nanosec }
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Self { sec: r.i32()?, nanosec: r.u32()? })
    }
}

impl RosMessage for Time {
    const DESCRIPTION: &'static TypeDescription = &TIME;
    fn write(&self, w: &mut CdrWriter) {
        w.i32(self.sec);
        w.u32(self.nanosec);
    }
}

/// `std_msgs/msg/String`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct StdString {
    /// The text.
    pub data: String,
}

impl RosMessage for StdString {
    const DESCRIPTION: &'static TypeDescription = &STRING;
    fn write(&self, w: &mut CdrWriter) {
        w.string(&self.data);
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Header {
    /// When.
    pub stamp: Time,
    /// In which frame.
    pub frame_id: String,
}

impl Header {
    pub(crate) fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Self { stamp: Time::read(r)?, frame_id: r.string()? })
    }
}

impl RosMessage for Header {
    const DESCRIPTION: &'static TypeDescription = &HEADER;
    fn write(&self, w: &mut CdrWriter) {
        self.stamp.write(w);
        w.string(&self.frame_id);
    }
}

/// `geometry_msgs/msg/Point` (`Vector3` has the same fields and layout).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Point {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// z, metres.
    pub z: f64,
}

impl Point {
    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Self { x: r.f64()?, y: r.f64()?, z: r.f64()? })
    }
    fn put(&self, w: &mut CdrWriter) {
        w.f64(self.x);
        w.f64(self.y);
        w.f64(self.z);
    }
}

impl RosMessage for Point {
    const DESCRIPTION: &'static TypeDescription = &POINT;
    fn write(&self, w: &mut CdrWriter) {
        self.put(w);
    }
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Vector3(pub Point);

impl RosMessage for Vector3 {
    const DESCRIPTION: &'static TypeDescription = &VECTOR3;
    fn write(&self, w: &mut CdrWriter) {
        self.0.put(w);
    }
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quaternion {
    /// x
    pub x: f64,
    /// y
    pub y: f64,
    /// z
    pub z: f64,
    /// w
    pub w: f64,
}

impl Default for Quaternion {
    /// The identity, as ROS 2's default (`w = 1`).
    fn default() -> Self {
        Self { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }
    }
}

impl Quaternion {
    /// A rotation of `yaw` radians about z.
    pub fn from_yaw(yaw: f64) -> Self {
        let (s, c) = (yaw / 2.0).sin_cos();
        Self { x: 0.0, y: 0.0, z: s, w: c }
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Self { x: r.f64()?, y: r.f64()?, z: r.f64()?, w: r.f64()? })
    }
}

impl RosMessage for Quaternion {
    const DESCRIPTION: &'static TypeDescription = &QUATERNION;
    fn write(&self, w: &mut CdrWriter) {
        for v in [self.x, self.y, self.z, self.w] {
            w.f64(v);
        }
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pose {
    /// Where.
    pub position: Point,
    /// Which way.
    pub orientation: Quaternion,
}

impl RosMessage for Pose {
    const DESCRIPTION: &'static TypeDescription = &POSE;
    fn write(&self, w: &mut CdrWriter) {
        self.position.write(w);
        self.orientation.write(w);
    }
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PoseStamped {
    /// When and in which frame.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

impl PoseStamped {
    /// Decodes one CDR message (encapsulation header included), as a ROS 2
    /// motion-capture driver publishes it; nothing may follow it.
    pub fn from_cdr(message: &[u8]) -> Result<Self, CdrError> {
        whole(message, Self::read)
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        let header = Header::read(r)?;
        let pose = Pose { position: Point::read(r)?, orientation: Quaternion::read(r)? };
        Ok(Self { header, pose })
    }
}

impl RosMessage for PoseStamped {
    const DESCRIPTION: &'static TypeDescription = &POSE_STAMPED;
    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        self.pose.write(w);
    }
}

/// `geometry_msgs/msg/Twist`: a velocity in free space, linear (m/s) and
/// angular (rad/s), in the frame of whoever takes it (a mobile base: its
/// own, x forward, y left, z up as ROS REP-103 has it).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Twist {
    /// Linear velocity, m/s.
    pub linear: Vector3,
    /// Angular velocity, rad/s (right-handed: +z turns counter-clockwise
    /// seen from above).
    pub angular: Vector3,
}

impl Twist {
    /// A ground robot's command: `v` m/s forward (`linear.x`) and `omega`
    /// rad/s about z (`angular.z`, counter-clockwise positive, REP-103);
    /// every other component zero.
    pub fn planar(v: f64, omega: f64) -> Self {
        Self {
            linear: Vector3(Point { x: v, ..Point::default() }),
            angular: Vector3(Point { z: omega, ..Point::default() }),
        }
    }

    /// Decodes one CDR message (encapsulation header included); nothing
    /// may follow it.
    pub fn from_cdr(message: &[u8]) -> Result<Self, CdrError> {
        whole(message, Self::read)
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Self { linear: Vector3(Point::read(r)?), angular: Vector3(Point::read(r)?) })
    }
}

impl RosMessage for Twist {
    const DESCRIPTION: &'static TypeDescription = &TWIST;
    fn write(&self, w: &mut CdrWriter) {
        self.linear.write(w);
        self.angular.write(w);
    }
}

/// `geometry_msgs/msg/TwistStamped`: a [`Twist`] with when and in which
/// frame (what ROS 2 Jazzy's `diff_drive_controller` takes by default).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TwistStamped {
    /// When and in which frame.
    pub header: Header,
    /// The velocity.
    pub twist: Twist,
}

impl TwistStamped {
    /// Decodes one CDR message (encapsulation header included); nothing
    /// may follow it.
    pub fn from_cdr(message: &[u8]) -> Result<Self, CdrError> {
        whole(message, |r| Ok(Self { header: Header::read(r)?, twist: Twist::read(r)? }))
    }
}

impl RosMessage for TwistStamped {
    const DESCRIPTION: &'static TypeDescription = &TWIST_STAMPED;
    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        self.twist.write(w);
    }
}

/// One whole CDR message read by `read`: the encapsulation header first,
/// nothing after.
fn whole<T>(
    message: &[u8],
    read: impl FnOnce(&mut CdrReader<'_>) -> Result<T, CdrError>,
) -> Result<T, CdrError> {
    let mut r = CdrReader::new(message)?;
    let out = read(&mut r)?;
    r.finish()?;
    Ok(out)
}

/// `geometry_msgs/msg/Transform`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Transform {
    /// The translation.
    pub translation: Vector3,
    /// The rotation.
    pub rotation: Quaternion,
}

impl RosMessage for Transform {
    const DESCRIPTION: &'static TypeDescription = &TRANSFORM;
    fn write(&self, w: &mut CdrWriter) {
        self.translation.write(w);
        self.rotation.write(w);
    }
}

/// `geometry_msgs/msg/TransformStamped`: `header.frame_id` → `child_frame_id`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TransformStamped {
    /// When, and the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child's pose in the parent frame.
    pub transform: Transform,
}

impl RosMessage for TransformStamped {
    const DESCRIPTION: &'static TypeDescription = &TRANSFORM_STAMPED;
    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        w.string(&self.child_frame_id);
        self.transform.write(w);
    }
}

/// `tf2_msgs/msg/TFMessage`: what `/tf` carries.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

impl TfMessage {
    /// Decodes one CDR message (encapsulation header included); nothing may
    /// follow it (what a late joiner gets from `/tf_static` is read back
    /// with it).
    pub fn from_cdr(message: &[u8]) -> Result<Self, CdrError> {
        whole(message, |r| {
            let n = r.u32()?;
            let mut transforms = Vec::new();
            for _ in 0..n {
                let header = Header::read(r)?;
                let child_frame_id = r.string()?;
                let translation = Vector3(Point::read(r)?);
                let transform = Transform { translation, rotation: Quaternion::read(r)? };
                transforms.push(TransformStamped { header, child_frame_id, transform });
            }
            Ok(Self { transforms })
        })
    }
}

impl RosMessage for TfMessage {
    const DESCRIPTION: &'static TypeDescription = &TF_MESSAGE;
    fn write(&self, w: &mut CdrWriter) {
        w.count(self.transforms.len());
        for t in &self.transforms {
            t.write(w);
        }
    }
}

/// `nav_msgs/msg/Path`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Path {
    /// When and in which frame.
    pub header: Header,
    /// The poses along the path.
    pub poses: Vec<PoseStamped>,
}

impl RosMessage for Path {
    const DESCRIPTION: &'static TypeDescription = &PATH;
    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        w.count(self.poses.len());
        for p in &self.poses {
            p.write(w);
        }
    }
}

/// `rosgraph_msgs/msg/Clock`: what `/clock` carries for nodes on sim time.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Clock {
    /// The simulated time.
    pub clock: Time,
}

impl RosMessage for Clock {
    const DESCRIPTION: &'static TypeDescription = &CLOCK;
    fn write(&self, w: &mut CdrWriter) {
        self.clock.write(w);
    }
}

/// `std_srvs/srv/Trigger`'s request: no fields (on the wire, the one
/// `uint8` rosidl gives an empty message).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TriggerRequest;

impl RosMessage for TriggerRequest {
    const DESCRIPTION: &'static TypeDescription = &TRIGGER_REQUEST;
    fn write(&self, w: &mut CdrWriter) {
        w.u8(0);
    }
}

/// `std_srvs/srv/Trigger`'s response.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TriggerResponse {
    /// Whether the service did it.
    pub success: bool,
    /// What it says about it.
    pub message: String,
}

impl RosMessage for TriggerResponse {
    const DESCRIPTION: &'static TypeDescription = &TRIGGER_RESPONSE;
    fn write(&self, w: &mut CdrWriter) {
        w.bool(self.success);
        w.string(&self.message);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What a late joiner gets from `/tf_static` and the map reads back as it was written.
    #[test]
    fn a_tf_message_and_an_occupancy_grid_decode_back() {
        let header = Header { stamp: Time { sec: 3, nanosec: 7 }, frame_id: "world".into() };
        let rotation = Quaternion { x: 0.5, y: -0.5, z: 0.5, w: 0.5 };
        let translation = Vector3(Point { x: 1.0, y: -2.0, z: 3.5 });
        let tf = TfMessage {
            transforms: vec![
                TransformStamped {
                    header: header.clone(),
                    child_frame_id: "arena".into(),
                    ..Default::default()
                },
                TransformStamped {
                    header: header.clone(),
                    child_frame_id: "mocap".into(),
                    transform: Transform { translation, rotation },
                },
            ],
        };
        assert_eq!(TfMessage::from_cdr(&tf.to_cdr()), Ok(tf.clone()));
        let grid = crate::display::OccupancyGrid {
            header,
            resolution: 0.5,
            width: 3,
            height: 2,
            data: vec![0, 100, -1, 0, 0, 100],
            ..Default::default()
        };
        assert_eq!(crate::display::OccupancyGrid::from_cdr(&grid.to_cdr()), Ok(grid.clone()));
        let mut longer = tf.to_cdr();
        longer.push(0);
        assert!(TfMessage::from_cdr(&longer).is_err(), "nothing may follow");
    }

    #[test]
    fn time_from_nanos_floors_and_keeps_nanoseconds_in_range() {
        assert_eq!(Time::from_nanos(1_500_000_000), Time { sec: 1, nanosec: 500_000_000 });
        assert_eq!(Time::from_nanos(-1), Time { sec: -1, nanosec: 999_999_999 });
        assert_eq!(Time::from_nanos(i64::MAX).sec, i32::MAX);
    }

    #[test]
    fn a_pose_stamped_decodes_to_what_was_encoded_and_refuses_a_cut() {
        let msg = PoseStamped {
            header: Header { stamp: Time { sec: 3, nanosec: 4 }, frame_id: "mocap".into() },
            pose: Pose {
                position: Point { x: 1.0, y: -2.0, z: 0.5 },
                orientation: Quaternion::from_yaw(0.3),
            },
        };
        let bytes = msg.to_cdr();
        assert_eq!(PoseStamped::from_cdr(&bytes), Ok(msg));
        for cut in 0..bytes.len() {
            assert!(PoseStamped::from_cdr(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert_eq!(PoseStamped::from_cdr(&longer), Err(CdrError::Trailing(1)));
    }

    #[test]
    fn a_planar_twist_is_forward_speed_and_counter_clockwise_turn() {
        let t = Twist::planar(0.25, -0.5);
        assert_eq!((t.linear.0.x, t.linear.0.y, t.linear.0.z), (0.25, 0.0, 0.0));
        assert_eq!((t.angular.0.x, t.angular.0.y, t.angular.0.z), (0.0, 0.0, -0.5));
    }

    #[test]
    fn twists_decode_to_what_was_encoded_and_refuse_a_cut() {
        let twist = Twist::planar(0.2, 1.5);
        let stamped = TwistStamped {
            header: Header { stamp: Time { sec: 5, nanosec: 6 }, frame_id: "base_link".into() },
            twist: Twist { linear: Vector3(Point { x: 0.1, y: -0.2, z: 0.3 }), ..twist },
        };
        let (plain, with_header) = (twist.to_cdr(), stamped.to_cdr());
        assert_eq!(plain.len(), 4 + 6 * 8, "the header, then six float64");
        assert_eq!(Twist::from_cdr(&plain), Ok(twist));
        assert_eq!(TwistStamped::from_cdr(&with_header), Ok(stamped));
        for cut in 0..plain.len() {
            assert!(Twist::from_cdr(&plain[..cut]).is_err(), "cut at {cut}");
        }
        for cut in 0..with_header.len() {
            assert!(TwistStamped::from_cdr(&with_header[..cut]).is_err(), "cut at {cut}");
        }
        assert_eq!(Twist::from_cdr(&[plain.as_slice(), &[0]].concat()), Err(CdrError::Trailing(1)));
        assert!(TwistStamped::from_cdr(&plain).is_err(), "a Twist is not a TwistStamped");
    }
}
