//! Foxglove primitives for the scene: colours, poses, discs, circles, labels.
//!
//! Everything is drawn in the `arena` frame, one grid cell = 1 m, z up; the
//! arena floor is z = 0 and markers sit just above it so they are not hidden
//! by the floor.

use bycoms_sim::Vec2;
use foxglove::messages::{
    line_primitive, ArrowPrimitive, Color, CubePrimitive, CylinderPrimitive, LinePrimitive, Point3, Pose,
    Quaternion, SpherePrimitive, TextPrimitive, Vector3,
};
use nalgebra::{UnitQuaternion, Vector3 as NVector3};

/// Points on a drawn circle (the ε circles, the goal disc outline).
pub const CIRCLE_POINTS: usize = 72;

/// An opaque or translucent colour from a `#rrggbb` palette entry.
pub fn rgba(hex: u32, a: f64) -> Color {
    let channel = |shift: u32| f64::from((hex >> shift) & 0xff) / 255.0;
    Color { r: channel(16), g: channel(8), b: channel(0), a }
}

/// The orientation of a heading θ (rad, counter-clockwise from +x) about z.
pub fn yaw(theta: f64) -> Quaternion {
    let q = UnitQuaternion::from_axis_angle(&NVector3::z_axis(), theta);
    Quaternion { x: q.i, y: q.j, z: q.k, w: q.w }
}

/// A pose at `(x, y, z)` with heading `theta`.
pub fn pose_at(x: f64, y: f64, z: f64, theta: f64) -> Pose {
    Pose { position: Some(Vector3 { x, y, z }), orientation: Some(yaw(theta)) }
}

/// A box spanning `[x0, x1] × [y0, y1]`, `height` tall, standing on z = `z0`.
pub fn cuboid(x0: f64, y0: f64, x1: f64, y1: f64, z0: f64, height: f64, color: Color) -> CubePrimitive {
    CubePrimitive {
        pose: Some(pose_at((x0 + x1) / 2.0, (y0 + y1) / 2.0, z0 + height / 2.0, 0.0)),
        size: Some(Vector3 { x: x1 - x0, y: y1 - y0, z: height }),
        color: Some(color),
    }
}

/// A flat disc of radius `r` at `c`, at height `z`.
pub fn disc(c: Vec2, r: f64, z: f64, color: Color) -> CylinderPrimitive {
    CylinderPrimitive {
        pose: Some(pose_at(c.x, c.y, z, 0.0)),
        size: Some(Vector3 { x: 2.0 * r, y: 2.0 * r, z: 0.02 }),
        bottom_scale: 1.0,
        top_scale: 1.0,
        color: Some(color),
    }
}

/// A ball of diameter `d` at `c`.
pub fn ball(c: Vec2, d: f64, z: f64, color: Color) -> SpherePrimitive {
    SpherePrimitive {
        pose: Some(pose_at(c.x, c.y, z, 0.0)),
        size: Some(Vector3 { x: d, y: d, z: d }),
        color: Some(color),
    }
}

/// An arrow from `c` along heading `theta`, `length` long.
pub fn arrow(c: Vec2, theta: f64, length: f64, z: f64, color: Color) -> ArrowPrimitive {
    ArrowPrimitive {
        pose: Some(pose_at(c.x, c.y, z, theta)),
        shaft_length: length * 0.7,
        shaft_diameter: length * 0.12,
        head_length: length * 0.3,
        head_diameter: length * 0.3,
        color: Some(color),
    }
}

/// A polyline through `points` at height `z` (closed when `closed`).
pub fn polyline(points: &[Vec2], z: f64, thickness: f64, closed: bool, color: Color) -> LinePrimitive {
    let kind = if closed { line_primitive::Type::LineLoop } else { line_primitive::Type::LineStrip };
    LinePrimitive {
        r#type: kind as i32,
        pose: Some(pose_at(0.0, 0.0, 0.0, 0.0)),
        thickness,
        scale_invariant: false,
        points: points.iter().map(|p| Point3 { x: p.x, y: p.y, z }).collect(),
        color: Some(color),
        colors: Vec::new(),
        indices: Vec::new(),
    }
}

/// The circle of radius `r` around `c`, as a closed polyline.
pub fn circle(c: Vec2, r: f64, z: f64, thickness: f64, color: Color) -> LinePrimitive {
    let points: Vec<Vec2> = (0..CIRCLE_POINTS)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / CIRCLE_POINTS as f64;
            Vec2::new(c.x + r * a.cos(), c.y + r * a.sin())
        })
        .collect();
    polyline(&points, z, thickness, true, color)
}

/// A label facing the viewer, `size` m tall, at `c` lifted to `z`.
pub fn label(c: Vec2, z: f64, size: f64, text: impl Into<String>, color: Color) -> TextPrimitive {
    TextPrimitive {
        pose: Some(pose_at(c.x, c.y, z, 0.0)),
        billboard: true,
        font_size: size,
        scale_invariant: false,
        color: Some(color),
        text: text.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_turns_the_x_axis_to_the_heading() {
        let q = yaw(std::f64::consts::FRAC_PI_2);
        let n = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z));
        let x = n * NVector3::x();
        assert!((x - NVector3::y()).norm() < 1e-12, "{x}");
    }

    #[test]
    fn a_circle_is_closed_and_at_its_radius() {
        let line = circle(Vec2::new(3.0, 4.0), 2.0, 0.1, 0.05, rgba(0xff0000, 1.0));
        assert_eq!(line.r#type, line_primitive::Type::LineLoop as i32);
        assert_eq!(line.points.len(), CIRCLE_POINTS);
        for p in &line.points {
            let r = ((p.x - 3.0).powi(2) + (p.y - 4.0).powi(2)).sqrt();
            assert!((r - 2.0).abs() < 1e-12, "{r}");
        }
    }

    #[test]
    fn palette_colours_decode() {
        let c = rgba(0x1f77b4, 0.5);
        assert_eq!((c.r * 255.0).round() as u32, 0x1f);
        assert_eq!((c.b * 255.0).round() as u32, 0xb4);
        assert_eq!(c.a, 0.5);
    }
}
