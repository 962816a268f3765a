//! What the emulated cameras see, frame by frame: sans-IO and seeded.
//!
//! Why apart from the sockets: the faults (lost frames, occlusions, noise,
//! swapped ids) are the point of the emulator, and they must repeat
//! exactly for a seed; a pure `next_frame(poses)` is tested without any
//! socket, and the server only sends what it returns.

use super::config::{OcclusionMode, ServerConfig};
use bycoms_protocol::natnet::{
    DataDescription, FrameOfData, MarkerSet, ModelDefinitions, RigidBody, RigidBodyDescription,
    RigidBodyMarkerDescription, Suffix, TRACKING_VALID,
};
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// The five markers on top of each robot (paper §VI), body frame, metres.
pub const MARKER_OFFSETS: [[f32; 3]; 5] =
    [[0.05, 0.10, 0.00], [-0.05, 0.10, 0.03], [0.00, 0.10, 0.06], [0.03, 0.10, -0.05], [-0.04, 0.10, -0.04]];

/// A body's true pose in Motive's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyPose {
    /// Position, metres.
    pub position: [f32; 3],
    /// Orientation qx, qy, qz, qw.
    pub orientation: [f32; 4],
}

impl BodyPose {
    /// A body at `position` turned `yaw` radians about Motive's up axis (Y).
    pub fn yawed(position: [f32; 3], yaw: f32) -> Self {
        let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), yaw);
        Self { position, orientation: [q.i, q.j, q.k, q.w] }
    }

    fn rotation(&self) -> UnitQuaternion<f32> {
        let [i, j, k, w] = self.orientation;
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, i, j, k))
    }
}

/// The model definitions for the configured bodies (names, ids, markers).
pub fn model_definitions(config: &ServerConfig) -> ModelDefinitions {
    let descriptions = config
        .bodies
        .iter()
        .map(|b| {
            DataDescription::RigidBody(RigidBodyDescription {
                name: b.name.clone(),
                id: b.id,
                parent_id: -1,
                offset: [0.0; 3],
                markers: MARKER_OFFSETS
                    .iter()
                    .enumerate()
                    .map(|(k, offset)| RigidBodyMarkerDescription {
                        offset: *offset,
                        active_label: 0,
                        name: format!("Marker{}", k + 1),
                    })
                    .collect(),
            })
        })
        .collect();
    ModelDefinitions { descriptions }
}

/// Makes frame after frame, applying the configured faults.
pub struct FrameMaker {
    config: ServerConfig,
    rng: Xoshiro256PlusPlus,
    index: u64,
}

impl FrameMaker {
    /// Starts at frame 0 with the faults' seed.
    pub fn new(config: ServerConfig) -> Self {
        let rng = Xoshiro256PlusPlus::seed_from_u64(config.faults.seed);
        Self { config, rng, index: 0 }
    }

    /// Stream time of the next frame, seconds.
    pub fn time_s(&self) -> f64 {
        self.index as f64 / self.config.rate_hz
    }

    /// The next frame for the bodies' true poses (in config order), or
    /// `None` when the frame is lost. The frame counter advances either way.
    pub fn next_frame(&mut self, poses: &[BodyPose]) -> Option<FrameOfData> {
        self.next_frame_seen(poses, &[])
    }

    /// [`FrameMaker::next_frame`] where body `k` (config order) is only
    /// seen when `seen[k]` is true (missing entries: seen); an unseen body
    /// is sent as Motive sends a body out of the volume: tracking-valid
    /// off, zero pose (the emulated lab's robots waiting off the arena).
    pub fn next_frame_seen(&mut self, poses: &[BodyPose], seen: &[bool]) -> Option<FrameOfData> {
        let t = self.time_s();
        let frame_number = i32::try_from(self.index).unwrap_or(i32::MAX);
        self.index += 1;
        let faults = &self.config.faults;
        let lost = self.rng.gen::<f64>() < faults.frame_loss;
        let noise = faults.marker_noise_m;
        let mut rigid_bodies = Vec::with_capacity(poses.len());
        let mut marker_sets = Vec::with_capacity(poses.len());
        for (k, (body, pose)) in self.config.bodies.iter().zip(poses).enumerate() {
            // Draw the noise even for a lost frame: the sequence stays the same.
            let jitter: [f32; 3] = [gauss(&mut self.rng), gauss(&mut self.rng), gauss(&mut self.rng)];
            let occlusion =
                faults.occlusions.iter().find(|o| o.id == body.id && (o.from_s..o.to_s).contains(&t));
            if matches!(occlusion, Some(o) if o.mode == OcclusionMode::Missing) {
                continue;
            }
            let id = faults
                .swaps
                .iter()
                .filter(|s| (s.from_s..s.to_s).contains(&t))
                .find_map(|s| match body.id {
                    x if x == s.a => Some(s.b),
                    x if x == s.b => Some(s.a),
                    _ => None,
                })
                .unwrap_or(body.id);
            let position: [f32; 3] = core::array::from_fn(|k| pose.position[k] + noise * jitter[k]);
            if occlusion.is_some() || !seen.get(k).copied().unwrap_or(true) {
                rigid_bodies.push(RigidBody {
                    id,
                    position: [0.0; 3],
                    orientation: [0.0; 4],
                    mean_error: 0.0,
                    params: 0,
                });
                marker_sets.push(MarkerSet { name: body.name.clone(), markers: Vec::new() });
                continue;
            }
            let rotation = pose.rotation();
            let markers = MARKER_OFFSETS
                .iter()
                .map(|o| {
                    let m = rotation * Vector3::from(*o) + Vector3::from(position);
                    [m.x, m.y, m.z]
                })
                .collect();
            marker_sets.push(MarkerSet { name: body.name.clone(), markers });
            let mean_error = noise * (jitter.iter().map(|j| j * j).sum::<f32>() / 3.0).sqrt();
            rigid_bodies.push(RigidBody {
                id,
                position,
                orientation: pose.orientation,
                mean_error,
                params: TRACKING_VALID,
            });
        }
        if lost {
            return None;
        }
        Some(FrameOfData {
            frame_number,
            marker_sets,
            rigid_bodies,
            suffix: Suffix { timestamp: t, ..Suffix::default() },
            ..FrameOfData::default()
        })
    }
}

/// A standard normal sample (Box–Muller), f32.
fn gauss(rng: &mut Xoshiro256PlusPlus) -> f32 {
    let u1 = rng.gen::<f64>().max(f64::MIN_POSITIVE);
    let u2 = rng.gen::<f64>();
    ((-2.0 * u1.ln()).sqrt() * (core::f64::consts::TAU * u2).cos()) as f32
}
