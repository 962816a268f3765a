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

/// An upper bound of the field sum on a disk around the point it was
/// computed at ([`Beacons::disk_bound`]), so that a robot moving in mode 1
/// far from the beacons needs no pass over them at every position.
///
/// With D the distance from `at` to the nearest beacon and r < D the
/// distance from `at` to p, every beacon is at least d − r from p if it is
/// d from `at`, and d / (d − r) ≤ D / (D − r) for d ≥ D: the sum at p is at
/// most (D / (D − r))² times the sum at `at`. The exact path's rounding
/// (its sum over the true one) is the same factor at every point, covered
/// by [`Beacons::upper_bound`]'s margin. r, D and the product are rounded
/// the safe way by a relative 1e-9, far above the roundings they cover,
/// and the disk ends at 0.99·D (a factor 10⁴ there: no use going further).
#[derive(Clone, Copy, Debug)]
pub struct DiskBound {
    at: Vec2,
    /// [`Beacons::upper_bound`] at `at`.
    sum: f64,
    /// At most the squared distance from `at` to the nearest beacon.
    near2: f64,
}

impl DiskBound {
    /// [`Beacons::upper_bound`] at the point it was computed at.
    #[inline]
    pub fn upper_bound(&self) -> f64 {
        self.sum
    }

    /// Whether this bound was computed at `p` itself.
    #[inline]
    pub fn is_at(&self, p: Vec2) -> bool {
        self.at.x.to_bits() == p.x.to_bits() && self.at.y.to_bits() == p.y.to_bits()
    }

    /// An upper bound of the Σ 1/d² that [`Beacons::sample`] computes at
    /// `p`; infinity if `p` is not well inside the disk.
    #[inline]
    pub fn at(&self, p: Vec2) -> f64 {
        if self.sum == 0.0 {
            // No beacons at all (the sum of one or more is positive).
            return 0.0;
        }
        let (dx, dy) = (p.x - self.at.x, p.y - self.at.y);
        // r is rounded up, D down (each by far more than their roundings).
        // (1e-100 covers the squares' underflow.)
        let r = libm::sqrt(dx * dx + dy * dy) * (1.0 + 1e-9) + 1e-100;
        let d = libm::sqrt(self.near2) * (1.0 - 1e-9);
        // Not within 99 % of D (or NaN): no bound.
        let inside = r < 0.99 * d;
        if !inside {
            return f64::INFINITY;
        }
        let ratio = d / (d - r);
        self.sum * (ratio * ratio) * (1.0 + 1e-9)
    }
}

/// Stopped robots, the sources of the field, in deployment order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Beacons {
    xs: Vec<f64>,
    ys: Vec<f64>,
    c: f64,
    /// The positions rounded to f32, for [`Self::disk_bound`]'s pass, in
    /// whole blocks of eight ...
    xs32: Vec<f32>,
    ys32: Vec<f32>,
    /// ... and the largest |coordinate| of them all (in f64), which bounds
    /// those roundings.
    extent: f64,
}

impl Beacons {
    /// An empty set with field constant `c` (the paper uses 1).
    pub fn new(c: f64) -> Self {
        Self { c, ..Self::default() }
    }

    /// Adds a stopped robot at `p`.
    pub fn push(&mut self, p: Vec2) {
        self.xs.push(p.x);
        self.ys.push(p.y);
        // Padded to whole blocks of eight with beacons infinitely far
        // away (each adds 1/∞ = 0 and is no nearer than any other).
        let n = self.xs.len();
        for (v32, v) in [(&mut self.xs32, p.x), (&mut self.ys32, p.y)] {
            v32.truncate(n - 1);
            v32.push(v as f32);
            v32.resize(n.div_ceil(8) * 8, f32::INFINITY);
        }
        // (A NaN is left out here; the pass's sum is NaN then: no bound.)
        self.extent = self.extent.max(libm::fabs(p.x)).max(libm::fabs(p.y));
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
        // Two beacons per iteration: their two divisions are independent of
        // the sums, so the compiler issues them as one packed division
        // (`divpd`, SSE2) — the divider, not the adds, bounded the one-at-a-
        // time loop. The three sums still take every term in deployment
        // order, one add at a time: the bits are those of the plain loop.
        let (mut g, mut gx, mut gy) = (0.0, 0.0, 0.0);
        let mut xs = self.xs.chunks_exact(2);
        let mut ys = self.ys.chunks_exact(2);
        for (x, y) in (&mut xs).zip(&mut ys) {
            let (dx0, dy0) = (x[0] - p.x, y[0] - p.y);
            let (dx1, dy1) = (x[1] - p.x, y[1] - p.y);
            let (inv0, inv1) = (1.0 / (dx0 * dx0 + dy0 * dy0), 1.0 / (dx1 * dx1 + dy1 * dy1));
            let (w0, w1) = (inv0 * inv0, inv1 * inv1);
            g += inv0;
            gx += dx0 * w0;
            gy += dy0 * w0;
            g += inv1;
            gx += dx1 * w1;
            gy += dy1 * w1;
        }
        for (&x, &y) in xs.remainder().iter().zip(ys.remainder()) {
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

    /// [`Self::sample`] at two points at once, each bit for bit as alone
    /// (its own three sums, in deployment order). The runner asks for the
    /// point one straight period ahead with it: the two positions' sums are
    /// independent chains of adds, which the one-point loop (bound by the
    /// latency of its adds) leaves the processor idle enough to run.
    #[inline]
    pub fn sample_pair(&self, p: Vec2, q: Vec2) -> (FieldSample, FieldSample) {
        let (mut g0, mut gx0, mut gy0) = (0.0, 0.0, 0.0);
        let (mut g1, mut gx1, mut gy1) = (0.0, 0.0, 0.0);
        for (&x, &y) in self.xs.iter().zip(&self.ys) {
            let (dx0, dy0) = (x - p.x, y - p.y);
            let (dx1, dy1) = (x - q.x, y - q.y);
            let (inv0, inv1) = (1.0 / (dx0 * dx0 + dy0 * dy0), 1.0 / (dx1 * dx1 + dy1 * dy1));
            let (w0, w1) = (inv0 * inv0, inv1 * inv1);
            g0 += inv0;
            gx0 += dx0 * w0;
            gy0 += dy0 * w0;
            g1 += inv1;
            gx1 += dx1 * w1;
            gy1 += dy1 * w1;
        }
        (
            FieldSample { intensity: self.c * g0, gx: gx0, gy: gy0 },
            FieldSample { intensity: self.c * g1, gx: gx1, gy: gy1 },
        )
    }

    /// The field constant c.
    pub fn field_constant(&self) -> f64 {
        self.c
    }

    /// An upper bound of the Σ 1/d² that [`Self::sample`] computes at `p`
    /// (its intensity is `c` times that sum), in a fraction of its time.
    ///
    /// A robot in mode 1 only needs to know that its sensed intensity is
    /// below the threshold, and usually it is by far: this answers that
    /// without the exact, deployment-order sum. Single precision from the
    /// positions rounded to f32 (kept at [`Self::push`]: no conversion in
    /// the pass), eight lanes (two packed `divps` per eight beacons, any
    /// order), and a rigorous margin for every rounding involved, E being
    /// the largest |coordinate| of the beacons and `p`:
    ///
    /// * each f32 difference is within 2⁻²²·E·(1 + 2⁻²⁵) of the true one
    ///   (roundings of 2⁻²⁴ of x and of p, at most E each, and of their
    ///   difference, at most 2E), so the difference vector is within
    ///   δ = 2⁻²⁰·E of the true one (1e-40 more for f32's subnormals), and
    ///   the true distance is at least d − δ for d = |computed
    ///   differences|: 1/(d − δ)² ≤ (D/(D − δ))²/d² for D ≤ d. D is taken
    ///   from the smallest d² of the pass, and without a square root:
    ///   δ/D ≤ x for the first x of 2⁻¹⁶, 2⁻¹⁴, 2⁻¹² that D² ≥ δ²/x² shows,
    ///   and the sum is scaled by 1/(1 − x)² ≥ (D/(D − δ))²; a beacon
    ///   nearer than 4096·δ (far above any threshold in the paper's
    ///   fields: 0.23 m at E = 60) takes the f64 differences instead, as
    ///   before ([`Self::disk_bound`]);
    /// * 1/d² ≤ q·(1 + 2⁻²¹) for q = fl32(1 / fl32(d²)) (three f32
    ///   roundings in d², one in the division);
    /// * the f32 sum of N positive terms is ≥ their sum·(1 − (N + 2)·2⁻²⁴);
    /// * the exact path's sum is ≤ Σ 1/d²·(1 + (N + 1)·2⁻⁵²);
    ///
    /// together at most a factor 1 + (N + 8)·2⁻²² for N < 2²⁰; the bound uses
    /// (N + 16)·2⁻²² to cover its own rounding, and the factors in f64 are
    /// rounded the safe way by 1e-9. A coordinate beyond 1e9 takes the f64
    /// differences too (d² might leave f32's range); a sum above 1e30 (a
    /// beacon closer than about 1e-15, or NaN) gives infinity: no bound,
    /// the caller sums exactly. `f32_positions_bound_the_exact_sum` checks
    /// it where δ matters, and that without δ it would fail there.
    pub fn upper_bound(&self, p: Vec2) -> f64 {
        self.disk_bound(p).upper_bound()
    }

    /// [`Self::upper_bound`] at `p`, with what it takes to bound the sum
    /// anywhere near `p` too ([`DiskBound::at`]): the same pass also keeps
    /// the smallest d² (a `minps` per four beacons).
    pub fn disk_bound(&self, p: Vec2) -> DiskBound {
        match self.disk_bound_f32(p, 1.0) {
            Some(disk) => disk,
            None => self.disk_bound_f64(p),
        }
    }

    /// [`Self::disk_bound`] from the f32 positions; `None` if a beacon is
    /// nearer than 4096·δ (or a coordinate beyond 1e9). δ is multiplied by
    /// `delta_scale` (1; the tests show that 0 would not do).
    fn disk_bound_f32(&self, p: Vec2, delta_scale: f64) -> Option<DiskBound> {
        let n = self.len();
        let none = Some(DiskBound { at: p, sum: f64::INFINITY, near2: 0.0 });
        let extent = self.extent.max(libm::fabs(p.x)).max(libm::fabs(p.y));
        // Not above 1e9 (a NaN shows in the sum).
        let in_range = extent <= 1e9 && n < 1 << 20;
        if !in_range {
            return None;
        }
        let (px, py) = (p.x as f32, p.y as f32);
        // Two blocks of four lanes (two `divps` per eight beacons); the
        // smaller of two by a compare (a NaN shows in the sum).
        let mut acc = [[0f32; 4]; 2];
        let mut near = [[f32::INFINITY; 4]; 2];
        // (Whole blocks: `push` pads them.)
        for (x, y) in self.xs32.chunks_exact(8).zip(self.ys32.chunks_exact(8)) {
            for h in 0..2 {
                let d2: [f32; 4] = core::array::from_fn(|j| {
                    let (dx, dy) = (x[4 * h + j] - px, y[4 * h + j] - py);
                    dx * dx + dy * dy
                });
                for j in 0..4 {
                    acc[h][j] += 1.0 / d2[j];
                    near[h][j] = if d2[j] < near[h][j] { d2[j] } else { near[h][j] };
                }
            }
        }
        let sum = acc.iter().flatten().fold(0.0, |a, &b| a + b);
        // Not below 1e30, or NaN.
        let finite_enough = sum < 1e30;
        if !finite_enough {
            return none;
        }
        let near = near.iter().flatten().fold(f32::INFINITY, |a, &b| if b < a { b } else { a });
        // D², rounded down (d² ≥ fl32(d²)·(1 − 2⁻²²)), and δ², up.
        let d2 = f64::from(near) * (1.0 - f64::powi(2.0, -21));
        // (1e-40 covers f32's subnormal roundings, absolute.)
        let delta = (extent * f64::powi(2.0, -20) + 1e-40) * (1.0 + 1e-9) * delta_scale;
        let delta2 = delta * delta * (1.0 + 1e-9);
        // δ/D at most 2⁻ᵏ for the first k of 16, 14, 12 that D² ≥ 2²ᵏ·δ²
        // shows (compares only: no square root, no division on the way).
        let tier = [16, 14, 12].into_iter().find(|&k| d2 >= f64::powi(2.0, 2 * k) * delta2)?;
        let x = f64::powi(2.0, -tier);
        // (D/(D − δ))² ≤ 1/(1 − x)²; (D − δ)² ≥ D²·(1 − x)².
        let scale = 1.0 / ((1.0 - x) * (1.0 - x)) * (1.0 + 1e-9);
        let nearest = d2 * ((1.0 - x) * (1.0 - x)) * (1.0 - 1e-9);
        let n = n as f64;
        Some(DiskBound {
            at: p,
            sum: (f64::from(sum) * (1.0 + (n + 16.0) * f64::powi(2.0, -22)) + n * 1e-38) * scale,
            // At most the true squared distance to the nearest beacon
            // (infinite without beacons, as `at` allows).
            near2: nearest,
        })
    }

    /// [`Self::disk_bound`] from the f64 positions: f32 lanes of the f64
    /// differences' d² (1/d² ≤ q·(1 + 2⁻²²) for q = fl32(1 / fl32(d²)), two
    /// roundings), the same margins otherwise; no δ.
    fn disk_bound_f64(&self, p: Vec2) -> DiskBound {
        let n = self.len();
        let none = DiskBound { at: p, sum: f64::INFINITY, near2: 0.0 };
        if n >= 1 << 20 {
            return none;
        }
        let mut acc = [0f32; 4];
        let mut near = [f32::INFINITY; 4];
        let mut xs = self.xs.chunks_exact(4);
        let mut ys = self.ys.chunks_exact(4);
        for (x, y) in (&mut xs).zip(&mut ys) {
            let mut d2 = [0f32; 4];
            for j in 0..4 {
                let (dx, dy) = (x[j] - p.x, y[j] - p.y);
                d2[j] = (dx * dx + dy * dy) as f32;
            }
            for j in 0..4 {
                acc[j] += 1.0 / d2[j];
                near[j] = near[j].min(d2[j]);
            }
        }
        for (&x, &y) in xs.remainder().iter().zip(ys.remainder()) {
            let (dx, dy) = (x - p.x, y - p.y);
            let d2 = (dx * dx + dy * dy) as f32;
            acc[0] += 1.0 / d2;
            near[0] = near[0].min(d2);
        }
        let sum = (acc[0] + acc[1]) + (acc[2] + acc[3]);
        // Not below 1e30, or NaN.
        let finite_enough = sum < 1e30;
        if !finite_enough {
            return none;
        }
        let near = near[0].min(near[1]).min(near[2].min(near[3]));
        let n = n as f64;
        DiskBound {
            at: p,
            sum: f64::from(sum) * (1.0 + (n + 16.0) * f64::powi(2.0, -22)) + n * 1e-38,
            // fl32(fl64(d²)) is within a factor 1 ± 2⁻²² of the true d²; a
            // d² beyond f32's range (or no beacon at all) counts as f32::MAX.
            near2: f64::from(near.min(f32::MAX)) * (1.0 - f64::powi(2.0, -20)),
        }
    }

    /// The plain one-beacon-at-a-time sum [`Self::sample`] must equal bit
    /// for bit (kept for the tests that check it).
    #[doc(hidden)]
    pub fn sample_reference(&self, p: Vec2) -> FieldSample {
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

    /// Seeded uniform numbers in [0, 1) (xorshift64).
    fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

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
    fn paired_sum_is_bit_identical_to_the_plain_loop() {
        // Odd and even counts (the pair loop and its remainder), near and far points.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 60.0
        };
        for n in 0..40 {
            let mut b = Beacons::new(1.0);
            for _ in 0..n {
                b.push(Vec2::new(next(), next()));
            }
            for _ in 0..50 {
                let p = Vec2::new(next(), next());
                let (fast, plain) = (b.sample(p), b.sample_reference(p));
                let q = Vec2::new(next(), next());
                let (pair_p, pair_q) = b.sample_pair(p, q);
                let plain_q = b.sample_reference(q);
                for (a, e) in [(pair_p, plain), (pair_q, plain_q)] {
                    assert_eq!(a.intensity.to_bits(), e.intensity.to_bits(), "{n} beacons, pair");
                    assert_eq!(a.gx.to_bits(), e.gx.to_bits(), "{n} beacons, pair");
                    assert_eq!(a.gy.to_bits(), e.gy.to_bits(), "{n} beacons, pair");
                }
                assert_eq!(fast.intensity.to_bits(), plain.intensity.to_bits(), "{n} beacons at {p:?}");
                assert_eq!(fast.gx.to_bits(), plain.gx.to_bits(), "{n} beacons at {p:?}");
                assert_eq!(fast.gy.to_bits(), plain.gy.to_bits(), "{n} beacons at {p:?}");
            }
        }
    }

    #[test]
    fn upper_bound_bounds_the_exact_sum_and_is_tight() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 60.0
        };
        for n in [0usize, 1, 2, 3, 4, 5, 7, 9, 33, 200, 1500] {
            let mut b = Beacons::new(1.0);
            for _ in 0..n {
                b.push(Vec2::new(next(), next()));
            }
            for _ in 0..200 {
                let p = Vec2::new(next(), next());
                let (exact, bound) = (b.sample(p).intensity, b.upper_bound(p));
                assert!(exact <= bound, "{n} beacons at {p:?}: {exact} > {bound}");
                assert!(bound <= exact * 1.001 + 1e-30, "{n} beacons at {p:?}: {bound} is loose for {exact}");
            }
        }
        // On a beacon: no bound.
        let mut b = Beacons::new(1.0);
        b.push(Vec2::new(1.0, 2.0));
        assert_eq!(b.upper_bound(Vec2::new(1.0, 2.0)), f64::INFINITY);
        assert_eq!(b.upper_bound(Vec2::new(f64::NAN, 2.0)), f64::INFINITY);
    }

    #[test]
    fn disk_bound_bounds_the_exact_sum_around_its_point() {
        let mut next = uniform(0x0bad_5eed_1234_5678u64);
        let (mut inside, mut outside) = (0usize, 0usize);
        for n in [0usize, 1, 2, 5, 9, 100, 1000] {
            let mut b = Beacons::new(1.0);
            for _ in 0..n {
                b.push(Vec2::new(60.0 * next(), 60.0 * next()));
            }
            for _ in 0..300 {
                let p0 = Vec2::new(60.0 * next(), 60.0 * next());
                let disk = b.disk_bound(p0);
                assert!(disk.is_at(p0));
                assert_eq!(disk.upper_bound().to_bits(), b.upper_bound(p0).to_bits());
                assert!(disk.at(p0) >= b.sample(p0).intensity);
                let nearest = b.positions().map(|q| q.distance(p0)).fold(f64::INFINITY, f64::min);
                for _ in 0..20 {
                    // Steps up to the nearest beacon and beyond, the robot's 0.1 included.
                    let (r, a) = (
                        [0.1, 0.3 * nearest, 0.98 * nearest, 1.5 * nearest][(4.0 * next()) as usize],
                        7.0 * next(),
                    );
                    let p = Vec2::new(p0.x + r * libm::cos(a), p0.y + r * libm::sin(a));
                    let (exact, bound) = (b.sample(p).intensity, disk.at(p));
                    assert!(exact <= bound, "{n} beacons, {p0:?} to {p:?}: {exact} > {bound}");
                    if bound.is_finite() {
                        inside += 1;
                    } else {
                        assert!(r > 0.98 * nearest, "{n} beacons, {p0:?} to {p:?}: no bound");
                        outside += 1;
                    }
                }
            }
        }
        assert!(inside > 20_000 && outside > 5_000, "{inside} inside, {outside} outside");
        // On a beacon: no bound anywhere.
        let mut b = Beacons::new(1.0);
        b.push(Vec2::new(1.0, 2.0));
        assert_eq!(b.disk_bound(Vec2::new(1.0, 2.0)).at(Vec2::new(1.0, 2.0)), f64::INFINITY);
    }

    /// Where δ (the f32 positions' rounding) matters: coordinates up to
    /// 1e5 (δ about 0.1), beacons and points a few hundred to a few
    /// thousand δ apart, so that every tier and the f64 fallback are taken.
    #[test]
    fn f32_positions_bound_the_exact_sum() {
        let mut next = uniform(0x1357_9bdf_2468_ace0u64);
        let (mut f32_pass, mut fallback, mut fails_without_delta) = (0usize, 0usize, 0usize);
        for case in 0..400 {
            let (offset, spread) = ([1e2, 1e4, 1e5][case % 3], [30.0, 3e3, 3e4][case / 3 % 3]);
            let mut b = Beacons::new(1.0);
            for _ in 0..[1usize, 7, 40][case % 3] {
                b.push(Vec2::new(offset + spread * next(), offset - spread * next()));
            }
            let extent = b.extent.max(offset + spread);
            let delta = extent * f64::powi(2.0, -20);
            for _ in 0..30 {
                // Next to a beacon, 100 to 1e6 δ away, or anywhere.
                let q = b.positions().nth((next() * b.len() as f64) as usize).unwrap();
                let (r, a) = (delta * libm::pow(10.0, 2.0 + 4.0 * next()), 7.0 * next());
                let p = if next() < 0.8 {
                    Vec2::new(q.x + r * libm::cos(a), q.y + r * libm::sin(a))
                } else {
                    Vec2::new(offset + spread * next(), offset - spread * next())
                };
                let exact = b.sample(p).intensity;
                let disk = b.disk_bound(p);
                assert!(
                    exact <= disk.upper_bound(),
                    "case {case} at {p:?}: {exact} > {}",
                    disk.upper_bound()
                );
                for _ in 0..5 {
                    let (r, a) = (r * next(), 7.0 * next());
                    let p2 = Vec2::new(p.x + r * libm::cos(a), p.y + r * libm::sin(a));
                    let exact = b.sample(p2).intensity;
                    assert!(exact <= disk.at(p2), "case {case}, {p:?} to {p2:?}: {exact} > {}", disk.at(p2));
                }
                match b.disk_bound_f32(p, 1.0) {
                    Some(_) => f32_pass += 1,
                    None => fallback += 1,
                }
                if b.disk_bound_f32(p, 0.0).is_some_and(|d| d.upper_bound() < exact) {
                    fails_without_delta += 1;
                }
            }
        }
        assert!(f32_pass > 2000 && fallback > 1000, "{f32_pass} f32 passes, {fallback} fallbacks");
        assert!(fails_without_delta > 100, "without δ only {fails_without_delta} bounds below the sum");
    }

    #[test]
    fn no_sources_no_field() {
        let s = Beacons::new(1.0).sample(Vec2::new(1.0, 1.0));
        assert_eq!(s.intensity, 0.0);
        assert_eq!(s.direction(), 0.0);
    }
}
