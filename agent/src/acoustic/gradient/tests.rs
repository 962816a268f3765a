//! The estimator against fields whose true gradient direction is known.

use super::*;
use crate::angle::between;
use core::f64::consts::PI;

const DEG: f64 = PI / 180.0;

fn ring() -> MicRing<PAPER_MICS> {
    MicRing::paper()
}

/// Readings of a point source c/d² at bearing `bearing`, distance `d`
/// from the ring's centre.
fn point_source<const M: usize>(ring: &MicRing<M>, c: f64, bearing: f64, d: f64) -> [f64; M] {
    let (sx, sy) = (d * libm::cos(bearing), d * libm::sin(bearing));
    ring.positions().map(|(x, y)| {
        let (dx, dy) = (sx - x, sy - y);
        c / (dx * dx + dy * dy)
    })
}

/// Largest direction error over a sweep of bearings (0.25° steps) at distance `d`.
fn worst_error(d: f64) -> f64 {
    let ring = ring();
    let mut worst: f64 = 0.0;
    for i in 0..1440 {
        let bearing = wrap(i as f64 * 0.25 * DEG);
        let est = ring.estimate(&point_source(&ring, 5500.0, bearing, d));
        let dir = est.direction.expect("a point source has a direction");
        worst = worst.max(between(dir, bearing));
    }
    worst
}

#[test]
fn paper_ring_geometry() {
    let p = ring().positions();
    assert_eq!(p[0], (0.1, 0.0));
    for (n, &(x, y)) in p.iter().enumerate() {
        assert!((libm::hypot(x, y) - 0.1).abs() < 1e-15);
        let expected = wrap(n as f64 * PI / 3.0);
        assert!(between(direction(x, y), expected) < 1e-12, "mic {n}");
    }
    // Counter-clockwise: M2 is at +60°.
    assert!(p[1].1 > 0.0);
}

#[test]
fn linear_field_is_exact() {
    let ring = ring();
    for i in 0..72 {
        let phi = wrap(i as f64 * 5.0 * DEG);
        let (gx, gy) = (300.0 * libm::cos(phi), 300.0 * libm::sin(phi));
        let v = ring.positions().map(|(x, y)| 20_000.0 + gx * x + gy * y);
        let est = ring.estimate(&v);
        assert!(between(est.direction.unwrap(), phi) < 1e-12, "phi = {phi}");
        assert!((est.mean - 20_000.0).abs() < 1e-9);
        assert!((ring.slope(&est) - 300.0).abs() < 1e-9);
    }
}

/// Measured worst errors (M = 6, r = 0.1): 0.63° at d = 3r, 0.21° at 4r,
/// 0.088° at 5r, 0.0138° at 8r — i.e. ≈ (r/d)⁴ rad, as the aliasing of the
/// 5th and 7th harmonics predicts. The stated bounds leave ~10 % margin.
#[test]
fn point_source_direction_error_bounds() {
    let r = PAPER_RADIUS;
    let cases = [(3.0, 0.8 * DEG), (4.0, 0.25 * DEG), (5.0, 0.1 * DEG), (8.0, 0.015 * DEG)];
    for (k, bound) in cases {
        let worst = worst_error(k * r);
        let predicted = libm::pow(1.0 / k, 4.0);
        assert!(worst <= bound, "d = {k}r: worst {} deg", worst / DEG);
        // The (r/d)^4 model is the right order: within a factor 1.2 of it.
        assert!(worst <= 1.2 * predicted && worst >= 0.8 * predicted, "d = {k}r");
    }
    // Error shrinks with distance, never grows.
    let mut last = f64::INFINITY;
    for k in 3..=20 {
        let w = worst_error(k as f64 * r);
        assert!(w < last);
        last = w;
    }
}

#[test]
fn bearings_on_a_mic_or_halfway_are_exact() {
    // By mirror symmetry the error vanishes on a microphone and midway between two.
    let ring = ring();
    for i in 0..12 {
        let bearing = wrap(i as f64 * 30.0 * DEG);
        let est = ring.estimate(&point_source(&ring, 1.0, bearing, 0.3));
        assert!(between(est.direction.unwrap(), bearing) < 1e-9, "bearing {bearing}");
    }
}

#[test]
fn two_sources_give_the_summed_field_gradient() {
    // Far sources: the estimate tracks the analytic gradient of the sum.
    let ring = ring();
    let (c1, b1, d1) = (5500.0, 0.4, 0.8);
    let (c2, b2, d2) = (3000.0, 2.5, 0.6);
    let a = point_source(&ring, c1, b1, d1);
    let b = point_source(&ring, c2, b2, d2);
    let v: [f64; 6] = core::array::from_fn(|n| a[n] + b[n]);
    // ∇(c/|s − p|²) at p = 0 is 2c·s/|s|⁴.
    let grad = |c: f64, bear: f64, d: f64| {
        let k = 2.0 * c / (d * d * d);
        (k * libm::cos(bear), k * libm::sin(bear))
    };
    let (g1, g2) = (grad(c1, b1, d1), grad(c2, b2, d2));
    let truth = direction(g1.0 + g2.0, g1.1 + g2.1);
    let est = ring.estimate(&v).direction.unwrap();
    assert!(between(est, truth) < 1.0 * DEG, "error {} deg", between(est, truth) / DEG);
}

#[test]
fn symmetric_readings_have_no_direction() {
    let ring = ring();
    for v in [
        [0.1; 6],
        [22_000.0; 6],
        [0.0; 6],
        [1.0, 2.0, 1.0, 2.0, 1.0, 2.0], // 3rd harmonic only
        [5.0, 7.0, 9.0, 5.0, 7.0, 9.0], // 3-fold symmetric
    ] {
        let est = ring.estimate(&v);
        assert_eq!(est.direction, None, "{v:?}");
        assert!(est.magnitude < 1e-9 * 0.1 * 22_000.0);
    }
    assert!((ring.estimate(&[0.1; 6]).mean - 0.1).abs() < 1e-16);
    assert_eq!(ring.estimate(&[f64::NAN; 6]).direction, None);
}

#[test]
fn single_loud_microphone_points_at_it() {
    let ring = ring();
    for n in 0..6 {
        let mut v = [100.0; 6];
        v[n] = 101.0;
        let dir = ring.estimate(&v).direction.unwrap();
        assert!(between(dir, wrap(MicRing::<6>::angle(n))) < 1e-12);
    }
}

#[test]
fn rotation_equivariance() {
    // Shifting the readings by one microphone rotates the estimate by 2π/M,
    // for any readings.
    let ring = ring();
    let v = [3.0, 8.5, 1.25, 4.0, 9.75, 2.0];
    let base = ring.estimate(&v);
    for shift in 1..6 {
        let rotated: [f64; 6] = core::array::from_fn(|n| v[(n + 6 - shift) % 6]);
        let est = ring.estimate(&rotated);
        let expected = wrap(base.direction.unwrap() + MicRing::<6>::angle(shift));
        assert!(between(est.direction.unwrap(), expected) < 1e-12, "shift {shift}");
        assert!((est.magnitude - base.magnitude).abs() < 1e-12);
        assert_eq!(est.mean, base.mean);
    }
}

#[test]
fn other_ring_sizes_work() {
    let ring = MicRing::<8>::new(0.05);
    let est = ring.estimate(&point_source(&ring, 1.0, 1.0, 0.5));
    assert!(between(est.direction.unwrap(), 1.0) < 0.01 * DEG);
}

#[test]
fn world_direction_adds_heading() {
    let est = GradientEstimate { mean: 1.0, direction: Some(3.0), magnitude: 1.0 };
    assert!((est.world_direction(1.0).unwrap() - wrap(4.0)).abs() < 1e-15);
    let none = GradientEstimate { direction: None, ..est };
    assert_eq!(none.world_direction(1.0), None);
}
