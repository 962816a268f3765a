//! Mode 2's periods at a fixed position with sensing noise, decided from
//! the drawn direction offset and the heading index alone.
//!
//! Why: in the study's noisy half nearly every period is a mode-2 turn in
//! place. The controller's chain — the sensed direction's `wrap`, θfg, the
//! tangent's side, the heading error's `wrap`, the motion — branches on the
//! drawn offset o several times per period, and the processor mispredicts
//! those branches (the tangent's side and θfg were a fifth of the study's
//! samples). At a fixed position the gradient direction φd and the goal
//! bearing φg are fixed, so the period's decision depends on o and on the
//! heading index k only, through the true angles (mod 2π)
//!
//! * d = φd + o − φg (θfg = |d|; its sign picks the tangent φf ∓ π/2),
//! * e = φd + o ∓ π/2 − θ_k (the heading error: straight if |e| ≤ tol,
//!   else a turn towards its sign),
//! * and the exit rule, |θ_k − φg| < π/2 and |d| > π/2.
//!
//! The controller's floats are within 1e-14 rad of these true values (a
//! few roundings of angles below 4π, as [`crate::robot::MotionCones`]
//! argues), and so are the ones computed here; the headings of the table
//! are checked at construction to lie within 1e-12 rad of θ0 + k·2π/n
//! ([`TurnGeometry::new`]). Whenever every true value is at least
//! [`MARGIN`] (1e-8 rad) from every boundary of the decision (d at 0, ±π/2
//! and ±π, which also keeps clear of the controller's 1e-9 rad tie zone;
//! e at ±tol and ±π; |θ_k − φg| at π/2), both sides take the same branch
//! everywhere, so they decide the same motion; anything closer, and any
//! period where the robot would leave mode 2, goes to the controller.
//!
//! The decision itself is arithmetic without data-dependent branches:
//! in units of the turn step δ = 2π/n, e/δ ≡ X − k (mod n) with X = (φd ∓
//! π/2 − θ0 + o)/δ, so the straight headings are the whole numbers in
//! [X − T, X + T] (T = tol/δ) and the clockwise ones follow up to the flip
//! at X + n/2 — three roundings per period, none of them on the chain from
//! one period's heading to the next.

use crate::body::HeadingTable;
use bycoms_agent::angle::wrap;
use bycoms_agent::Motion;
use core::f64::consts::{FRAC_PI_2, PI, TAU};

/// Smallest distance, rad, of a true angle from a boundary of the decision
/// that [`NoisyBypass::decide`] trusts (rounding is below 1e-11 rad).
pub const MARGIN: f64 = 1e-8;

/// Largest distance, rad, of a table heading from θ0 + k·2π/n for which
/// the arithmetic in turn steps holds.
const TABLE_SLACK: f64 = 1e-12;

/// 1.5 · 2^52: adding and subtracting it rounds an f64 below 2^51 in
/// magnitude to the nearest whole number (ties to even), without a branch.
const ROUND: f64 = 6_755_399_441_055_744.0;

#[inline]
fn nearest(x: f64) -> f64 {
    (x + ROUND) - ROUND
}

/// A heading table's geometry in turn steps, shared by every position.
#[derive(Clone, Copy, Debug)]
pub struct TurnGeometry {
    n: i32,
    theta0: f64,
    /// 1/δ = n/2π.
    per_rad: f64,
    /// 1/n.
    per_turn: f64,
    /// T = tol/δ.
    tol: f64,
    /// [`MARGIN`] in turn steps.
    margin: f64,
}

impl TurnGeometry {
    /// The geometry of `table` with straight tolerance `tol`, if its
    /// headings are θ0 + k·2π/n within [`TABLE_SLACK`] and 0 < tol < π/4.
    pub fn new(table: &HeadingTable, tol: f64) -> Option<Self> {
        let n = table.len();
        let usable = (8..=1 << 20).contains(&n) && tol > 0.0 && tol < PI / 4.0;
        if !usable {
            return None;
        }
        let theta0 = table.heading(0);
        let step = TAU / f64::from(n);
        let regular = (0..n).all(|k| {
            let ideal = theta0 + f64::from(k) * step;
            libm::fabs(wrap(table.heading(k) - ideal)) <= TABLE_SLACK
        });
        let per_rad = f64::from(n) / TAU;
        (regular && theta0.is_finite()).then_some(Self {
            n: n as i32,
            theta0,
            per_rad,
            per_turn: 1.0 / f64::from(n),
            tol: tol * per_rad,
            margin: MARGIN * per_rad,
        })
    }

    /// `rad` − θ0 in turn steps, reduced by whole turns to about [0, n]
    /// (within a rounding, which the uses allow for).
    #[inline]
    fn steps_from_theta0(&self, rad: f64) -> f64 {
        let x = (rad - self.theta0) * self.per_rad;
        x - f64::from(self.n) * nearest(x * self.per_turn - 0.5)
    }

    /// Whether `x` (turn steps) is within the margin of a whole number.
    #[inline]
    fn near_whole(&self, x: f64) -> bool {
        libm::fabs(x - nearest(x)) < self.margin
    }

    /// The decision at a position with gradient direction `fd` and goal
    /// bearing `fg` (the unperturbed values the controller's inputs come
    /// from), or `None` if a heading lies within the margin of the exit
    /// rule's boundary |θ_k − φg| = π/2.
    pub fn at(&self, fd: f64, fg: f64) -> Option<NoisyBypass> {
        if !(fd.is_finite() && fg.is_finite()) {
            return None;
        }
        let n = f64::from(self.n);
        let g = self.steps_from_theta0(fg);
        let quarter = n / 4.0;
        if self.near_whole(g - quarter) || self.near_whole(g + quarter) {
            return None;
        }
        // Clear of whole numbers by the margin: ceil and floor by rounding.
        let exit_lo = nearest(g - quarter + 0.5);
        let exit_width = (nearest(g + quarter - 0.5) - exit_lo) as i32;
        // g is within a rounding of [0, n]: exit_lo lies in (−n, 2n).
        let exit_lo = wrap_index(exit_lo as i32, self.n);
        Some(NoisyBypass {
            geometry: *self,
            d0: wrap(fd - fg),
            x_cw: self.steps_from_theta0(fd - FRAC_PI_2),
            x_ccw: self.steps_from_theta0(fd + FRAC_PI_2),
            exit_lo,
            exit_width,
        })
    }
}

/// Mode 2's decision at one position (see the module's docs).
#[derive(Clone, Copy, Debug)]
pub struct NoisyBypass {
    geometry: TurnGeometry,
    /// wrap(φd − φg): d = d0 + o (mod 2π).
    d0: f64,
    /// X at o = 0 for d > 0 (tangent φf − π/2) and d < 0 (φf + π/2).
    x_cw: f64,
    x_ccw: f64,
    /// Headings k with |θ_k − φg| < π/2: (k − exit_lo) mod n ≤ exit_width.
    exit_lo: i32,
    exit_width: i32,
}

impl NoisyBypass {
    /// The motion of a mode-2 period at heading `k` with direction offset
    /// `offset`, after which the controller is still in mode 2, and the
    /// heading index after it; `None` when the controller must decide (near
    /// a boundary, or it leaves mode 2).
    #[inline]
    pub fn decide(&self, offset: f64, k: u32) -> Option<(Motion, u32)> {
        let geo = &self.geometry;
        let n = geo.n;
        let s = self.d0 + offset;
        let d = s - TAU * f64::from(u8::from(s > PI)) + TAU * f64::from(u8::from(s <= -PI));
        let theta_fg = libm::fabs(d);
        let x = if d < 0.0 { self.x_ccw } else { self.x_cw } + offset * geo.per_rad;
        let (lo_v, hi_v, flip_v) = (x - geo.tol, x + geo.tol, x + f64::from(n) * 0.5);
        let near = (theta_fg < MARGIN)
            | (libm::fabs(theta_fg - FRAC_PI_2) < MARGIN)
            | (theta_fg > PI - MARGIN)
            | !(-PI..=PI).contains(&offset)
            | geo.near_whole(lo_v)
            | geo.near_whole(hi_v)
            | geo.near_whole(flip_v);
        let k = k as i32;
        let to_exit = wrap_index(k - self.exit_lo, n) <= self.exit_width;
        if near | ((theta_fg > FRAC_PI_2) & to_exit) {
            return None;
        }
        // The straight headings are lo ..= hi, the clockwise ones follow up
        // to lo + flip (exclusive), the counter-clockwise ones the rest.
        let lo = nearest(lo_v + 0.5);
        let width = nearest(hi_v - 0.5) - lo;
        let flip = nearest(flip_v + 0.5) - lo;
        let u = f64::from(wrap_index(k - wrap_index(lo as i32, n), n));
        // −1 (clockwise), 0 (straight) or +1, without a branch.
        let turn = i32::from(u > width) * (1 - 2 * i32::from(u < flip));
        const MOTIONS: [Motion; 3] = [Motion::TurnCw, Motion::Straight, Motion::TurnCcw];
        Some((MOTIONS[(turn + 1) as usize], wrap_index(k + turn, n) as u32))
    }
}

/// `i` mod `n` for −n ≤ i < 2n, without a branch.
#[inline]
fn wrap_index(i: i32, n: i32) -> i32 {
    i + n * i32::from(i < 0) - n * i32::from(i >= n)
}
