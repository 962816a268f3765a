//! Motion-capture frame → arena frame: axes, origin, scale, heading.
//!
//! Why configurable: Motive streams Y-up by default (ground plane X–Z),
//! some labs switch it to Z-up, the arena's origin is wherever the start
//! was taped, and the simulated grid's unit is not the metre. Heading is
//! the yaw of the orientation: the body's forward axis (+X in Motive's
//! rigid-body frame) rotated by the quaternion and projected on the ground
//! plane — no Euler convention to get wrong, and pitch/roll from a tilted
//! marker plate cannot leak into it.
//!
//! Y-up (right-handed): arena x = X, arena y = −Z (so that looking down
//! the up axis, x → y is counter-clockwise and a positive yaw about +Y is
//! a positive heading). Z-up: arena x = X, arena y = Y.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// Which mocap axis points up.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
pub enum UpAxis {
    /// Motive's default.
    #[default]
    #[serde(rename = "y")]
    Y,
    /// Z up.
    #[serde(rename = "z")]
    Z,
}

/// How mocap coordinates map into the arena.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ArenaTransform {
    /// The up axis of the mocap frame.
    #[serde(default)]
    pub up: UpAxis,
    /// The arena origin in mocap coordinates, metres.
    #[serde(default)]
    pub origin: [f64; 3],
    /// Arena units per metre.
    #[serde(default = "unit_scale")]
    pub scale: f64,
}

fn unit_scale() -> f64 {
    1.0
}

impl Default for ArenaTransform {
    fn default() -> Self {
        Self { up: UpAxis::Y, origin: [0.0; 3], scale: 1.0 }
    }
}

/// A pose in the arena: position (arena units) and heading (rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArenaPose {
    /// x, arena units.
    pub x: f64,
    /// y, arena units.
    pub y: f64,
    /// Heading, rad, counter-clockwise from +x.
    pub heading: f64,
}

impl ArenaTransform {
    fn ground(&self, v: Vector3<f64>) -> (f64, f64) {
        match self.up {
            UpAxis::Y => (v.x, -v.z),
            UpAxis::Z => (v.x, v.y),
        }
    }

    /// Converts a mocap position (metres) and quaternion (qx, qy, qz, qw).
    /// `None` if the quaternion is degenerate (zero or not finite).
    pub fn to_arena(&self, position: [f32; 3], orientation: [f32; 4]) -> Option<ArenaPose> {
        self.to_arena_f64(position.map(f64::from), orientation.map(f64::from))
    }

    /// [`Self::to_arena`] of a pose in double precision (a ROS 2
    /// `geometry_msgs/msg/Pose`: position in metres, quaternion x, y, z, w).
    pub fn to_arena_f64(&self, position: [f64; 3], orientation: [f64; 4]) -> Option<ArenaPose> {
        let [qx, qy, qz, qw] = orientation;
        let q = Quaternion::new(qw, qx, qy, qz);
        let norm = q.norm();
        if !(norm.is_finite() && norm > 1e-6) || position.iter().any(|p| !p.is_finite()) {
            return None;
        }
        let rotation = UnitQuaternion::from_quaternion(q);
        let forward = rotation * Vector3::x();
        let (fx, fy) = self.ground(forward);
        let heading = fy.atan2(fx);
        let p = Vector3::from(position) - Vector3::from(self.origin);
        let (x, y) = self.ground(p);
        Some(ArenaPose { x: x * self.scale, y: y * self.scale, heading })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::FRAC_PI_2;

    fn yaw_about(axis: Vector3<f64>, angle: f64) -> [f32; 4] {
        let q = UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
        [q.i as f32, q.j as f32, q.k as f32, q.w as f32]
    }

    #[test]
    fn motive_y_up_maps_minus_z_to_arena_y_and_yaw_to_heading() {
        let t = ArenaTransform { origin: [1.0, 0.0, 1.0], scale: 10.0, ..ArenaTransform::default() };
        let p = t.to_arena([2.0, 0.3, -1.0], yaw_about(Vector3::y(), FRAC_PI_2)).unwrap();
        assert!((p.x - 10.0).abs() < 1e-5 && (p.y - 20.0).abs() < 1e-5, "{p:?}");
        assert!((p.heading - FRAC_PI_2).abs() < 1e-6, "yaw +90° about Y is heading +90°");
    }

    #[test]
    fn z_up_uses_x_y_and_yaw_about_z() {
        let t = ArenaTransform { up: UpAxis::Z, ..ArenaTransform::default() };
        let p = t.to_arena([1.0, 2.0, 0.5], yaw_about(Vector3::z(), -0.5)).unwrap();
        assert!((p.x - 1.0).abs() < 1e-6 && (p.y - 2.0).abs() < 1e-6);
        assert!((p.heading + 0.5).abs() < 1e-6);
    }

    #[test]
    fn tilt_does_not_change_heading_and_bad_quaternions_are_refused() {
        let t = ArenaTransform::default();
        let yaw = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.7);
        let roll = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.3);
        let q = yaw * roll;
        let p = t.to_arena([0.0; 3], [q.i as f32, q.j as f32, q.k as f32, q.w as f32]).unwrap();
        assert!((p.heading - 0.7).abs() < 1e-6, "{}", p.heading);
        assert_eq!(t.to_arena([0.0; 3], [0.0; 4]), None, "Motive's untracked zero quaternion");
        assert_eq!(t.to_arena([f32::NAN, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]), None);
    }
}
