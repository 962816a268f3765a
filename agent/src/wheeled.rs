//! The paper's differential-drive law (§VI-C, [`crate::acoustic::drive`]) on
//! a wheeled robot that takes velocity commands (a ROS 2 robot's `cmd_vel`),
//! sensing the field virtually.
//!
//! Why here, no_std: the acoustic robot's firmware and a ROS 2 robot run the
//! same [`DriveController`]; only what goes in and what comes out differ.
//! In goes a *virtual* field sample instead of six microphones: the paper's
//! §IV field g = Σ c/d² of the stopped robots at the robot's trusted pose
//! from motion capture, with its gradient direction. Out go (v, ω) instead
//! of two track voltages.
//!
//! * **The field's scale.** The law was tuned for microphone readings
//!   (V_target = 22000, V_min = 15000, α = 1e-4). [`drive_config`] keeps
//!   every ratio and puts V_target at the simulation's threshold g_th =
//!   c/ε² ([`crate::point::ControllerConfig::paper`]): mode 2 holds the
//!   contour at ε metres from a lone beacon, gives up below
//!   V_min/V_target = 15/22 of it, and α·V_target stays 2.2 rad.
//! * **Track voltages to (v, ω).** The track speeds are taken proportional
//!   to the commands: v_m, the base voltage, is the robot's top linear speed.
//!   v is their mean, ω = (right − left) / wheel base (counter-clockwise
//!   positive, REP-103; more on the left turns clockwise as on the
//!   crawler), then both are clamped to the robot's limits ([`Limits`]).

use crate::acoustic::{DriveConfig, DriveController, DriveInput, DriveOutput, Tangent};
use crate::point::{Mode, FIELD_CONSTANT};

/// The acoustic robot's V_target, which [`drive_config`] maps onto g_th.
const PAPER_V_TARGET: f64 = 22_000.0;
/// The acoustic robot's V_min.
const PAPER_V_MIN: f64 = 15_000.0;
/// The acoustic robot's base voltage v_m.
const PAPER_BASE_VOLTAGE: f64 = 120.0;
/// The acoustic robot's motor command limit (8-bit PWM).
const PAPER_VOLTAGE_LIMIT: f64 = 255.0;

/// A wheeled robot's velocity limits and geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Largest forward speed, m/s (reached when both tracks get v_m).
    pub linear: f64,
    /// Largest turn rate, rad/s.
    pub angular: f64,
    /// Distance between the wheels, m.
    pub wheel_base: f64,
}

impl Limits {
    /// A TurtleBot 3 Burger's: 0.22 m/s, 2.84 rad/s, 0.160 m between wheels.
    pub const TURTLEBOT3_BURGER: Self = Self { linear: 0.22, angular: 2.84, wheel_base: 0.160 };

    /// Why these limits cannot drive a robot, if they cannot.
    pub fn check(&self) -> Result<(), &'static str> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        match (positive(self.linear), positive(self.angular), positive(self.wheel_base)) {
            (false, _, _) => Err("the linear limit must be a positive number of m/s"),
            (_, false, _) => Err("the angular limit must be a positive number of rad/s"),
            (_, _, false) => Err("the wheel base must be a positive number of metres"),
            _ => Ok(()),
        }
    }
}

/// A planar velocity command: what a `geometry_msgs/Twist` carries for a
/// ground robot.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Velocity {
    /// Forward speed, m/s (`linear.x`).
    pub linear: f64,
    /// Turn rate, rad/s, counter-clockwise positive (`angular.z`).
    pub angular: f64,
}

impl Velocity {
    /// Standing still.
    pub const ZERO: Self = Self { linear: 0.0, angular: 0.0 };
}

/// The field at the robot, sensed virtually.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldReading {
    /// g = Σ c/d² over the stopped robots.
    pub intensity: f64,
    /// Direction of the gradient (towards the sources) in the world frame,
    /// rad; `None` without a field.
    pub gradient: Option<f64>,
}

/// The paper's drive law with V_target = `g_th` (see the module docs).
pub fn drive_config(g_th: f64) -> DriveConfig {
    let scale = g_th / PAPER_V_TARGET;
    DriveConfig {
        kp: 100.0,
        alpha: 1e-4 / scale,
        v_target: g_th,
        v_min: PAPER_V_MIN * scale,
        base_voltage: PAPER_BASE_VOLTAGE,
        voltage_limit: Some(PAPER_VOLTAGE_LIMIT),
        tangent: Tangent::TowardsGoal,
    }
}

/// g_th for a contour at `eps` metres from a lone beacon (c = 1).
pub fn threshold(eps: f64) -> f64 {
    FIELD_CONSTANT / (eps * eps)
}

/// One wheeled robot's controller: the drive law and the conversion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wheeled {
    drive: DriveController,
    limits: Limits,
}

impl Wheeled {
    /// A controller in mode 1 holding the contour at `eps` metres.
    pub fn new(eps: f64, limits: Limits) -> Self {
        Self { drive: DriveController::new(drive_config(threshold(eps))), limits }
    }

    /// The current mode.
    pub fn mode(&self) -> Mode {
        self.drive.mode()
    }

    /// One control period: the robot at `heading` (world frame, rad) heads
    /// for `goal_bearing` in `field`.
    pub fn step(&mut self, goal_bearing: f64, heading: f64, field: FieldReading) -> (DriveOutput, Velocity) {
        let input = DriveInput { goal_bearing, heading, gradient: field.gradient, v_ave: field.intensity };
        let out = self.drive.step(&input);
        (out, velocity(&out, self.drive.config().base_voltage, &self.limits))
    }
}

/// The track commands of `out` as (v, ω) within `limits`, v_m being the
/// top linear speed.
pub fn velocity(out: &DriveOutput, base_voltage: f64, limits: &Limits) -> Velocity {
    let per_volt = limits.linear / base_voltage;
    let (left, right) = (out.left * per_volt, out.right * per_volt);
    let clamp = |v: f64, limit: f64| libm::fmin(libm::fmax(v, -limit), limit);
    Velocity {
        linear: clamp((left + right) / 2.0, limits.linear),
        angular: clamp((right - left) / limits.wheel_base, limits.angular),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::{FRAC_PI_2, PI};

    const NO_FIELD: FieldReading = FieldReading { intensity: 0.0, gradient: None };

    #[test]
    fn facing_the_goal_it_drives_straight_at_top_speed() {
        let mut robot = Wheeled::new(0.5, Limits::TURTLEBOT3_BURGER);
        let (out, v) = robot.step(0.3, 0.3, NO_FIELD);
        assert_eq!(out.mode, Mode::Goal);
        assert_eq!(v, Velocity { linear: 0.22, angular: 0.0 });
    }

    #[test]
    fn a_goal_to_the_left_turns_counter_clockwise_within_the_limit() {
        let mut robot = Wheeled::new(0.5, Limits::TURTLEBOT3_BURGER);
        let (_, small) = robot.step(0.05, 0.0, NO_FIELD);
        assert!(small.angular > 0.0 && small.angular < 2.84, "{small:?}");
        let (_, big) = robot.step(FRAC_PI_2, 0.0, NO_FIELD);
        assert_eq!(big.angular, 2.84, "clamped to the angular limit");
        let (_, right) = robot.step(-FRAC_PI_2, 0.0, NO_FIELD);
        assert_eq!(right.angular, -2.84);
        // Clamped tracks (±255 around 120) slow it: one track goes backwards.
        assert!(big.linear < 0.22 && big.linear > 0.0, "{big:?}");
    }

    #[test]
    fn the_threshold_is_the_simulations_and_mode_2_holds_the_contour_at_eps() {
        let eps = 0.4;
        assert_eq!(threshold(eps), crate::ControllerConfig::paper(eps).g_th);
        let c = drive_config(threshold(eps));
        assert!((c.alpha * c.v_target - 2.2).abs() < 1e-12, "α·V_target as the paper's");
        assert!((c.v_min / c.v_target - 15.0 / 22.0).abs() < 1e-12);
        // A beacon straight ahead on the way to the goal, just inside ε:
        // the field is above g_th and ahead, so mode 2 walks along it.
        let mut robot = Wheeled::new(eps, Limits::TURTLEBOT3_BURGER);
        let d = 0.95 * eps;
        let field = FieldReading { intensity: 1.0 / (d * d), gradient: Some(0.0) };
        let (out, v) = robot.step(0.0, 0.0, field);
        assert_eq!(out.mode, Mode::Bypass);
        assert!((out.target.abs() - FRAC_PI_2).abs() < 1e-12, "a tangent: {}", out.target);
        assert!(v.angular.abs() > 0.0);
        // Far from it (below V_min) mode 1 again.
        let far = FieldReading { intensity: 0.5 * threshold(eps), gradient: Some(PI) };
        assert_eq!(robot.step(0.0, 0.0, far).0.mode, Mode::Goal);
    }

    #[test]
    fn limits_that_cannot_drive_are_refused() {
        assert!(Limits::TURTLEBOT3_BURGER.check().is_ok());
        let bad = [
            Limits { linear: 0.0, ..Limits::TURTLEBOT3_BURGER },
            Limits { angular: f64::NAN, ..Limits::TURTLEBOT3_BURGER },
            Limits { wheel_base: -0.1, ..Limits::TURTLEBOT3_BURGER },
        ];
        for limits in bad {
            assert!(limits.check().is_err(), "{limits:?}");
        }
    }
}
