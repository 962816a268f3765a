//! `NAT_MODELDEF`: the model definitions, where rigid-body *names* live.
//!
//! Why it matters here: frames carry only numeric ids; the operator names
//! robots' rigid bodies in Motive ("robot1", …), and the orchestrator maps
//! names to robot ids. Kinds 0 (marker set), 1 (rigid body), 2 (skeleton),
//! 5 (camera) and 6 (asset) are decoded; others (force plates, devices) are
//! kept as raw bytes, which needs the 4.1 per-description size to skip them.

use super::wire::{read_many, Reader, Writer};
use super::{Error, Version};

const KIND_MARKER_SET: i32 = 0;
const KIND_RIGID_BODY: i32 = 1;
const KIND_SKELETON: i32 = 2;
const KIND_CAMERA: i32 = 5;
const KIND_ASSET: i32 = 6;

/// Smallest rigid-body description: empty name (its NUL), id, parent id,
/// offset, marker count.
const RIGID_BODY_DESCRIPTION_MIN_LEN: usize = 1 + 4 + 4 + 12 + 4;
/// Smallest asset marker description: empty name (its NUL), id, position,
/// size, params. (Once 27, more than a real one needs: a 4.0 packet whose
/// last description is an asset with short marker names was refused after
/// its own encoding, the fuzz finding of `fuzz/README.md`.)
const ASSET_MARKER_MIN_LEN: usize = 1 + 4 + 12 + 4 + 2;
/// Smallest rigid-body marker: offset, active label, empty name's NUL.
const RIGID_BODY_MARKER_MIN_LEN: usize = 12 + 4 + 1;

/// A marker set's name and its markers' names.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkerSetDescription {
    /// Marker set name.
    pub name: String,
    /// Names of its markers.
    pub marker_names: Vec<String>,
}

/// One marker of a rigid body's definition.
#[derive(Clone, Debug, PartialEq)]
pub struct RigidBodyMarkerDescription {
    /// Offset from the body's pivot, metres.
    pub offset: [f32; 3],
    /// Active-marker label (0 for passive markers).
    pub active_label: i32,
    /// Marker name.
    pub name: String,
}

/// A rigid body's definition: its name and streaming id.
#[derive(Clone, Debug, PartialEq)]
pub struct RigidBodyDescription {
    /// Name given in Motive.
    pub name: String,
    /// Streaming id, as in frames.
    pub id: i32,
    /// Parent id (-1: none).
    pub parent_id: i32,
    /// Offset from the parent, metres.
    pub offset: [f32; 3],
    /// Its markers (five per robot in the paper's lab).
    pub markers: Vec<RigidBodyMarkerDescription>,
}

/// A skeleton's definition.
#[derive(Clone, Debug, PartialEq)]
pub struct SkeletonDescription {
    /// Name.
    pub name: String,
    /// Id.
    pub id: i32,
    /// Bones.
    pub rigid_bodies: Vec<RigidBodyDescription>,
}

/// A camera's definition.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDescription {
    /// Name.
    pub name: String,
    /// Position, metres.
    pub position: [f32; 3],
    /// Orientation qx, qy, qz, qw.
    pub orientation: [f32; 4],
}

/// A marker of an asset's definition.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkerDescription {
    /// Name.
    pub name: String,
    /// Id.
    pub id: i32,
    /// Initial position, metres.
    pub position: [f32; 3],
    /// Size, metres.
    pub size: f32,
    /// Flags.
    pub params: i16,
}

/// An asset's definition (4.1+).
#[derive(Clone, Debug, PartialEq)]
pub struct AssetDescription {
    /// Name.
    pub name: String,
    /// Asset type.
    pub asset_type: i32,
    /// Id.
    pub id: i32,
    /// Its rigid bodies.
    pub rigid_bodies: Vec<RigidBodyDescription>,
    /// Its markers.
    pub markers: Vec<MarkerDescription>,
}

/// One data description.
#[derive(Clone, Debug, PartialEq)]
pub enum DataDescription {
    /// Kind 0.
    MarkerSet(MarkerSetDescription),
    /// Kind 1.
    RigidBody(RigidBodyDescription),
    /// Kind 2.
    Skeleton(SkeletonDescription),
    /// Kind 5.
    Camera(CameraDescription),
    /// Kind 6.
    Asset(AssetDescription),
    /// Any other kind (force plate 3, device 4, …), undecoded (4.1+ only).
    Other {
        /// The kind number.
        kind: i32,
        /// The description's bytes.
        bytes: Vec<u8>,
    },
}

/// `NAT_MODELDEF`'s payload.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ModelDefinitions {
    /// The descriptions, in the server's order.
    pub descriptions: Vec<DataDescription>,
}

impl ModelDefinitions {
    /// The rigid-body definitions (top-level ones), in order.
    pub fn rigid_bodies(&self) -> impl Iterator<Item = &RigidBodyDescription> {
        self.descriptions.iter().filter_map(|d| match d {
            DataDescription::RigidBody(rb) => Some(rb),
            _ => None,
        })
    }

    pub(crate) fn read(r: &mut Reader<'_>, v: Version) -> Result<Self, Error> {
        v.check()?;
        let n = r.count("data description", 4)?;
        let mut descriptions = Vec::with_capacity(n);
        for _ in 0..n {
            let kind = r.i32("description kind")?;
            let size = if v.has_sizes() { Some(r.count("description byte", 1)?) } else { None };
            let d = match kind {
                KIND_MARKER_SET => {
                    let name = r.cstr("marker set name")?;
                    let m = r.count("marker name", 1)?;
                    let marker_names = read_many(r, m, |r| r.cstr("marker name"))?;
                    DataDescription::MarkerSet(MarkerSetDescription { name, marker_names })
                }
                KIND_RIGID_BODY => DataDescription::RigidBody(read_rigid_body(r)?),
                KIND_SKELETON => {
                    let name = r.cstr("skeleton name")?;
                    let id = r.i32("skeleton id")?;
                    let b = r.count("skeleton bone", RIGID_BODY_DESCRIPTION_MIN_LEN)?;
                    let rigid_bodies = read_many(r, b, read_rigid_body)?;
                    DataDescription::Skeleton(SkeletonDescription { name, id, rigid_bodies })
                }
                KIND_CAMERA => DataDescription::Camera(CameraDescription {
                    name: r.cstr("camera name")?,
                    position: r.vec3("camera position")?,
                    orientation: r.quat("camera orientation")?,
                }),
                KIND_ASSET => {
                    let name = r.cstr("asset name")?;
                    let asset_type = r.i32("asset type")?;
                    let id = r.i32("asset id")?;
                    let b = r.count("asset rigid body", RIGID_BODY_DESCRIPTION_MIN_LEN)?;
                    let rigid_bodies = read_many(r, b, read_rigid_body)?;
                    let m = r.count("asset marker", ASSET_MARKER_MIN_LEN)?;
                    let markers = read_many(r, m, |r| {
                        Ok(MarkerDescription {
                            name: r.cstr("marker name")?,
                            id: r.i32("marker id")?,
                            position: r.vec3("marker position")?,
                            size: r.f32("marker size")?,
                            params: r.i16("marker params")?,
                        })
                    })?;
                    DataDescription::Asset(AssetDescription { name, asset_type, id, rigid_bodies, markers })
                }
                other => match size {
                    Some(len) => DataDescription::Other {
                        kind: other,
                        bytes: r.take(len, "description bytes")?.to_vec(),
                    },
                    None => return Err(Error::UnsupportedDescription(other)),
                },
            };
            descriptions.push(d);
        }
        Ok(Self { descriptions })
    }

    pub(crate) fn write(&self, w: &mut Writer, v: Version) -> Result<(), Error> {
        v.check()?;
        w.count(self.descriptions.len(), "data descriptions")?;
        for d in &self.descriptions {
            let kind = match d {
                DataDescription::MarkerSet(_) => KIND_MARKER_SET,
                DataDescription::RigidBody(_) => KIND_RIGID_BODY,
                DataDescription::Skeleton(_) => KIND_SKELETON,
                DataDescription::Camera(_) => KIND_CAMERA,
                DataDescription::Asset(_) => KIND_ASSET,
                DataDescription::Other { kind, .. } => *kind,
            };
            w.i32(kind);
            let at = v.has_sizes().then(|| w.begin_size());
            match d {
                DataDescription::MarkerSet(m) => {
                    w.cstr(&m.name, "marker set name")?;
                    w.count(m.marker_names.len(), "marker names")?;
                    for name in &m.marker_names {
                        w.cstr(name, "marker name")?;
                    }
                }
                DataDescription::RigidBody(rb) => write_rigid_body(w, rb)?,
                DataDescription::Skeleton(s) => {
                    w.cstr(&s.name, "skeleton name")?;
                    w.i32(s.id);
                    w.count(s.rigid_bodies.len(), "skeleton bones")?;
                    for rb in &s.rigid_bodies {
                        write_rigid_body(w, rb)?;
                    }
                }
                DataDescription::Camera(c) => {
                    w.cstr(&c.name, "camera name")?;
                    w.floats(&c.position);
                    w.floats(&c.orientation);
                }
                DataDescription::Asset(a) => {
                    w.cstr(&a.name, "asset name")?;
                    w.i32(a.asset_type);
                    w.i32(a.id);
                    w.count(a.rigid_bodies.len(), "asset rigid bodies")?;
                    for rb in &a.rigid_bodies {
                        write_rigid_body(w, rb)?;
                    }
                    w.count(a.markers.len(), "asset markers")?;
                    for m in &a.markers {
                        w.cstr(&m.name, "marker name")?;
                        w.i32(m.id);
                        w.floats(&m.position);
                        w.f32(m.size);
                        w.i16(m.params);
                    }
                }
                DataDescription::Other { kind, bytes } => {
                    if at.is_none() || matches!(*kind, 0..=2 | 5 | 6) {
                        return Err(Error::UnsupportedDescription(*kind));
                    }
                    w.buf.extend_from_slice(bytes);
                }
            }
            if let Some(at) = at {
                w.end_size(at, "data description")?;
            }
        }
        Ok(())
    }
}

/// Name, id, parent, offset, then the markers as three arrays: all
/// offsets, all active labels, all names (the SDK's order).
fn read_rigid_body(r: &mut Reader<'_>) -> Result<RigidBodyDescription, Error> {
    let name = r.cstr("rigid body name")?;
    let id = r.i32("rigid body id")?;
    let parent_id = r.i32("rigid body parent id")?;
    let offset = r.vec3("rigid body offset")?;
    let n = r.count("rigid body marker", RIGID_BODY_MARKER_MIN_LEN)?;
    let offsets = read_many(r, n, |r| r.vec3("marker offset"))?;
    let labels = read_many(r, n, |r| r.i32("marker active label"))?;
    let mut markers = Vec::with_capacity(n);
    for (offset, active_label) in offsets.into_iter().zip(labels) {
        let name = r.cstr("rigid body marker name")?;
        markers.push(RigidBodyMarkerDescription { offset, active_label, name });
    }
    Ok(RigidBodyDescription { name, id, parent_id, offset, markers })
}

fn write_rigid_body(w: &mut Writer, rb: &RigidBodyDescription) -> Result<(), Error> {
    w.cstr(&rb.name, "rigid body name")?;
    w.i32(rb.id);
    w.i32(rb.parent_id);
    w.floats(&rb.offset);
    w.count(rb.markers.len(), "rigid body markers")?;
    rb.markers.iter().for_each(|m| w.floats(&m.offset));
    rb.markers.iter().for_each(|m| w.i32(m.active_label));
    for m in &rb.markers {
        w.cstr(&m.name, "rigid body marker name")?;
    }
    Ok(())
}
