//! The differential-drive controller of the acoustic robot (paper §VI-C).
//!
//! The crawler robot cannot do the point robot's "straight / turn in place":
//! it steers continuously by a voltage difference between its tracks. The
//! paper's law, per control period:
//!
//! * mode 1: u = Kp·θ1, θ1 the heading error to the goal;
//! * mode 2: the target is the gradient rotated by π/2 (walk along the
//!   field's contour), u = Kp·(θ2 + α·V_e), V_e = V_ave − V_target, so the
//!   intensity error bends the path in or out and the robot holds the contour
//!   V_ave ≈ V_target (a proportional law: while circling, a small steady
//!   intensity error supplies the turn, so the robot settles slightly outside);
//! * left motor v_m + u, right motor v_m − u.
//!
//! Switching (strict inequalities, as in the paper): 1 → 2 when
//! V_ave > V_target and angle(goal, grad) < π/2 — never without a gradient
//! direction; 2 → 1 when angle(heading, goal) < π/2 and angle(grad, goal) > π/2
//! (gradient known this period), or when V_ave < V_min (the field got too weak
//! for a gradient). The mode is updated first, then u from the new mode.
//!
//! # Sign conventions (the paper leaves them implicit)
//!
//! More voltage on the left track turns the robot clockwise, so u > 0 must
//! mean "target is clockwise of the heading". The heading errors are therefore
//! taken clockwise: θ = wrap(heading − target) ∈ (−π, π]. With the opposite
//! sign the paper's u = Kp·θ1 would steer away from the goal.
//!
//! The same reading fixes the paper's π/2 rotation: V_e > 0 (too close) gives
//! u > 0, a clockwise turn, which moves away from the source only if the
//! source is on the robot's left, i.e. target = grad − π/2 (the robot circles
//! the source counter-clockwise). That is [`Tangent::SourceOnLeft`], the
//! paper's formula verbatim. [`DriveConfig::paper`] instead uses
//! [`Tangent::TowardsGoal`]: as in the simulation (§IV) and the point
//! controller, the perpendicular closer to the goal (same rule and tie-break
//! as [`crate::point::tangent_towards`]), with the sign of the α·V_e term
//! flipped when that puts the source on the right, so the distance loop
//! stays stable either way.
//!
//! Angles are in the world frame (a caller with only robot-frame bearings
//! passes heading = 0). If the gradient is unknown during mode 2, the last
//! known gradient direction is used for the target.

use crate::angle::{between, wrap};
use crate::point::Mode;
use core::f64::consts::FRAC_PI_2;

/// Which of the two perpendiculars to the gradient mode 2 follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Tangent {
    /// The one closer to the goal, re-chosen every period (as in §IV).
    TowardsGoal,
    /// grad − π/2: source on the left, circling it counter-clockwise.
    SourceOnLeft,
    /// grad + π/2: source on the right, circling it clockwise.
    SourceOnRight,
}

/// Parameters of the drive controller; [`DriveConfig::paper`] gives the paper's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveConfig {
    /// Proportional gain Kp, voltage per rad (paper: 100).
    pub kp: f64,
    /// Weight α of the intensity error against the angle error (paper: 1e-4).
    pub alpha: f64,
    /// V_target: mode 2 holds this intensity; above it mode 1 yields (paper: 22000).
    pub v_target: f64,
    /// V_min: below it mode 2 gives up (paper: 15000).
    pub v_min: f64,
    /// Base voltage v_m applied to both motors (not given in the paper).
    pub base_voltage: f64,
    /// If set, each motor command is clamped to ±limit (u is reported unclamped).
    pub voltage_limit: Option<f64>,
    /// Which perpendicular mode 2 follows.
    pub tangent: Tangent,
}

impl DriveConfig {
    /// The paper's Kp, α, V_target and V_min with base voltage `base_voltage`,
    /// no clamping, and the perpendicular closer to the goal.
    pub const fn paper(base_voltage: f64) -> Self {
        Self {
            kp: 100.0,
            alpha: 1e-4,
            v_target: 22_000.0,
            v_min: 15_000.0,
            base_voltage,
            voltage_limit: None,
            tangent: Tangent::TowardsGoal,
        }
    }
}

/// What the robot knows in one control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveInput {
    /// Goal bearing in the world frame, rad.
    pub goal_bearing: f64,
    /// The robot's heading in the world frame, rad.
    pub heading: f64,
    /// Gradient direction in the world frame, `None` if it could not be
    /// estimated (see [`super::GradientEstimate::world_direction`]).
    pub gradient: Option<f64>,
    /// V_ave, the mean microphone reading.
    pub v_ave: f64,
}

/// The controller's decision for one control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveOutput {
    /// Mode after this period's switching rules.
    pub mode: Mode,
    /// Heading the robot steers towards (goal, or the chosen perpendicular).
    pub target: f64,
    /// Control input u; positive turns clockwise.
    pub u: f64,
    /// Left motor command v_m + u (clamped if configured).
    pub left: f64,
    /// Right motor command v_m − u (clamped if configured).
    pub right: f64,
}

/// The acoustic robot's two-mode controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveController {
    config: DriveConfig,
    mode: Mode,
    /// Last known gradient direction (world frame), for mode-2 periods
    /// without one.
    last_gradient: Option<f64>,
}

impl DriveController {
    /// A controller in mode 1.
    pub const fn new(config: DriveConfig) -> Self {
        Self { config, mode: Mode::Goal, last_gradient: None }
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The parameters this controller runs with.
    pub fn config(&self) -> &DriveConfig {
        &self.config
    }

    /// One control period: update the mode, then compute the motor commands.
    pub fn step(&mut self, input: &DriveInput) -> DriveOutput {
        let c = &self.config;
        if input.gradient.is_some() {
            self.last_gradient = input.gradient;
        }
        self.mode = next_mode(self.mode, input, c);
        let (target, u) = match (self.mode, self.last_gradient) {
            (Mode::Bypass, Some(grad)) => {
                let (target, sign) = tangent(c.tangent, grad, input.goal_bearing);
                let v_e = input.v_ave - c.v_target;
                (target, c.kp * (heading_error(input.heading, target) + sign * c.alpha * v_e))
            }
            // Mode 2 is only entered with a gradient, so this arm is mode 1.
            _ => (input.goal_bearing, c.kp * heading_error(input.heading, input.goal_bearing)),
        };
        let clamp = |v: f64| match c.voltage_limit {
            Some(l) => libm::fmin(libm::fmax(v, -l), l),
            None => v,
        };
        DriveOutput {
            mode: self.mode,
            target,
            u,
            left: clamp(c.base_voltage + u),
            right: clamp(c.base_voltage - u),
        }
    }
}

/// Clockwise heading error wrap(heading − target) ∈ (−π, π]: positive when
/// the target is clockwise of the heading, so u = Kp·θ > 0 turns towards it.
pub fn heading_error(heading: f64, target: f64) -> f64 {
    wrap(heading - target)
}

/// The paper's switching rules (strict inequalities).
pub fn next_mode(mode: Mode, input: &DriveInput, c: &DriveConfig) -> Mode {
    match (mode, input.gradient) {
        (Mode::Goal, Some(grad))
            if input.v_ave > c.v_target && between(input.goal_bearing, grad) < FRAC_PI_2 =>
        {
            Mode::Bypass
        }
        (Mode::Goal, _) => Mode::Goal,
        (Mode::Bypass, _) if input.v_ave < c.v_min => Mode::Goal,
        (Mode::Bypass, Some(grad))
            if between(input.heading, input.goal_bearing) < FRAC_PI_2
                && between(grad, input.goal_bearing) > FRAC_PI_2 =>
        {
            Mode::Goal
        }
        (Mode::Bypass, _) => Mode::Bypass,
    }
}

/// Mode-2 target for gradient `grad` and the sign of the α·V_e term that
/// makes "too loud" steer away from the source: +1 with the source on the
/// left (target grad − π/2), −1 with it on the right (grad + π/2).
pub fn tangent(rule: Tangent, grad: f64, goal_bearing: f64) -> (f64, f64) {
    let left = wrap(grad - FRAC_PI_2);
    let right = wrap(grad + FRAC_PI_2);
    let source_on_left = match rule {
        Tangent::SourceOnLeft => true,
        Tangent::SourceOnRight => false,
        // Same comparison and tie-break (grad + π/2) as point::tangent_towards.
        Tangent::TowardsGoal => between(left, goal_bearing) < between(right, goal_bearing),
    };
    if source_on_left {
        (left, 1.0)
    } else {
        (right, -1.0)
    }
}

#[cfg(test)]
mod tests;
