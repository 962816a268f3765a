//! One simulated robot: body + the shared controller + its noise source.
//!
//! This is the single place where a simulated robot senses and acts, used
//! both by the in-process runner and by the `sim-agent` process, so the two
//! cannot drift apart. Sensing is physical: the field of the other robots at
//! the body's position (plus noise) and the goal bearing handed in from
//! outside (computed by the runner, or by the orchestrator from mocap). The
//! terrain is never an input here.

use crate::body::{Body, HeadingTable};
use crate::bypass::{NoisyBypass, TurnGeometry};
use crate::field::{Beacons, DiskBound, FieldSample};
use crate::sensing::SensingNoise;
use crate::Vec2;
use bycoms_agent::angle::wrap;
use bycoms_agent::point::{choose_motion, tangent_towards};
use bycoms_agent::{Controller, ControllerConfig, FieldGoal, Input, Mode, Motion, Output};
use core::f64::consts::{FRAC_PI_2, TAU};

/// A simulated robot between deployment and stop.
#[derive(Clone, Debug)]
pub struct SimRobot {
    pub body: Body,
    controller: Controller,
    noise: Option<SensingNoise>,
    dt: f64,
}

impl SimRobot {
    /// A robot placed at `start`, facing the table's initial heading, in mode 1.
    pub fn new(start: Vec2, config: ControllerConfig, noise: Option<SensingNoise>, dt: f64) -> Self {
        Self { body: Body::new(start), controller: Controller::new(config), noise, dt }
    }

    pub fn mode(&self) -> Mode {
        self.controller.mode()
    }

    /// One control period: sense the field of `beacons`, decide, move.
    #[inline]
    pub fn step(&mut self, table: &HeadingTable, beacons: &Beacons, goal_bearing: f64) -> Output {
        let (factor, offset) = match &mut self.noise {
            Some(n) => n.draw(),
            None => (1.0, 0.0),
        };
        let sample = beacons.sample(self.body.pos);
        let intensity = sample.intensity * factor;
        // In mode 1 below threshold the controller never looks at the
        // gradient direction (the 1→2 rule needs g ≥ g_th first), so its
        // atan2 is skipped; the decision is identical either way.
        let needs_direction =
            self.controller.mode() == Mode::Bypass || intensity >= self.controller.config().g_th;
        let field_direction = if needs_direction { wrap(sample.direction() + offset) } else { 0.0 };
        let input = Input {
            goal_bearing,
            field_intensity: intensity,
            field_direction,
            heading: self.body.heading(table),
            dt: self.dt,
        };
        let out = self.controller.step(&input);
        self.body.apply(out.motion, table);
        out
    }
}

/// For every heading θ_k of a [`HeadingTable`], the unit vectors at
/// θ_k − tol, θ_k and θ_k + tol (tol: the controller's straight tolerance).
///
/// In mode 1 below threshold the controller's whole decision is where the
/// goal bearing φg lies relative to θ_k: within ±tol (straight), beyond
/// +tol (turn counter-clockwise) or beyond −tol (clockwise). Three cross
/// products with these vectors tell that from the goal vector itself, with
/// no `atan2` — whenever the goal vector is at least 1e-9 rad from every
/// boundary (±tol, 0, π). The controller's float φg − θ_k is within a few
/// 1e-15 rad of the true angle (atan2 and two roundings), so such a margin
/// cannot change its decision; anything closer goes to the exact path.
///
/// It also keeps the table's [`TurnGeometry`], with which a [`Deployment`]
/// decides mode 2's noisy turns in place ([`crate::bypass`]).
#[derive(Clone, Debug)]
pub struct MotionCones {
    lo: Vec<(f64, f64)>,
    mid: Vec<(f64, f64)>,
    hi: Vec<(f64, f64)>,
    turns: Option<TurnGeometry>,
}

/// Smallest |sin| of the angle to a boundary (relative to |v|₁ ≥ |v|₂) the
/// cheap decision trusts; rounding is six orders of magnitude smaller.
const CONE_MARGIN: f64 = 1e-9;

impl MotionCones {
    pub fn new(table: &HeadingTable, tolerance: f64) -> Self {
        let unit = |a: f64| (libm::cos(a), libm::sin(a));
        let heading = |k: u32| table.heading(k);
        Self {
            lo: (0..table.len()).map(|k| unit(heading(k) - tolerance)).collect(),
            mid: (0..table.len()).map(|k| unit(heading(k))).collect(),
            hi: (0..table.len()).map(|k| unit(heading(k) + tolerance)).collect(),
            turns: TurnGeometry::new(table, tolerance),
        }
    }

    /// The mode-1 motion for heading `k` and goal vector (vx, vy), if it is
    /// certain without the bearing; `None` near a boundary.
    #[inline]
    pub fn decide(&self, k: u32, vx: f64, vy: f64) -> Option<Motion> {
        let k = k as usize;
        let m = CONE_MARGIN * (libm::fabs(vx) + libm::fabs(vy));
        let cross = |(ux, uy): (f64, f64)| ux * vy - uy * vx;
        let (s_lo, s_hi) = (cross(self.lo[k]), cross(self.hi[k]));
        // φ − θ ∈ (−tol, tol): v is counter-clockwise of θ−tol and clockwise of θ+tol.
        if s_lo > m && s_hi < -m {
            return Some(Motion::Straight);
        }
        let s_mid = cross(self.mid[k]);
        if s_mid > m && s_hi > m {
            // φ − θ ∈ (tol, π)
            Some(Motion::TurnCcw)
        } else if s_mid < -m && s_lo < -m {
            // φ − θ ∈ (−π, −tol)
            Some(Motion::TurnCw)
        } else {
            None
        }
    }
}

/// One robot's deployment in the sequential runner: the beacons and the
/// goal stay fixed while it moves (borrowed, so they cannot change under it).
///
/// Each period does exactly what [`SimRobot::step`] does with the goal
/// bearing `pos.bearing_to(goal)`, with less work:
///
/// * turning in place leaves the position, hence the field sample, the goal
///   bearing and the gradient direction, unchanged: they are kept from the
///   previous period (noise is still drawn every period and applied anew);
/// * in mode 1 the exact, deployment-order field sum is skipped when an
///   upper bound already shows the intensity below threshold (the
///   controller then ignores the field): the last [`DiskBound`], which
///   holds around the point it was computed at, else a new one computed
///   here (one f32 pass, [`Beacons::disk_bound`]). Far from the beacons a
///   straight run needs a pass only every few periods; near the threshold
///   the bound still settles most periods, for a fraction of an exact sum;
/// * in mode 1 below threshold the motion comes from [`MotionCones`]
///   without computing the bearing (no `atan2`), the controller's state
///   being unchanged by such a period (it stays in mode 1);
/// * an exact sample is computed together with the one a straight period
///   ahead ([`Beacons::sample_pair`], each bit for bit as alone), kept for
///   when the robot gets there: on its heading, or in mode 2 without noise
///   on the heading it probably turns to ([`Self::ahead_heading`]);
/// * the bearing and the direction are computed only when the controller
///   needs them, with the same `libm` calls as `SimRobot::step`.
/// * with noise, once a mode-2 turn was decided at a position, the next
///   periods there are decided from the drawn offset and the heading index
///   by [`NoisyBypass`] (the same motion as the controller's, proven away
///   from the boundaries; the controller decides the rest). The noise is
///   drawn once per period either way, so the stream stays the robot's.
///
/// `sim-agent/tests/deployment.rs` checks it against `SimRobot::step` bit
/// for bit; the study's `runs.csv` is byte-identical to the plain loop's.
pub struct Deployment<'a> {
    pub robot: SimRobot,
    table: &'a HeadingTable,
    cones: &'a MotionCones,
    beacons: &'a Beacons,
    goal: Vec2,
    /// Position the cached values belong to (`None`: nothing cached yet).
    at: Option<Vec2>,
    /// The exact field sample there, once computed.
    sample: Option<FieldSample>,
    /// Upper bounds of the exact sum, there and around.
    bounds: Bounds,
    bearing: Option<f64>,
    direction: Option<f64>,
    /// The exact sample one straight period ahead, computed with the last
    /// exact one ([`Beacons::sample_pair`]): used if the robot goes there.
    ahead: Option<(Vec2, FieldSample)>,
    /// The controller's values of the sensed field direction and the goal
    /// bearing (kept while both stay the same: turns without noise).
    field_goal: FieldGoal,
    /// Turns in place already known to follow, each the same as the last
    /// period's (without noise: [`Self::same_turns`]).
    pending: u32,
    /// The turn they repeat.
    turn: Motion,
    /// Mode 2's decision at this position with noise, once a mode-2 turn
    /// was decided here ([`crate::bypass`]); `None` after a move.
    bypass: Option<NoisyBypass>,
    /// The gradient direction and goal bearing of the last two positions
    /// at which the controller decided in mode 2, the last one first (for
    /// [`Self::ahead_heading`]).
    fields: [Option<(f64, f64)>; 2],
    /// Where the robot would have gone from the last mode-2 position with
    /// a guess, straight on and as guessed, to score the guess when it
    /// gets to a new position: +1 when only the guess was right, −1 when
    /// only straight on was, kept within ±8; the guess is taken while the
    /// score is not negative (straight on was better in the study).
    guess: (Option<(Vec2, Vec2)>, i32),
}

/// Fewest beacons for which [`Deployment::ahead_heading`] is worth its
/// time: with fewer, an exact sample costs little more than the guess
/// (the study's noiseless half, with a few dozen, took 6 % longer with it).
const GUESS_BEACONS: usize = 64;

/// A [`Deployment`]'s upper bounds of the exact field sum.
struct Bounds {
    /// At the current position, once known.
    here: Option<f64>,
    /// The last [`Beacons::disk_bound`]: it bounds the sum near where it
    /// was computed too.
    disk: Option<DiskBound>,
}

impl Bounds {
    /// Whether an upper bound of the exact sum at `p` passes `below`: the
    /// one already known here, else the last disk's, else a new disk's
    /// computed here.
    #[inline]
    fn below(&mut self, beacons: &Beacons, p: Vec2, below: impl Fn(f64) -> bool) -> bool {
        let known = match (self.here, self.disk) {
            (Some(b), _) => Some(b),
            (None, Some(disk)) => Some(*self.here.insert(disk.at(p))),
            (None, None) => None,
        };
        if known.is_some_and(&below) {
            return true;
        }
        if self.disk.is_some_and(|d| d.is_at(p)) {
            // The bound here is already the tightest one.
            return false;
        }
        let disk = beacons.disk_bound(p);
        self.disk = Some(disk);
        below(*self.here.insert(disk.upper_bound()))
    }
}

impl<'a> Deployment<'a> {
    pub fn new(
        robot: SimRobot,
        table: &'a HeadingTable,
        cones: &'a MotionCones,
        beacons: &'a Beacons,
        goal: Vec2,
    ) -> Self {
        Self {
            robot,
            table,
            cones,
            beacons,
            goal,
            at: None,
            sample: None,
            bounds: Bounds { here: None, disk: None },
            bearing: None,
            direction: None,
            ahead: None,
            field_goal: FieldGoal::default(),
            pending: 0,
            turn: Motion::Straight,
            bypass: None,
            fields: [None; 2],
            guess: (None, 0),
        }
    }

    /// One control period; returns the motion performed.
    #[inline]
    pub fn step(&mut self) -> Motion {
        if self.pending > 0 {
            // A turn proven the same as the last period's (`same_turns`).
            self.pending -= 1;
            self.robot.body.apply(self.turn, self.table);
            return self.turn;
        }
        let Some(noise) = self.robot.noise.as_mut() else {
            return self.noiseless_step();
        };
        let (factor, offset) = noise.draw();
        if let Some((motion, k)) = self.bypass.and_then(|b| b.decide(offset, self.robot.body.k)) {
            if motion == Motion::Straight {
                self.bypass = None;
                self.robot.body.apply(motion, self.table);
            } else {
                self.robot.body.k = k;
            }
            return motion;
        }
        let (motion, _, _) = self.decide(factor, offset);
        self.bypass = match (motion, self.robot.mode(), self.direction, self.bearing) {
            (Motion::Straight, ..) | (_, Mode::Goal, ..) => None,
            (_, Mode::Bypass, Some(fd), Some(fg)) => {
                self.bypass.or_else(|| self.cones.turns.and_then(|t| t.at(fd, fg)))
            }
            _ => None,
        };
        motion
    }

    /// [`Self::step`] without noise: the turns known to follow are found.
    #[inline]
    fn noiseless_step(&mut self) -> Motion {
        let (motion, target, exit_possible) = self.decide(1.0, 0.0);
        if motion != Motion::Straight && !exit_possible {
            let p = self.robot.body.pos;
            let target =
                target.unwrap_or_else(|| *self.bearing.get_or_insert_with(|| p.bearing_to(self.goal)));
            self.turn = motion;
            self.pending = self.same_turns(target, motion);
        }
        motion
    }

    /// Performs up to `max` of the turns that surely follow (those
    /// [`Self::step`] would replay one by one) at once; returns how many.
    #[inline]
    pub fn skip_known_turns(&mut self, max: u64) -> u32 {
        if self.pending == 0 {
            // With noise always: no division on the heading's chain.
            return 0;
        }
        let j = u64::from(self.pending).min(max) as u32;
        let n = self.table.len();
        let k = self.robot.body.k;
        self.robot.body.k = match self.turn {
            Motion::TurnCcw => (k + j % n) % n,
            _ => (k + n - j % n) % n,
        };
        self.pending -= j;
        j
    }

    /// One period as [`SimRobot::step`] does it: the motion, the target
    /// heading it turned towards (`None`: the goal bearing, not computed)
    /// and whether the next period's mode could change with the heading
    /// alone (mode 2 with the field behind: θfg > π/2).
    #[inline(always)]
    fn decide(&mut self, factor: f64, offset: f64) -> (Motion, Option<f64>, bool) {
        let p = self.robot.body.pos;
        self.arrive(p);
        let config = *self.robot.controller.config();
        let heading = self.robot.body.heading(self.table);
        let beacons = self.beacons;
        let mode1 = self.robot.controller.mode() == Mode::Goal;
        // Mode 1 surely below threshold, from the bound alone: the sensed
        // intensity fl(fl(c·g)·factor) is monotone in g for c, factor > 0.
        let c = beacons.field_constant();
        let surely_below = mode1
            && self.sample.is_none()
            && c > 0.0
            && factor > 0.0
            && self.bounds.below(beacons, p, |bound| c * bound * factor < config.g_th);
        let (below, intensity) = if surely_below {
            (true, 0.0)
        } else {
            let sample = self.exact_sample(p, mode1, &config);
            let intensity = sample.intensity * factor;
            // Exactly the negation of the controller's `intensity >= g_th` (NaN included).
            let reaches = intensity >= config.g_th;
            (mode1 && !reaches, intensity)
        };
        let r = &mut self.robot;
        if below {
            // Mode 1 stays mode 1 and the target is the goal bearing.
            let cheap = match self.bearing {
                Some(_) => None,
                None => self.cones.decide(r.body.k, self.goal.x - p.x, self.goal.y - p.y),
            };
            let motion = cheap.unwrap_or_else(|| {
                let bearing = *self.bearing.get_or_insert_with(|| p.bearing_to(self.goal));
                choose_motion(wrap(bearing - heading), config.straight_tolerance)
            });
            r.body.apply(motion, self.table);
            return (motion, self.bearing, false);
        }
        let bearing = *self.bearing.get_or_insert_with(|| p.bearing_to(self.goal));
        let sample = self.sample.expect("computed above when not surely below");
        let direction = *self.direction.get_or_insert_with(|| sample.direction());
        let input = Input {
            goal_bearing: bearing,
            field_intensity: intensity,
            field_direction: wrap(direction + offset),
            heading,
            dt: r.dt,
        };
        let out = r.controller.step_cached(&input, &mut self.field_goal);
        let guessing = r.noise.is_none() && beacons.len() >= GUESS_BEACONS;
        if out.mode == Mode::Bypass && guessing && self.fields[0] != Some((direction, bearing)) {
            self.fields = [Some((direction, bearing)), self.fields[0]];
        }
        r.body.apply(out.motion, self.table);
        // The controller's θfg (`FieldGoal`): the same two angles, the same bits.
        let exit_possible =
            out.mode == Mode::Bypass && libm::fabs(wrap(input.field_direction - bearing)) > FRAC_PI_2;
        (out.motion, Some(out.target), exit_possible)
    }

    /// The robot is at `p`: if that is a new position, what was kept for
    /// the last one goes (but the sample one step ahead, if it is `p`'s),
    /// and the guess of where it would be is scored.
    #[inline(always)]
    fn arrive(&mut self, p: Vec2) {
        let same = self.at.is_some_and(|a| a.x.to_bits() == p.x.to_bits() && a.y.to_bits() == p.y.to_bits());
        if same {
            return;
        }
        if let Some((straight, guessed)) = self.guess.0.take() {
            let hit = |q: Vec2| i32::from(q.x.to_bits() == p.x.to_bits() && q.y.to_bits() == p.y.to_bits());
            self.guess.1 = (self.guess.1 + hit(guessed) - hit(straight)).clamp(-8, 8);
        }
        self.at = Some(p);
        self.sample = match self.ahead.take() {
            Some((q, s)) if q.x.to_bits() == p.x.to_bits() && q.y.to_bits() == p.y.to_bits() => Some(s),
            _ => None,
        };
        self.bounds.here = None;
        self.bearing = None;
        self.direction = None;
    }

    /// The exact sample at `p`, computed with the one a step ahead (kept
    /// for the next position): straight on in mode 1 and with noise; in
    /// mode 2 without noise, among many beacons, where the robot probably
    /// turns to, while that guess does better than straight on.
    #[inline(always)]
    fn exact_sample(&mut self, p: Vec2, mode1: bool, config: &ControllerConfig) -> FieldSample {
        if let Some(s) = self.sample {
            return s;
        }
        let k = self.robot.body.k;
        let mut q = self.table.advance(p, k);
        if !mode1 && self.robot.noise.is_none() && self.beacons.len() >= GUESS_BEACONS {
            let turned = Self::ahead_heading(self.table, config, self.fields, k);
            if turned != k {
                let guessed = self.table.advance(p, turned);
                self.guess.0 = Some((q, guessed));
                if self.guess.1 >= 0 {
                    q = guessed;
                }
            }
        }
        let (s, ahead) = self.beacons.sample_pair(p, q);
        self.ahead = Some((q, ahead));
        *self.sample.insert(s)
    }

    /// The heading a mode-2 robot at a new position probably leaves it
    /// with, for the exact sample one step ahead ([`Beacons::sample_pair`]):
    /// the one it turns to, without noise, for the gradient direction of
    /// the last two mode-2 positions (`fields`, the last first) extrapolated
    /// by one step, and the last goal bearing. The robot in mode 2 walks a
    /// step and often turns a step or two (the direction drifts past the
    /// tolerance): straight on, the sample ahead went unused three times
    /// in four in the bench; a wrong guess costs no more than that, and no
    /// bits (a sample is used only at its exact position). Not with noise:
    /// its heading wanders around the tangent at random, and straight on
    /// was the better guess there (the study's noisy half took 10 % more
    /// CPU time with this one); nor with few beacons ([`GUESS_BEACONS`]).
    fn ahead_heading(
        table: &HeadingTable,
        config: &ControllerConfig,
        fields: [Option<(f64, f64)>; 2],
        k: u32,
    ) -> u32 {
        let Some((fd, fg)) = fields[0] else {
            return k;
        };
        let fd = match fields[1] {
            Some((before, _)) => fd + wrap(fd - before),
            None => fd,
        };
        let error = wrap(tangent_towards(fd, fg) - table.heading(k));
        let n = table.len();
        // The first heading within the tolerance, turning towards the target.
        let turns = ((libm::fabs(error) - config.straight_tolerance) / (TAU / f64::from(n))).ceil();
        // Within the tolerance already (or NaN): straight on.
        let turning = turns > 0.0;
        if !turning {
            return k;
        }
        let turns = (turns as u32).min(n / 2);
        if error > 0.0 {
            (k + turns) % n
        } else {
            (k + n - turns) % n
        }
    }

    /// How many of the next periods, without noise and at this position,
    /// surely repeat the last one's turn `motion` towards `target`.
    ///
    /// Nothing the controller reads changes while the robot turns in place
    /// without noise but its heading: the mode stays (mode 1's rule reads
    /// the field and the goal alone, and gave mode 1 with these very values;
    /// mode 2's exit reads the heading, so the caller asks only when θfg ≤ π/2,
    /// where it cannot fire), and so does the target. The motion is then
    /// `choose_motion(wrap(target − θ_k), tol)` for the next headings θ_k,
    /// whose true angle to the target falls (or rises) by the turn step δ
    /// each period, from within the turn's side of ±tol towards tol, never
    /// near ±π; the floats are within 1e-14 rad of the true values, so at
    /// most one of them (the one at tol) can differ from its true side and
    /// the turns are a run of periods followed by none: its end is found by
    /// evaluating the exact decision around the estimate (e − tol)/δ.
    fn same_turns(&self, target: f64, motion: Motion) -> u32 {
        let table = self.table;
        let n = table.len();
        let tol = self.robot.controller.config().straight_tolerance;
        let k = self.robot.body.k;
        let heading = |i: u32| match motion {
            Motion::TurnCcw => table.heading((k + i) % n),
            _ => table.heading((k + n - i % n) % n),
        };
        let same = |i: u32| choose_motion(wrap(target - heading(i)), tol) == motion;
        let e = libm::fabs(wrap(target - heading(0)));
        if !e.is_finite() || !(0.0..core::f64::consts::PI).contains(&tol) {
            return 0;
        }
        let estimate = (e - tol) / (TAU / f64::from(n));
        let mut i = (estimate.max(0.0) as u32).min(n / 2);
        while i > 0 && !same(i - 1) {
            i -= 1;
        }
        while i < n / 2 && same(i) {
            i += 1;
        }
        i
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::Kinematics;
    use bycoms_agent::angle::between;
    use core::f64::consts::PI;
    use rand::{Rng, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// Among 100 beacons without noise the guessed samples ahead are taken
    /// and used, and the deployment still follows `SimRobot::step` bit for
    /// bit (state and mode after every period).
    #[test]
    fn guessed_samples_ahead_are_used_bit_for_bit() {
        let kin = Kinematics::paper();
        let (start, goal) = (Vec2::new(15.5, 15.5), Vec2::new(44.5, 44.5));
        let table = HeadingTable::new(&kin, start.bearing_to(goal)).unwrap();
        let config = ControllerConfig::paper(1.0);
        let cones = MotionCones::new(&table, config.straight_tolerance);
        let (mut used, mut periods) = (0usize, 0usize);
        for case in 0..12u64 {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(200 + case);
            let mut beacons = Beacons::new(1.0);
            for _ in 0..[64, 100, 150][case as usize % 3] {
                beacons.push(Vec2::new(rng.gen_range(0.0..60.0), rng.gen_range(0.0..60.0)));
            }
            let mut plain = SimRobot::new(start, config, None, kin.dt);
            let mut d =
                Deployment::new(SimRobot::new(start, config, None, kin.dt), &table, &cones, &beacons, goal);
            for period in 0..5000 {
                let guessed = match (d.guess.0, d.ahead) {
                    (Some((_, g)), Some((q, _))) if q == g => Some(g),
                    _ => None,
                };
                let out = plain.step(&table, &beacons, plain.body.pos.bearing_to(goal));
                let motion = d.step();
                assert_eq!(motion, out.motion, "case {case} period {period}");
                assert_eq!(d.robot.body.state(), plain.body.state(), "case {case} period {period}");
                assert_eq!(d.robot.mode(), plain.mode(), "case {case} period {period}");
                used += usize::from(motion == Motion::Straight && guessed == Some(d.robot.body.pos));
                periods += 1;
            }
        }
        assert!(used > 150, "{used} guessed samples used in {periods} periods");
    }

    /// The guessed heading is the one the controller, in mode 2 without
    /// noise at the (extrapolated) direction, turns to before it goes
    /// straight — away from the ties where either may round the other way.
    #[test]
    fn ahead_heading_is_where_mode_two_turns_to() {
        let kin = Kinematics::paper();
        let config = ControllerConfig::paper(1.0);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(35);
        let (mut turned, mut straight, mut skipped) = (0usize, 0usize, 0usize);
        for _ in 0..20_000 {
            let table = HeadingTable::new(&kin, rng.gen_range(-PI..PI)).unwrap();
            let n = table.len();
            let (k, fg) = (rng.gen_range(0..n), rng.gen_range(-PI..PI));
            let (fd, before) = (rng.gen_range(-PI..PI), rng.gen_range(-PI..PI));
            let fields = [Some((fd, fg)), rng.gen_bool(0.5).then_some((before, fg))];
            let guess = Deployment::ahead_heading(&table, &config, fields, k);
            let direction = match fields[1] {
                Some((b, _)) => fd + wrap(fd - b),
                None => fd,
            };
            // Away from the tangent's tie and from the tolerance's edges.
            let step = TAU / f64::from(n);
            let error = libm::fabs(wrap(tangent_towards(direction, fg) - table.heading(k)));
            let edge = (error - config.straight_tolerance) / step;
            let theta_fg = between(direction, fg);
            if libm::fabs(edge - libm::round(edge)) < 1e-6 || theta_fg < 1e-6 || PI - theta_fg < 1e-6 {
                skipped += 1;
                continue;
            }
            // The controller in mode 2 (the field reached straight ahead first).
            let mut c = Controller::new(config);
            let ahead = Input {
                goal_bearing: 0.0,
                field_intensity: 1e9,
                field_direction: 0.0,
                heading: 0.0,
                dt: kin.dt,
            };
            assert_eq!(c.step(&ahead).mode, Mode::Bypass);
            let mut body = Body { pos: Vec2::new(0.0, 0.0), k };
            let input = |h| Input {
                goal_bearing: fg,
                field_intensity: 1e9,
                field_direction: direction,
                heading: h,
                dt: kin.dt,
            };
            let mut left = false;
            for _ in 0..n {
                let out = c.step(&input(body.heading(&table)));
                left |= out.mode == Mode::Goal;
                if out.motion == Motion::Straight || left {
                    break;
                }
                body.apply(out.motion, &table);
            }
            if left {
                // It leaves mode 2 on the way: no guess to make.
                skipped += 1;
                continue;
            }
            assert_eq!(guess, body.k, "k {k} fd {fd} fg {fg} fields {fields:?}");
            if guess == k {
                straight += 1;
            } else {
                turned += 1;
            }
        }
        assert!(turned > 5000 && straight > 100 && skipped < 12_000, "{turned} {straight} {skipped}");
    }
}
