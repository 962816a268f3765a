//! The BYCOMS point-robot controller (paper §IV-C).
//!
//! Each control period the robot knows four numbers — the goal bearing φg, the
//! field intensity g and gradient direction φf at its position, and its own
//! heading θ — and picks one of three motions: straight, turn clockwise, turn
//! counter-clockwise. It never senses terrain and never decides that anyone is
//! stuck; stopping is physical.
//!
//! * mode 1 → mode 2 when g ≥ g_th and θfg ≤ π/2 (a companion's field is ahead);
//! * mode 2 → mode 1 when θrg < π/2 and θfg > π/2 (the field is behind us and
//!   we face the goal);
//! * target: mode 1 → φg; mode 2 → φf ± π/2, whichever is closer to φg;
//! * straight if |target − θ| ≤ π/36, else turn towards the target.
//!
//! The mode is updated first and the target computed from the new mode.

use crate::angle::{between, wrap};
use core::f64::consts::{FRAC_PI_2, PI};

/// Behaviour mode of the controller.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Mode 1: head straight for the goal.
    Goal = 1,
    /// Mode 2: walk along the companions' field, perpendicular to its gradient.
    Bypass = 2,
}

/// The three motions of the point robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Motion {
    /// Move forward at `speed`.
    Straight,
    /// Turn in place clockwise (heading decreases) at `turn_rate`.
    TurnCw,
    /// Turn in place counter-clockwise (heading increases) at `turn_rate`.
    TurnCcw,
}

/// Parameters of the controller; [`ControllerConfig::paper`] gives the paper's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerConfig {
    /// Field threshold g_th; the circumferential radius is ε = sqrt(c / g_th).
    pub g_th: f64,
    /// Straight-line speed, units per second (paper: 1).
    pub speed: f64,
    /// Turning rate, rad/s (paper: π/6).
    pub turn_rate: f64,
    /// Largest |target − θ| that still counts as "facing the target" (paper: π/36).
    pub straight_tolerance: f64,
}

/// Field constant c of g = c / d² used by the paper's simulation.
pub const FIELD_CONSTANT: f64 = 1.0;

impl ControllerConfig {
    /// The paper's parameters with circumferential radius `eps` (g_th = c / ε²).
    pub fn paper(eps: f64) -> Self {
        Self {
            g_th: FIELD_CONSTANT / (eps * eps),
            speed: 1.0,
            turn_rate: PI / 6.0,
            straight_tolerance: PI / 36.0,
        }
    }

    /// The circumferential radius ε = sqrt(c / g_th) this threshold gives.
    pub fn radius(&self) -> f64 {
        libm::sqrt(FIELD_CONSTANT / self.g_th)
    }
}

/// What the robot senses in one control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Input {
    /// Goal bearing φg in the world frame, rad.
    pub goal_bearing: f64,
    /// Sensed field intensity g (sum over the other robots).
    pub field_intensity: f64,
    /// Direction φf of the field gradient (towards the sources), rad.
    pub field_direction: f64,
    /// The robot's own heading θ in the world frame, rad.
    pub heading: f64,
    /// Length of this control period, s (paper: 0.1).
    pub dt: f64,
}

/// The controller's decision for one control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Output {
    /// Mode after this period's switching rules.
    pub mode: Mode,
    /// Heading the robot wants to face.
    pub target: f64,
    /// Which of the three motions to perform.
    pub motion: Motion,
    /// Distance to advance this period (`speed · dt` when straight, else 0).
    pub advance: f64,
    /// Heading change this period (±`turn_rate · dt` when turning, else 0).
    pub rotate: f64,
}

/// The BYCOMS point-robot controller: a two-state machine, nothing else.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Controller {
    config: ControllerConfig,
    mode: Mode,
}

impl Controller {
    /// A controller in mode 1, as every robot starts.
    pub fn new(config: ControllerConfig) -> Self {
        Self { config, mode: Mode::Goal }
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The parameters this controller runs with.
    pub fn config(&self) -> &ControllerConfig {
        &self.config
    }

    /// One control period: update the mode, choose target and motion.
    #[inline]
    pub fn step(&mut self, input: &Input) -> Output {
        self.step_cached(input, &mut FieldGoal::default())
    }

    /// [`Self::step`], taking the parts of the decision that depend only on
    /// the field direction and the goal bearing from `cache` (and filling
    /// it): a simulated robot turning in place without sensing noise senses
    /// the same two angles period after period. The same bits as `step`.
    #[inline]
    pub fn step_cached(&mut self, input: &Input, cache: &mut FieldGoal) -> Output {
        cache.refresh(input.field_direction, input.goal_bearing);
        self.mode = next_mode_cached(self.mode, input, self.config.g_th, cache);
        let target = match self.mode {
            Mode::Goal => input.goal_bearing,
            Mode::Bypass => cache.tangent(),
        };
        let error = wrap(target - input.heading);
        let motion = choose_motion(error, self.config.straight_tolerance);
        let (advance, rotate) = match motion {
            Motion::Straight => (self.config.speed * input.dt, 0.0),
            Motion::TurnCcw => (0.0, self.config.turn_rate * input.dt),
            Motion::TurnCw => (0.0, -self.config.turn_rate * input.dt),
        };
        Output { mode: self.mode, target, motion, advance, rotate }
    }
}

/// What a period's decision computes from the field direction φf and the
/// goal bearing φg alone — their angle θfg and the tangent towards the
/// goal — each computed when first needed and kept while both angles stay
/// the same, bit for bit ([`Controller::step_cached`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct FieldGoal {
    /// The bits of (φf, φg) the values below belong to.
    key: Option<(u64, u64)>,
    /// wrap(φf − φg): θfg with its sign.
    signed: Option<f64>,
    tangent: Option<f64>,
}

/// Smallest |θfg| and π − |θfg| for which the tangent is taken from the
/// sign of θfg alone; the roundings of either way are below 1e-14 rad.
const TANGENT_MARGIN: f64 = 1e-9;

impl FieldGoal {
    /// Forgets the values unless they belong to these two angles.
    #[inline]
    fn refresh(&mut self, field_direction: f64, goal_bearing: f64) {
        let key = (field_direction.to_bits(), goal_bearing.to_bits());
        if self.key != Some(key) {
            *self = Self { key: Some(key), signed: None, tangent: None };
        }
    }

    #[inline]
    fn angles(&self) -> (f64, f64) {
        let (f, g) = self.key.expect("FieldGoal::refresh before use");
        (f64::from_bits(f), f64::from_bits(g))
    }

    /// wrap(φf − φg), in (−π, π].
    #[inline]
    fn signed(&mut self) -> f64 {
        let (f, g) = self.angles();
        *self.signed.get_or_insert_with(|| wrap(f - g))
    }

    /// θfg = |φf − φg| wrapped, in [0, π] (the bits of [`between`]).
    #[inline]
    fn between(&mut self) -> f64 {
        libm::fabs(self.signed())
    }

    /// [`tangent_towards`]`(φf, φg)`: with φf counter-clockwise of φg
    /// (θfg ∈ (0, π)) the clockwise perpendicular is the closer one, with
    /// φf clockwise of it the other; only near a tie (θfg near 0 or ±π,
    /// within [`TANGENT_MARGIN`]) are the two compared as there.
    #[inline]
    fn tangent(&mut self) -> f64 {
        if let Some(t) = self.tangent {
            return t;
        }
        let d = self.signed();
        let (f, g) = self.angles();
        let t = if d > TANGENT_MARGIN && d < PI - TANGENT_MARGIN {
            wrap(f - FRAC_PI_2)
        } else if d < -TANGENT_MARGIN && d > -PI + TANGENT_MARGIN {
            wrap(f + FRAC_PI_2)
        } else {
            tangent_towards(f, g)
        };
        *self.tangent.insert(t)
    }
}

/// The switching rules between the modes (paper §IV-C).
#[inline]
pub fn next_mode(mode: Mode, input: &Input, g_th: f64) -> Mode {
    let mut cache = FieldGoal::default();
    cache.refresh(input.field_direction, input.goal_bearing);
    next_mode_cached(mode, input, g_th, &mut cache)
}

/// [`next_mode`] with θfg from `cache` (refreshed for `input`).
#[inline]
fn next_mode_cached(mode: Mode, input: &Input, g_th: f64, cache: &mut FieldGoal) -> Mode {
    match mode {
        Mode::Goal => {
            if input.field_intensity >= g_th && cache.between() <= FRAC_PI_2 {
                Mode::Bypass
            } else {
                Mode::Goal
            }
        }
        Mode::Bypass => {
            if between(input.heading, input.goal_bearing) < FRAC_PI_2 && cache.between() > FRAC_PI_2 {
                Mode::Goal
            } else {
                Mode::Bypass
            }
        }
    }
}

/// Of the two perpendiculars to the gradient, the one closer to the goal
/// bearing. On an exact tie (gradient parallel to the goal bearing) the
/// counter-clockwise one (φf + π/2) is taken, so the choice is deterministic.
#[inline]
pub fn tangent_towards(field_direction: f64, goal_bearing: f64) -> f64 {
    let ccw = wrap(field_direction + FRAC_PI_2);
    let cw = wrap(field_direction - FRAC_PI_2);
    if between(cw, goal_bearing) < between(ccw, goal_bearing) {
        cw
    } else {
        ccw
    }
}

/// Straight when the heading error is within tolerance (inclusive), else
/// turn towards the target: a positive error means the target is
/// counter-clockwise of the heading.
#[inline]
pub fn choose_motion(heading_error: f64, tolerance: f64) -> Motion {
    if libm::fabs(heading_error) <= tolerance {
        Motion::Straight
    } else if heading_error > 0.0 {
        Motion::TurnCcw
    } else {
        Motion::TurnCw
    }
}

#[cfg(test)]
mod tests;
