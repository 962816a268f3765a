//! Field physics: every robot is a source of g(r) = c / |r − r_j|².
//!
//! The field a robot senses is the sum over all *other* robots (in the
//! sequential runner, the beacons: only one robot moves at a time). The
//! gradient of c/d² points towards each source with weight 2c/d³; only its
//! direction is used, so [`Beacons::sample`] accumulates Σ (r_j − r)/d⁴ and
//! leaves the constant factor out.
//!
//! Beacons are stored as two flat arrays (struct of arrays) because the sum
//! over them is the simulator's inner loop; the summation order is the
//! deployment order, which makes the result (bit for bit) independent of how
//! the caller got here.

use crate::Vec2;

/// The field at one point, before sensing noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldSample {
    /// Intensity g = Σ c / d².
    pub intensity: f64,
    /// Gradient vector direction components (towards the sources), unnormalised.
    pub gx: f64,
    pub gy: f64,
}

impl FieldSample {
    /// Direction of the gradient, rad; 0 when there is no field at all.
    #[inline]
    pub fn direction(&self) -> f64 {
        libm::atan2(self.gy, self.gx)
    }
}

/// Stopped robots, the sources of the field, in deployment order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Beacons {
    xs: Vec<f64>,
    ys: Vec<f64>,
    c: f64,
}

impl Beacons {
    /// An empty set with field constant `c` (the paper uses 1).
    pub fn new(c: f64) -> Self {
        Self { xs: Vec::new(), ys: Vec::new(), c }
    }

    /// Adds a stopped robot at `p`.
    pub fn push(&mut self, p: Vec2) {
        self.xs.push(p.x);
        self.ys.push(p.y);
    }

    pub fn len(&self) -> usize {
        self.xs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.xs.is_empty()
    }

    /// Positions in deployment order.
    pub fn positions(&self) -> impl ExactSizeIterator<Item = Vec2> + '_ {
        self.xs.iter().zip(&self.ys).map(|(&x, &y)| Vec2::new(x, y))
    }

    /// Field intensity and gradient direction at `p`.
    ///
    /// A source exactly at `p` contributes infinity (the robot sits on a
    /// companion); the simulator never asks for that since a robot stops
    /// where it enters an impassable cell and the next starts elsewhere.
    #[inline]
    pub fn sample(&self, p: Vec2) -> FieldSample {
        let (mut g, mut gx, mut gy) = (0.0, 0.0, 0.0);
        for (&x, &y) in self.xs.iter().zip(&self.ys) {
            let dx = x - p.x;
            let dy = y - p.y;
            let inv = 1.0 / (dx * dx + dy * dy);
            g += inv;
            let w = inv * inv;
            gx += dx * w;
            gy += dy * w;
        }
        FieldSample { intensity: self.c * g, gx, gy }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_source_inverse_square_and_points_at_it() {
        let mut b = Beacons::new(1.0);
        b.push(Vec2::new(3.0, 4.0));
        let s = b.sample(Vec2::new(0.0, 0.0));
        assert!((s.intensity - 1.0 / 25.0).abs() < 1e-15);
        assert!((s.direction() - libm::atan2(4.0, 3.0)).abs() < 1e-12);
    }

    #[test]
    fn sums_over_sources_and_scales_with_c() {
        let mut b = Beacons::new(2.0);
        b.push(Vec2::new(1.0, 0.0));
        b.push(Vec2::new(-2.0, 0.0));
        let s = b.sample(Vec2::new(0.0, 0.0));
        assert!((s.intensity - 2.0 * (1.0 + 0.25)).abs() < 1e-15);
        // The nearer source dominates: gradient points to +x.
        assert!(s.direction().abs() < 1e-12);
    }

    #[test]
    fn gradient_matches_finite_difference() {
        let mut b = Beacons::new(1.0);
        for (x, y) in [(3.0, 1.0), (-1.0, 4.0), (2.5, -2.0)] {
            b.push(Vec2::new(x, y));
        }
        let p = Vec2::new(0.3, 0.2);
        let h = 1e-6;
        let fx = (b.sample(Vec2::new(p.x + h, p.y)).intensity - b.sample(Vec2::new(p.x - h, p.y)).intensity)
            / (2.0 * h);
        let fy = (b.sample(Vec2::new(p.x, p.y + h)).intensity - b.sample(Vec2::new(p.x, p.y - h)).intensity)
            / (2.0 * h);
        let s = b.sample(p);
        assert!((libm::atan2(fy, fx) - s.direction()).abs() < 1e-6);
    }

    #[test]
    fn no_sources_no_field() {
        let s = Beacons::new(1.0).sample(Vec2::new(1.0, 1.0));
        assert_eq!(s.intensity, 0.0);
        assert_eq!(s.direction(), 0.0);
    }
}
