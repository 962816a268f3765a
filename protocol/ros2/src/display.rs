//! The messages that show a run in RViz beyond poses and transforms: the
//! terrain as a `nav_msgs/msg/OccupancyGrid`, beacons and their ε circles as
//! a `visualization_msgs/msg/MarkerArray`, and real robots' health as a
//! `diagnostic_msgs/msg/DiagnosticArray`.
//!
//! Why every field of `Marker` is here although bycoms fills few: the type
//! hash covers the whole type (Jazzy's `Marker` has a texture, UV
//! coordinates and a mesh file), and the CDR must carry every field, empty
//! ones included. Field lists are Jazzy's and Kilted's; `tests/golden.rs`
//! pins hashes and bytes against PyPI `rosbags`.

use crate::cdr::CdrWriter;
use crate::msgs::{Header, Point, Pose, RosMessage, Time, Vector3, HEADER, POINT, POSE, TIME, VECTOR3};
use crate::types::{Field, Primitive as P, TypeDescription};

description!(
    DURATION,
    "builtin_interfaces/msg/Duration",
    [Field::prim("sec", P::Int32), Field::prim("nanosec", P::Uint32)]
);
description!(
    COLOR_RGBA,
    "std_msgs/msg/ColorRGBA",
    [
        Field::prim("r", P::Float32),
        Field::prim("g", P::Float32),
        Field::prim("b", P::Float32),
        Field::prim("a", P::Float32)
    ]
);
description!(
    COMPRESSED_IMAGE,
    "sensor_msgs/msg/CompressedImage",
    [
        Field::nested("header", &HEADER),
        Field::prim("format", P::String),
        Field::prim_sequence("data", P::Uint8)
    ]
);
description!(
    UV_COORDINATE,
    "visualization_msgs/msg/UVCoordinate",
    [Field::prim("u", P::Float32), Field::prim("v", P::Float32)]
);
description!(
    MESH_FILE,
    "visualization_msgs/msg/MeshFile",
    [Field::prim("filename", P::String), Field::prim_sequence("data", P::Uint8)]
);
description!(
    MARKER,
    "visualization_msgs/msg/Marker",
    [
        Field::nested("header", &HEADER),
        Field::prim("ns", P::String),
        Field::prim("id", P::Int32),
        Field::prim("type", P::Int32),
        Field::prim("action", P::Int32),
        Field::nested("pose", &POSE),
        Field::nested("scale", &VECTOR3),
        Field::nested("color", &COLOR_RGBA),
        Field::nested("lifetime", &DURATION),
        Field::prim("frame_locked", P::Bool),
        Field::sequence("points", &POINT),
        Field::sequence("colors", &COLOR_RGBA),
        Field::prim("texture_resource", P::String),
        Field::nested("texture", &COMPRESSED_IMAGE),
        Field::sequence("uv_coordinates", &UV_COORDINATE),
        Field::prim("text", P::String),
        Field::prim("mesh_resource", P::String),
        Field::nested("mesh_file", &MESH_FILE),
        Field::prim("mesh_use_embedded_materials", P::Bool)
    ]
);
description!(MARKER_ARRAY, "visualization_msgs/msg/MarkerArray", [Field::sequence("markers", &MARKER)]);
description!(
    MAP_META_DATA,
    "nav_msgs/msg/MapMetaData",
    [
        Field::nested("map_load_time", &TIME),
        Field::prim("resolution", P::Float32),
        Field::prim("width", P::Uint32),
        Field::prim("height", P::Uint32),
        Field::nested("origin", &POSE)
    ]
);
description!(
    OCCUPANCY_GRID,
    "nav_msgs/msg/OccupancyGrid",
    [
        Field::nested("header", &HEADER),
        Field::nested("info", &MAP_META_DATA),
        Field::prim_sequence("data", P::Int8)
    ]
);
description!(
    KEY_VALUE,
    "diagnostic_msgs/msg/KeyValue",
    [Field::prim("key", P::String), Field::prim("value", P::String)]
);
description!(
    DIAGNOSTIC_STATUS,
    "diagnostic_msgs/msg/DiagnosticStatus",
    [
        Field::prim("level", P::Byte),
        Field::prim("name", P::String),
        Field::prim("message", P::String),
        Field::prim("hardware_id", P::String),
        Field::sequence("values", &KEY_VALUE)
    ]
);
description!(
    DIAGNOSTIC_ARRAY,
    "diagnostic_msgs/msg/DiagnosticArray",
    [Field::nested("header", &HEADER), Field::sequence("status", &DIAGNOSTIC_STATUS)]
);

/// `std_msgs/msg/ColorRGBA`, each channel in `0..=1`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ColorRgba {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Opacity.
    pub a: f32,
}

impl RosMessage for ColorRgba {
    const DESCRIPTION: &'static TypeDescription = &COLOR_RGBA;
    fn write(&self, w: &mut CdrWriter) {
        for v in [self.r, self.g, self.b, self.a] {
            w.f32(v);
        }
    }
}

/// `visualization_msgs/msg/Marker`'s `type`s bycoms uses.
pub mod marker_type {
    /// `CYLINDER`: a beacon's ε disc (scale x, y: its diameter).
    pub const CYLINDER: i32 = 3;
    /// `SPHERE`: the beacon itself.
    pub const SPHERE: i32 = 2;
    /// `LINE_STRIP`: an ε circle's outline (its `points`).
    pub const LINE_STRIP: i32 = 4;
}

/// `visualization_msgs/msg/Marker`'s `action`s.
pub mod marker_action {
    /// `ADD` (also modifies).
    pub const ADD: i32 = 0;
    /// `DELETEALL`: clears every marker of the display.
    pub const DELETEALL: i32 = 3;
}

/// `visualization_msgs/msg/Marker`, with the fields bycoms sets; the
/// texture, UV coordinates, mesh and per-point colours go out empty and the
/// lifetime is 0 (forever).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Marker {
    /// When and in which frame.
    pub header: Header,
    /// Its namespace (with `id`, its identity in RViz).
    pub ns: String,
    /// Its id within `ns`.
    pub id: i32,
    /// [`marker_type`].
    pub kind: i32,
    /// [`marker_action`].
    pub action: i32,
    /// Where.
    pub pose: Pose,
    /// Its size.
    pub scale: Vector3,
    /// Its colour.
    pub color: ColorRgba,
    /// A line strip's points.
    pub points: Vec<Point>,
    /// The text of a text marker.
    pub text: String,
}

impl RosMessage for Marker {
    const DESCRIPTION: &'static TypeDescription = &MARKER;
    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        w.string(&self.ns);
        w.i32(self.id);
        w.i32(self.kind);
        w.i32(self.action);
        self.pose.write(w);
        self.scale.write(w);
        self.color.write(w);
        w.i32(0); // lifetime: 0 s 0 ns, forever
        w.u32(0);
        w.bool(false); // frame_locked
        w.count(self.points.len());
        for p in &self.points {
            p.write(w);
        }
        w.count(0); // colors
        w.string(""); // texture_resource
        Header::default().write(w); // texture: an empty CompressedImage
        w.string("");
        w.bytes(&[]);
        w.count(0); // uv_coordinates
        w.string(&self.text);
        w.string(""); // mesh_resource
        w.string(""); // mesh_file: an empty MeshFile
        w.bytes(&[]);
        w.bool(false); // mesh_use_embedded_materials
    }
}

/// `visualization_msgs/msg/MarkerArray`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MarkerArray {
    /// The markers, in order (a `DELETEALL` first clears the old ones).
    pub markers: Vec<Marker>,
}

impl RosMessage for MarkerArray {
    const DESCRIPTION: &'static TypeDescription = &MARKER_ARRAY;
    fn write(&self, w: &mut CdrWriter) {
        w.count(self.markers.len());
        for m in &self.markers {
            m.write(w);
        }
    }
}

/// `nav_msgs/msg/OccupancyGrid`: row-major cells from the origin's corner,
/// each `-1` (unknown) or `0..=100` (the probability it is occupied).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OccupancyGrid {
    /// When and in which frame.
    pub header: Header,
    /// `info.map_load_time`.
    pub map_load_time: Time,
    /// `info.resolution`: metres (frame units) per cell.
    pub resolution: f32,
    /// Cells per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `info.origin`: where cell (0, 0)'s corner is.
    pub origin: Pose,
    /// The cells, `width × height`, row by row from the origin.
    pub data: Vec<i8>,
}

impl OccupancyGrid {
    /// Decodes one CDR message (encapsulation header included); nothing may
    /// follow it (what a late joiner gets from the map is read back with it).
    pub fn from_cdr(message: &[u8]) -> Result<Self, crate::cdr::CdrError> {
        let mut r = crate::cdr::CdrReader::new(message)?;
        let header = Header::read(&mut r)?;
        let map_load_time = Time { sec: r.i32()?, nanosec: r.u32()? };
        let (resolution, width, height) = (r.f32()?, r.u32()?, r.u32()?);
        let position = Point { x: r.f64()?, y: r.f64()?, z: r.f64()? };
        let orientation = crate::msgs::Quaternion { x: r.f64()?, y: r.f64()?, z: r.f64()?, w: r.f64()? };
        let data = r.bytes()?.into_iter().map(|b| i8::from_le_bytes([b])).collect();
        r.finish()?;
        let origin = Pose { position, orientation };
        Ok(Self { header, map_load_time, resolution, width, height, origin, data })
    }
}

impl RosMessage for OccupancyGrid {
    const DESCRIPTION: &'static TypeDescription = &OCCUPANCY_GRID;
    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        self.map_load_time.write(w);
        w.f32(self.resolution);
        w.u32(self.width);
        w.u32(self.height);
        self.origin.write(w);
        let bytes: Vec<u8> = self.data.iter().map(|&c| c.to_le_bytes()[0]).collect();
        w.bytes(&bytes);
    }
}

/// `diagnostic_msgs/msg/DiagnosticStatus`'s levels.
pub mod level {
    /// `OK`
    pub const OK: u8 = 0;
    /// `WARN`
    pub const WARN: u8 = 1;
    /// `ERROR`
    pub const ERROR: u8 = 2;
    /// `STALE`
    pub const STALE: u8 = 3;
}

/// `diagnostic_msgs/msg/DiagnosticStatus`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DiagnosticStatus {
    /// [`level`].
    pub level: u8,
    /// What is reported on (`bycoms/robot_3`).
    pub name: String,
    /// A sentence.
    pub message: String,
    /// The hardware's id.
    pub hardware_id: String,
    /// The values, as key and text.
    pub values: Vec<(String, String)>,
}

impl RosMessage for DiagnosticStatus {
    const DESCRIPTION: &'static TypeDescription = &DIAGNOSTIC_STATUS;
    fn write(&self, w: &mut CdrWriter) {
        w.u8(self.level);
        w.string(&self.name);
        w.string(&self.message);
        w.string(&self.hardware_id);
        w.count(self.values.len());
        for (k, v) in &self.values {
            w.string(k);
            w.string(v);
        }
    }
}

/// `diagnostic_msgs/msg/DiagnosticArray`: what `/diagnostics` carries.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DiagnosticArray {
    /// When.
    pub header: Header,
    /// One status per thing reported on.
    pub status: Vec<DiagnosticStatus>,
}

impl RosMessage for DiagnosticArray {
    const DESCRIPTION: &'static TypeDescription = &DIAGNOSTIC_ARRAY;
    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        w.count(self.status.len());
        for s in &self.status {
            s.write(w);
        }
    }
}
