//! `NAT_FRAMEOFDATA`: one motion-capture frame, every section of 4.x.
//!
//! Why every section is decoded, not only rigid bodies: the sections are
//! laid end to end without offsets, so reaching the suffix (timestamp,
//! params) means walking skeletons, assets, labeled markers, force plates
//! and devices anyway; keeping them costs little and lets the server
//! encode a frame the SDK's client reads in full.

use super::wire::{read_many, Reader, Writer};
use super::{Error, Version};

/// Bit of [`RigidBody::params`] set when the body was tracked this frame.
pub const TRACKING_VALID: i16 = 0x01;

const MARKER_LEN: usize = 12;
const RIGID_BODY_LEN: usize = 4 + 12 + 16 + 4 + 2;
const LABELED_MARKER_LEN: usize = 4 + 12 + 4 + 2 + 4;

/// A named marker set and its markers' positions.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkerSet {
    /// The model's name.
    pub name: String,
    /// Marker positions, metres, in Motive's frame.
    pub markers: Vec<[f32; 3]>,
}

/// One rigid body's solution in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidBody {
    /// Streaming id (matches [`super::RigidBodyDescription::id`]).
    pub id: i32,
    /// Position, metres, in Motive's frame.
    pub position: [f32; 3],
    /// Orientation quaternion as sent: qx, qy, qz, qw.
    pub orientation: [f32; 4],
    /// Mean marker error, metres.
    pub mean_error: f32,
    /// Flags; bit 0 is [`TRACKING_VALID`].
    pub params: i16,
}

impl RigidBody {
    /// Whether Motive tracked the body in this frame (bit 0 of `params`).
    pub fn tracking_valid(&self) -> bool {
        self.params & TRACKING_VALID != 0
    }

    fn read(r: &mut Reader<'_>) -> Result<Self, Error> {
        Ok(Self {
            id: r.i32("rigid body id")?,
            position: r.vec3("rigid body position")?,
            orientation: r.quat("rigid body orientation")?,
            mean_error: r.f32("rigid body mean error")?,
            params: r.i16("rigid body params")?,
        })
    }

    fn write(&self, w: &mut Writer) {
        w.i32(self.id);
        w.floats(&self.position);
        w.floats(&self.orientation);
        w.f32(self.mean_error);
        w.i16(self.params);
    }
}

/// A skeleton: an id and its bones as rigid bodies.
#[derive(Clone, Debug, PartialEq)]
pub struct Skeleton {
    /// Skeleton id.
    pub id: i32,
    /// Its bones.
    pub rigid_bodies: Vec<RigidBody>,
}

/// A labeled marker (also the marker layout inside assets).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabeledMarker {
    /// Model id in the high 16 bits, marker id in the low 16.
    pub id: i32,
    /// Position, metres.
    pub position: [f32; 3],
    /// Marker size, metres.
    pub size: f32,
    /// Flags (occluded, point-cloud solved, model solved, …).
    pub params: i16,
    /// Residual, metres.
    pub residual: f32,
}

impl LabeledMarker {
    fn read(r: &mut Reader<'_>) -> Result<Self, Error> {
        Ok(Self {
            id: r.i32("marker id")?,
            position: r.vec3("marker position")?,
            size: r.f32("marker size")?,
            params: r.i16("marker params")?,
            residual: r.f32("marker residual")?,
        })
    }

    fn write(&self, w: &mut Writer) {
        w.i32(self.id);
        w.floats(&self.position);
        w.f32(self.size);
        w.i16(self.params);
        w.f32(self.residual);
    }
}

/// An asset (NatNet 4.1+): its rigid bodies and markers.
#[derive(Clone, Debug, PartialEq)]
pub struct Asset {
    /// Asset id.
    pub id: i32,
    /// Its rigid bodies (same layout as top-level rigid bodies).
    pub rigid_bodies: Vec<RigidBody>,
    /// Its markers (same layout as labeled markers).
    pub markers: Vec<LabeledMarker>,
}

/// A force plate or device: per channel, the samples of this frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Channels {
    /// Plate or device id.
    pub id: i32,
    /// Samples per channel.
    pub channels: Vec<Vec<f32>>,
}

impl Channels {
    fn read(r: &mut Reader<'_>) -> Result<Self, Error> {
        let id = r.i32("channel owner id")?;
        let n = r.count("channel", 4)?;
        let mut channels = Vec::with_capacity(n);
        for _ in 0..n {
            let frames = r.count("channel sample", 4)?;
            let mut samples = Vec::with_capacity(frames);
            for _ in 0..frames {
                samples.push(r.f32("channel sample")?);
            }
            channels.push(samples);
        }
        Ok(Self { id, channels })
    }

    fn write(&self, w: &mut Writer) -> Result<(), Error> {
        w.i32(self.id);
        w.count(self.channels.len(), "channels")?;
        for samples in &self.channels {
            w.count(samples.len(), "channel samples")?;
            w.floats(samples);
        }
        Ok(())
    }
}

/// The frame suffix: timing and frame flags.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Suffix {
    /// SMPTE timecode.
    pub timecode: u32,
    /// Timecode sub-frame.
    pub timecode_sub: u32,
    /// Seconds since Motive started streaming.
    pub timestamp: f64,
    /// Camera mid-exposure, high-resolution clock ticks.
    pub stamp_camera_mid_exposure: u64,
    /// Camera data received, ticks.
    pub stamp_data_received: u64,
    /// Frame transmitted, ticks.
    pub stamp_transmit: u64,
    /// Precision timestamp, whole seconds (0 when unavailable).
    pub precision_secs: u32,
    /// Precision timestamp, fraction of a second.
    pub precision_frac_secs: u32,
    /// Bit 0: recording; bit 1: tracked models changed.
    pub params: i16,
}

/// One frame of motion-capture data.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameOfData {
    /// Motive's frame number.
    pub frame_number: i32,
    /// Marker sets.
    pub marker_sets: Vec<MarkerSet>,
    /// Legacy unlabeled ("other") markers.
    pub unlabeled_markers: Vec<[f32; 3]>,
    /// Rigid bodies: the robots.
    pub rigid_bodies: Vec<RigidBody>,
    /// Skeletons.
    pub skeletons: Vec<Skeleton>,
    /// Assets (4.1+; always empty in a 4.0 stream).
    pub assets: Vec<Asset>,
    /// Labeled markers.
    pub labeled_markers: Vec<LabeledMarker>,
    /// Force plates.
    pub force_plates: Vec<Channels>,
    /// Other analog devices.
    pub devices: Vec<Channels>,
    /// Timing and flags.
    pub suffix: Suffix,
}

/// Reads one section's count, and its byte size from 4.1 on.
fn section(r: &mut Reader<'_>, v: Version, what: &'static str, min: usize) -> Result<usize, Error> {
    let n = r.count(what, min)?;
    if v.has_sizes() {
        // Informative only: each item is walked field by field anyway.
        r.i32("section size")?;
    }
    Ok(n)
}

fn begin(w: &mut Writer, v: Version, n: usize, what: &'static str) -> Result<Option<usize>, Error> {
    w.count(n, what)?;
    Ok(v.has_sizes().then(|| w.begin_size()))
}

fn end(w: &mut Writer, at: Option<usize>, what: &'static str) -> Result<(), Error> {
    at.map_or(Ok(()), |at| w.end_size(at, what))
}

impl FrameOfData {
    pub(crate) fn read(r: &mut Reader<'_>, v: Version) -> Result<Self, Error> {
        v.check()?;
        let frame_number = r.i32("frame number")?;
        let n = section(r, v, "marker set", 5)?;
        let marker_sets = read_many(r, n, |r| {
            let name = r.cstr("marker set name")?;
            let m = r.count("marker", MARKER_LEN)?;
            Ok(MarkerSet { name, markers: read_many(r, m, |r| r.vec3("marker"))? })
        })?;
        let n = section(r, v, "unlabeled marker", MARKER_LEN)?;
        let unlabeled_markers = read_many(r, n, |r| r.vec3("unlabeled marker"))?;
        let n = section(r, v, "rigid body", RIGID_BODY_LEN)?;
        let rigid_bodies = read_many(r, n, RigidBody::read)?;
        let n = section(r, v, "skeleton", 8)?;
        let skeletons = read_many(r, n, |r| {
            let id = r.i32("skeleton id")?;
            let b = r.count("skeleton bone", RIGID_BODY_LEN)?;
            Ok(Skeleton { id, rigid_bodies: read_many(r, b, RigidBody::read)? })
        })?;
        let assets = if v.has_sizes() {
            let n = section(r, v, "asset", 12)?;
            read_many(r, n, |r| {
                let id = r.i32("asset id")?;
                let b = r.count("asset rigid body", RIGID_BODY_LEN)?;
                let rigid_bodies = read_many(r, b, RigidBody::read)?;
                let m = r.count("asset marker", LABELED_MARKER_LEN)?;
                Ok(Asset { id, rigid_bodies, markers: read_many(r, m, LabeledMarker::read)? })
            })?
        } else {
            Vec::new()
        };
        let n = section(r, v, "labeled marker", LABELED_MARKER_LEN)?;
        let labeled_markers = read_many(r, n, LabeledMarker::read)?;
        let n = section(r, v, "force plate", 8)?;
        let force_plates = read_many(r, n, Channels::read)?;
        let n = section(r, v, "device", 8)?;
        let devices = read_many(r, n, Channels::read)?;
        let suffix = Suffix {
            timecode: r.u32("timecode")?,
            timecode_sub: r.u32("timecode sub-frame")?,
            timestamp: r.f64("timestamp")?,
            stamp_camera_mid_exposure: r.u64("mid-exposure stamp")?,
            stamp_data_received: r.u64("data-received stamp")?,
            stamp_transmit: r.u64("transmit stamp")?,
            precision_secs: r.u32("precision timestamp")?,
            precision_frac_secs: r.u32("precision timestamp fraction")?,
            params: r.i16("frame params")?,
        };
        // Newer servers may append fields (4.4 adds an end-of-data tag):
        // ignored, as the SDK's reference client does.
        Ok(Self {
            frame_number,
            marker_sets,
            unlabeled_markers,
            rigid_bodies,
            skeletons,
            assets,
            labeled_markers,
            force_plates,
            devices,
            suffix,
        })
    }

    pub(crate) fn write(&self, w: &mut Writer, v: Version) -> Result<(), Error> {
        v.check()?;
        w.i32(self.frame_number);
        let at = begin(w, v, self.marker_sets.len(), "marker sets")?;
        for set in &self.marker_sets {
            w.cstr(&set.name, "marker set name")?;
            w.count(set.markers.len(), "markers")?;
            set.markers.iter().for_each(|m| w.floats(m));
        }
        end(w, at, "marker sets")?;
        let at = begin(w, v, self.unlabeled_markers.len(), "unlabeled markers")?;
        self.unlabeled_markers.iter().for_each(|m| w.floats(m));
        end(w, at, "unlabeled markers")?;
        let at = begin(w, v, self.rigid_bodies.len(), "rigid bodies")?;
        self.rigid_bodies.iter().for_each(|b| b.write(w));
        end(w, at, "rigid bodies")?;
        let at = begin(w, v, self.skeletons.len(), "skeletons")?;
        for s in &self.skeletons {
            w.i32(s.id);
            w.count(s.rigid_bodies.len(), "skeleton bones")?;
            s.rigid_bodies.iter().for_each(|b| b.write(w));
        }
        end(w, at, "skeletons")?;
        if v.has_sizes() {
            let at = begin(w, v, self.assets.len(), "assets")?;
            for a in &self.assets {
                w.i32(a.id);
                w.count(a.rigid_bodies.len(), "asset rigid bodies")?;
                a.rigid_bodies.iter().for_each(|b| b.write(w));
                w.count(a.markers.len(), "asset markers")?;
                a.markers.iter().for_each(|m| m.write(w));
            }
            end(w, at, "assets")?;
        } else if !self.assets.is_empty() {
            return Err(Error::TooLarge { what: "assets (none in NatNet 4.0)" });
        }
        let at = begin(w, v, self.labeled_markers.len(), "labeled markers")?;
        self.labeled_markers.iter().for_each(|m| m.write(w));
        end(w, at, "labeled markers")?;
        for (list, what) in [(&self.force_plates, "force plates"), (&self.devices, "devices")] {
            let at = begin(w, v, list.len(), what)?;
            for c in list {
                c.write(w)?;
            }
            end(w, at, what)?;
        }
        let s = &self.suffix;
        w.u32(s.timecode);
        w.u32(s.timecode_sub);
        w.f64(s.timestamp);
        w.u64(s.stamp_camera_mid_exposure);
        w.u64(s.stamp_data_received);
        w.u64(s.stamp_transmit);
        w.u32(s.precision_secs);
        w.u32(s.precision_frac_secs);
        w.i16(s.params);
        Ok(())
    }
}
