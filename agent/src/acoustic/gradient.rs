//! Gradient direction from a ring of microphones (paper §VI-B).
//!
//! The physical robot cannot measure a gradient directly: it hears the same
//! field at M microphones spaced evenly on a circle of radius r around its
//! centre (paper: M = 6, r = 0.1 m, M1 at (r, 0) in the robot frame, numbered
//! counter-clockwise). The paper's estimator is a first-harmonic fit:
//!
//! * V_ave = Σ V_n / M — the intensity at the robot's centre;
//! * grad = Σ (V_n − V_ave)·m_n, m_n the position of microphone n.
//!
//! Only grad's direction is used by the controller. For a linear field the
//! estimate is exact (grad = (M r²/2)·∇V). For a point source c/d² at distance
//! d the readings' k-th angular harmonic falls off as (r/d)^k, and with M
//! samples harmonics M ± 1 alias onto the first; the direction error is thus
//! about (r/d)^(M−2) rad at worst — for M = 6 measured 0.63° at d = 3r and
//! 0.088° at d = 5r (see the tests). Readings with no first harmonic
//! (all equal, or M-fold symmetric patterns) give no direction at all, which
//! is reported as `None` rather than as an arbitrary angle.

use crate::angle::{direction, wrap};
use core::f64::consts::TAU;

/// Radius of the paper robot's microphone circle, m.
pub const PAPER_RADIUS: f64 = 0.1;

/// Number of microphones on the paper robot.
pub const PAPER_MICS: usize = 6;

/// A gradient smaller than this fraction of `radius · max |V_n|` counts as
/// zero: it is rounding noise of the mean, not a direction.
pub const DEGENERATE_RELATIVE: f64 = 1e-9;

/// M microphones evenly on a circle of `radius`, microphone 0 (the paper's
/// M1) at (radius, 0) in the robot frame, numbered counter-clockwise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MicRing<const M: usize> {
    /// Radius of the circle, m.
    pub radius: f64,
}

/// What one set of M readings says about the field at the robot's centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradientEstimate {
    /// V_ave, the mean reading: the intensity estimate at the centre.
    pub mean: f64,
    /// Direction of grad in the robot frame, (−π, π], counter-clockwise from
    /// the robot's x axis (M1); `None` when grad is (numerically) zero.
    pub direction: Option<f64>,
    /// |grad| as the paper defines it (reading units × m); see
    /// [`MicRing::slope`] for a field-per-metre value.
    pub magnitude: f64,
}

impl GradientEstimate {
    /// The gradient direction in the world frame for a robot with `heading`.
    pub fn world_direction(&self, heading: f64) -> Option<f64> {
        self.direction.map(|d| wrap(heading + d))
    }
}

impl MicRing<PAPER_MICS> {
    /// The paper robot's ring: six microphones on a 0.1 m circle.
    pub const fn paper() -> Self {
        Self { radius: PAPER_RADIUS }
    }
}

impl<const M: usize> MicRing<M> {
    /// A ring of M microphones on a circle of `radius`.
    pub const fn new(radius: f64) -> Self {
        Self { radius }
    }

    /// Angle of microphone `n` (0-based) in the robot frame: 2πn/M.
    pub fn angle(n: usize) -> f64 {
        TAU * n as f64 / M as f64
    }

    /// Positions m_n of the microphones in the robot frame, m.
    pub fn positions(&self) -> [(f64, f64); M] {
        core::array::from_fn(|n| {
            let a = Self::angle(n);
            (self.radius * libm::cos(a), self.radius * libm::sin(a))
        })
    }

    /// The factor M r²/2 relating grad to the true gradient of a linear field.
    pub fn scale(&self) -> f64 {
        M as f64 * self.radius * self.radius / 2.0
    }

    /// The slope |∇V| (reading units per metre) an estimate corresponds to;
    /// exact for a linear field.
    pub fn slope(&self, estimate: &GradientEstimate) -> f64 {
        estimate.magnitude / self.scale()
    }

    /// The paper's estimator: V_ave and the direction of Σ (V_n − V_ave)·m_n.
    pub fn estimate(&self, v: &[f64; M]) -> GradientEstimate {
        if M == 0 {
            return GradientEstimate { mean: 0.0, direction: None, magnitude: 0.0 };
        }
        let mean = v.iter().sum::<f64>() / M as f64;
        let (mut gx, mut gy, mut largest) = (0.0, 0.0, 0.0);
        for (&vn, (mx, my)) in v.iter().zip(self.positions()) {
            gx += (vn - mean) * mx;
            gy += (vn - mean) * my;
            largest = libm::fmax(largest, libm::fabs(vn));
        }
        let magnitude = libm::hypot(gx, gy);
        let floor = DEGENERATE_RELATIVE * libm::fabs(self.radius) * largest;
        // Written as `>` so that NaN readings give `None` too.
        let direction = if magnitude > floor { Some(direction(gx, gy)) } else { None };
        GradientEstimate { mean, direction, magnitude }
    }
}

#[cfg(test)]
mod tests;
