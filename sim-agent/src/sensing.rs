//! Sensing noise of the paper's robustness study (§V-B).
//!
//! When enabled, every control period the measured intensity is multiplied by
//! U(0.8, 1.2) and π/6·U(−1, 1) is added to the gradient direction, drawn
//! independently. Both draws happen every period whether or not the
//! controller needs the values, so a robot's random stream depends only on
//! its seed and its number of periods — which is what lets a robot process
//! reproduce the in-process simulator exactly.
//!
//! Each robot owns its generator, seeded from the run seed and its robot id
//! (`robot_seed`), for the same reason.

use core::f64::consts::PI;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Bounds of the noise; [`NoiseModel::paper`] gives §V-B's.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NoiseModel {
    /// Intensity factor drawn from U(1 − gain, 1 + gain).
    pub gain: f64,
    /// Direction offset drawn from U(−angle, angle), rad.
    pub angle: f64,
}

impl NoiseModel {
    pub fn paper() -> Self {
        Self { gain: 0.2, angle: PI / 6.0 }
    }
}

/// One robot's seeded noise source.
#[derive(Clone, Debug)]
pub struct SensingNoise {
    model: NoiseModel,
    rng: Xoshiro256PlusPlus,
}

/// The seed of robot `robot` (1-based) in a run seeded `run_seed`:
/// [`crate::seed::mix`] of the pair, so neighbouring ids get unrelated streams.
pub fn robot_seed(run_seed: u64, robot: u32) -> u64 {
    crate::seed::mix(run_seed, u64::from(robot))
}

impl SensingNoise {
    pub fn new(model: NoiseModel, seed: u64) -> Self {
        Self { model, rng: Xoshiro256PlusPlus::seed_from_u64(seed) }
    }

    /// Draws this period's (intensity factor, direction offset).
    #[inline]
    pub fn draw(&mut self) -> (f64, f64) {
        let factor = 1.0 + self.model.gain * self.rng.gen_range(-1.0..1.0);
        let offset = self.model.angle * self.rng.gen_range(-1.0..1.0);
        (factor, offset)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_stay_in_bounds_and_cover_them() {
        let mut n = SensingNoise::new(NoiseModel::paper(), 7);
        let (mut lo, mut hi, mut alo, mut ahi) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for _ in 0..100_000 {
            let (f, a) = n.draw();
            assert!((0.8..=1.2).contains(&f));
            assert!((-PI / 6.0..=PI / 6.0).contains(&a));
            lo = lo.min(f);
            hi = hi.max(f);
            alo = alo.min(a);
            ahi = ahi.max(a);
        }
        assert!(lo < 0.801 && hi > 1.199 && alo < -0.52 && ahi > 0.52);
    }

    #[test]
    fn same_seed_same_stream_and_robots_differ() {
        let mut a = SensingNoise::new(NoiseModel::paper(), robot_seed(1, 1));
        let mut b = SensingNoise::new(NoiseModel::paper(), robot_seed(1, 1));
        let mut c = SensingNoise::new(NoiseModel::paper(), robot_seed(1, 2));
        let sa: Vec<_> = (0..10).map(|_| a.draw()).collect();
        let sb: Vec<_> = (0..10).map(|_| b.draw()).collect();
        let sc: Vec<_> = (0..10).map(|_| c.draw()).collect();
        assert_eq!(sa, sb);
        assert_ne!(sa, sc);
    }
}
