//! Angle arithmetic shared by the controllers.
//!
//! All math goes through `libm` rather than the platform's libm so that the
//! same inputs give the same bits on every target (host, ESP32, CI runner):
//! determinism is a tested contract of this project.

use core::f64::consts::{PI, TAU};

/// Wraps an angle to the half-open interval (−π, π].
#[inline]
pub fn wrap(a: f64) -> f64 {
    // Fast path: the controller only ever wraps differences of two wrapped
    // angles, i.e. values in (−2π, 2π]; one conditional step suffices.
    if a > PI {
        if a <= PI + TAU {
            return a - TAU;
        }
    } else if a > -PI {
        return a;
    } else if a > -PI - TAU {
        return a + TAU;
    }
    if !a.is_finite() {
        return a;
    }
    let mut r = libm::remainder(a, TAU);
    if r <= -PI {
        r += TAU;
    }
    r
}

/// Absolute angle between two directions, in [0, π].
#[inline]
pub fn between(a: f64, b: f64) -> f64 {
    libm::fabs(wrap(a - b))
}

/// Direction of the vector (x, y), in (−π, π]; 0 for the zero vector.
#[inline]
pub fn direction(x: f64, y: f64) -> f64 {
    libm::atan2(y, x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_lands_in_half_open_interval() {
        assert_eq!(wrap(PI), PI);
        assert_eq!(wrap(-PI), PI);
        assert!((wrap(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap(-0.5) + 0.5).abs() < 1e-15);
        assert!((wrap(TAU + 0.25) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn between_is_symmetric_and_bounded() {
        assert!((between(0.1, -0.1) - 0.2).abs() < 1e-15);
        assert!((between(-0.1, 0.1) - 0.2).abs() < 1e-15);
        assert!((between(PI - 0.1, -PI + 0.1) - 0.2).abs() < 1e-12);
        assert!(between(0.0, PI) <= PI);
    }
}
