//! Switching rules, steering signs, and closed-loop runs of the drive law on
//! a unicycle model with the microphone ring in the loop.

use super::*;
use crate::acoustic::gradient::MicRing;
use crate::angle::direction;
use core::f64::consts::PI;

fn cfg() -> DriveConfig {
    DriveConfig::paper(100.0)
}

fn input(goal: f64, heading: f64, gradient: Option<f64>, v_ave: f64) -> DriveInput {
    DriveInput { goal_bearing: goal, heading, gradient, v_ave }
}

/// A controller already in mode 2 (entered through the 1 → 2 rule).
fn in_mode_two(config: DriveConfig) -> DriveController {
    let mut c = DriveController::new(config);
    assert_eq!(c.step(&input(0.0, 0.0, Some(0.0), 30_000.0)).mode, Mode::Bypass);
    c
}

#[test]
fn paper_parameters() {
    let c = DriveConfig::paper(123.0);
    assert_eq!((c.kp, c.alpha, c.v_target, c.v_min), (100.0, 1e-4, 22_000.0, 15_000.0));
    assert_eq!(c.base_voltage, 123.0);
    assert_eq!(c.voltage_limit, None);
    assert_eq!(c.tangent, Tangent::TowardsGoal);
    assert_eq!(DriveController::new(c).mode(), Mode::Goal);
}

#[test]
fn mode_one_steers_towards_the_goal() {
    let mut c = DriveController::new(cfg());
    // Goal 0.5 rad to the left (counter-clockwise): u < 0, right track faster.
    let out = c.step(&input(0.5, 0.0, None, 0.0));
    assert_eq!(out.mode, Mode::Goal);
    assert_eq!(out.target, 0.5);
    assert!((out.u + 50.0).abs() < 1e-12);
    assert!((out.left - 50.0).abs() < 1e-12 && (out.right - 150.0).abs() < 1e-12);
    // Goal to the right: u > 0, left track faster.
    let out = c.step(&input(-0.5, 0.0, None, 0.0));
    assert!((out.u - 50.0).abs() < 1e-12);
    // Facing the goal: straight, both tracks at v_m.
    let out = c.step(&input(2.0, 2.0, None, 0.0));
    assert_eq!((out.u, out.left, out.right), (0.0, 100.0, 100.0));
    // Heading error wraps: goal at −3 rad from heading 3 rad is 0.28 rad ccw.
    let out = c.step(&input(-3.0, 3.0, None, 0.0));
    assert!((out.u - 100.0 * wrap(6.0)).abs() < 1e-12 && out.u < 0.0);
}

#[test]
fn one_to_two_needs_loud_field_ahead_and_strictly_so() {
    let c = cfg();
    let at = |v: f64, grad: Option<f64>| next_mode(Mode::Goal, &input(0.0, 0.0, grad, v), &c);
    assert_eq!(at(22_001.0, Some(0.0)), Mode::Bypass);
    assert_eq!(at(22_000.0, Some(0.0)), Mode::Goal); // V_ave = V_target: not >
    assert_eq!(at(30_000.0, Some(FRAC_PI_2 - 1e-9)), Mode::Bypass);
    assert_eq!(at(30_000.0, Some(FRAC_PI_2)), Mode::Goal); // angle = π/2: not <
    assert_eq!(at(30_000.0, Some(-FRAC_PI_2)), Mode::Goal);
    assert_eq!(at(30_000.0, Some(PI)), Mode::Goal); // field behind
    assert_eq!(at(1e9, None), Mode::Goal); // no gradient, no switch
}

#[test]
fn two_to_one_when_past_the_field_and_strictly_so() {
    let c = cfg();
    let at =
        |heading: f64, grad: Option<f64>, v: f64| next_mode(Mode::Bypass, &input(0.0, heading, grad, v), &c);
    // Field behind, facing the goal: back to mode 1, however loud.
    assert_eq!(at(0.3, Some(PI), 30_000.0), Mode::Goal);
    assert_eq!(at(0.3, Some(FRAC_PI_2 + 1e-9), 30_000.0), Mode::Goal);
    assert_eq!(at(0.3, Some(FRAC_PI_2), 30_000.0), Mode::Bypass); // angle = π/2: not >
    assert_eq!(at(FRAC_PI_2 - 1e-9, Some(PI), 30_000.0), Mode::Goal);
    assert_eq!(at(FRAC_PI_2, Some(PI), 30_000.0), Mode::Bypass); // angle = π/2: not <
    assert_eq!(at(PI, Some(PI), 30_000.0), Mode::Bypass); // facing away
    assert_eq!(at(0.0, Some(0.2), 30_000.0), Mode::Bypass); // field ahead
    assert_eq!(at(0.0, None, 20_000.0), Mode::Bypass); // no gradient: stay
}

#[test]
fn v_min_escape_and_its_strictness() {
    let c = cfg();
    let at = |grad: Option<f64>, v: f64| next_mode(Mode::Bypass, &input(0.0, PI, grad, v), &c);
    // Facing away from the goal with the field ahead: only V_min can end mode 2.
    assert_eq!(at(Some(0.0), 14_999.0), Mode::Goal);
    assert_eq!(at(None, 14_999.0), Mode::Goal); // works without a gradient
    assert_eq!(at(Some(0.0), 15_000.0), Mode::Bypass); // V_ave = V_min: not <
    assert_eq!(at(None, 15_000.0), Mode::Bypass);
}

#[test]
fn mode_is_updated_before_steering() {
    let mut c = DriveController::new(cfg());
    // Loud field straight ahead (goal at 0): mode 2 in this very period, and
    // the target is a perpendicular, not the goal.
    let out = c.step(&input(0.0, 0.0, Some(0.1), 22_000.0 + 1.0));
    assert_eq!(out.mode, Mode::Bypass);
    assert!((between(out.target, 0.1) - FRAC_PI_2).abs() < 1e-12);
}

#[test]
fn towards_goal_matches_the_point_controller() {
    for i in 0..72 {
        for j in 0..72 {
            let (grad, goal) = (wrap(i as f64 * 0.0873), wrap(j as f64 * 0.0873 + 0.01));
            let (target, sign) = tangent(Tangent::TowardsGoal, grad, goal);
            assert_eq!(target, crate::point::tangent_towards(grad, goal));
            // sign +1 exactly when the source (grad) is on the left of the target.
            assert_eq!(sign > 0.0, wrap(grad - target) > 0.0);
        }
    }
    // Tie (gradient parallel to the goal): grad + π/2, as point::tangent_towards.
    assert_eq!(tangent(Tangent::TowardsGoal, 0.0, 0.0), (FRAC_PI_2, -1.0));
    assert_eq!(tangent(Tangent::SourceOnLeft, 1.0, 1.0), (1.0 - FRAC_PI_2, 1.0));
    assert_eq!(tangent(Tangent::SourceOnRight, 1.0, -2.0), (1.0 + FRAC_PI_2, -1.0));
}

#[test]
fn too_loud_turns_away_from_the_source_on_either_side() {
    for tangent_rule in [Tangent::SourceOnLeft, Tangent::SourceOnRight] {
        let config = DriveConfig { tangent: tangent_rule, ..cfg() };
        let mut c = in_mode_two(config);
        // Heading exactly on the tangent, field 10 % too loud / too quiet.
        let (target, _) = tangent(tangent_rule, 0.0, 0.0);
        let loud = c.step(&input(0.0, target, Some(0.0), 24_200.0));
        let quiet = c.step(&input(0.0, target, Some(0.0), 19_800.0));
        assert_eq!((loud.mode, quiet.mode), (Mode::Bypass, Mode::Bypass));
        // Source (gradient 0) on the left → away is clockwise, u > 0.
        let away_is_cw = tangent_rule == Tangent::SourceOnLeft;
        assert_eq!(loud.u > 0.0, away_is_cw, "{tangent_rule:?}");
        assert_eq!(quiet.u > 0.0, !away_is_cw, "{tangent_rule:?}");
        // |u| = Kp·α·|V_e| = 100 · 1e-4 · 2200.
        assert!((loud.u.abs() - 22.0).abs() < 1e-9);
    }
}

#[test]
fn mode_two_holds_the_last_gradient_when_it_is_lost() {
    let config = DriveConfig { tangent: Tangent::SourceOnLeft, ..cfg() };
    let mut c = in_mode_two(config);
    let with = c.step(&input(0.0, 0.0, Some(0.4), 22_000.0));
    let without = c.step(&input(0.0, 0.0, None, 22_000.0));
    assert_eq!(without.mode, Mode::Bypass);
    assert_eq!(with.target, without.target);
    assert_eq!(with.u, without.u);
}

#[test]
fn voltage_limit_clamps_each_motor() {
    let config = DriveConfig { voltage_limit: Some(200.0), ..cfg() };
    let out = DriveController::new(config).step(&input(3.0, 0.0, None, 0.0));
    assert!((out.u + 300.0).abs() < 1e-12); // reported unclamped
    assert_eq!((out.left, out.right), (-200.0, 200.0));
}

// ---- closed loop -------------------------------------------------------

/// Track speed per volt (m/s), track separation (m), control period (s).
const K_V: f64 = 1e-3;
const TRACK: f64 = 0.2;
const DT: f64 = 0.05;

#[derive(Clone, Copy, Debug)]
struct Pose {
    x: f64,
    y: f64,
    heading: f64,
}

/// One period of a differential-drive (unicycle) robot, counter-clockwise positive.
fn drive(p: Pose, left: f64, right: f64) -> Pose {
    let v = K_V * (left + right) / 2.0;
    let w = K_V * (right - left) / TRACK;
    let heading = wrap(p.heading + w * DT);
    Pose { x: p.x + v * DT * libm::cos(heading), y: p.y + v * DT * libm::sin(heading), heading }
}

/// Field c/d² of a source at the origin; c puts V_target at 0.5 m.
const C: f64 = 22_000.0 * 0.25;

fn field(x: f64, y: f64) -> f64 {
    C / (x * x + y * y)
}

/// Sense with the paper ring (gradient estimator in the loop) and step.
fn sense_and_step(c: &mut DriveController, p: Pose, goal: (f64, f64)) -> DriveOutput {
    let ring = MicRing::paper();
    let (s, co) = (libm::sin(p.heading), libm::cos(p.heading));
    let v = ring.positions().map(|(mx, my)| field(p.x + co * mx - s * my, p.y + s * mx + co * my));
    let est = ring.estimate(&v);
    c.step(&DriveInput {
        goal_bearing: direction(goal.0 - p.x, goal.1 - p.y),
        heading: p.heading,
        gradient: est.world_direction(p.heading),
        v_ave: est.mean,
    })
}

#[test]
fn unicycle_turns_towards_the_goal() {
    for start in [-3.0, -2.0, -1.0, -0.2, 0.2, 1.0, 2.0, 3.0] {
        let mut c = DriveController::new(cfg());
        let mut p = Pose { x: 0.0, y: 0.0, heading: start };
        let goal_bearing = 0.0;
        let mut last = between(p.heading, goal_bearing);
        for _ in 0..200 {
            let out = c.step(&input(goal_bearing, p.heading, None, 0.0));
            p = drive(p, out.left, out.right);
            let err = between(p.heading, goal_bearing);
            assert!(err <= last + 1e-12, "start {start}: error grew");
            last = err;
        }
        assert!(last < 1e-3, "start {start}: heading error {last}");
    }
}

#[test]
fn bypasses_a_loud_robot_on_the_way_and_reaches_the_goal() {
    let goal = (3.0, 0.0);
    let mut c = DriveController::new(cfg());
    let mut p = Pose { x: -3.0, y: 0.05, heading: 0.0 };
    let (mut min_d, mut bypassed, mut reached) = (f64::INFINITY, false, false);
    for _ in 0..4000 {
        let out = sense_and_step(&mut c, p, goal);
        bypassed |= out.mode == Mode::Bypass;
        p = drive(p, out.left, out.right);
        min_d = min_d.min(libm::hypot(p.x, p.y));
        if libm::hypot(goal.0 - p.x, goal.1 - p.y) < 0.05 {
            reached = true;
            break;
        }
    }
    assert!(bypassed && reached, "{p:?}");
    assert_eq!(c.mode(), Mode::Goal);
    // The V_target circle is 0.5 m; it overshoots by at most a few cm (measured 0.443 m).
    assert!(min_d > 0.4, "closest approach {min_d}");
}

#[test]
fn mode_two_follows_the_contour_in_the_chosen_sense() {
    // Goal at the source itself: mode 2 is never left, the robot circles.
    for rule in [Tangent::SourceOnLeft, Tangent::SourceOnRight] {
        let mut c = DriveController::new(DriveConfig { tangent: rule, ..cfg() });
        let mut p = Pose { x: -2.0, y: 0.0, heading: 0.0 };
        let (mut lo, mut hi, mut swept) = (f64::INFINITY, 0.0_f64, 0.0);
        for i in 0..3000 {
            let out = sense_and_step(&mut c, p, (0.0, 0.0));
            let before = direction(p.x, p.y);
            p = drive(p, out.left, out.right);
            swept += wrap(direction(p.x, p.y) - before);
            if i > 600 {
                assert_eq!(out.mode, Mode::Bypass);
                let d = libm::hypot(p.x, p.y);
                (lo, hi) = (lo.min(d), hi.max(d));
            }
        }
        // Settled on a circle just outside the V_target contour (0.5 m): a
        // proportional law needs a steady error to keep turning, here
        // α·V_e ≈ −ω·track/(2·K_V·Kp), i.e. V_ave ≈ 19 500, d ≈ 0.53 m
        // (measured 0.5317 ± 0.0001).
        assert!(lo > 0.52 && hi < 0.54 && hi - lo < 0.005, "{rule:?}: {lo}..{hi}");
        // Source on the left ⇒ circling counter-clockwise (angle about it grows).
        assert_eq!(swept > 2.0 * PI, rule == Tangent::SourceOnLeft, "{rule:?}: {swept}");
        assert_eq!(swept < -2.0 * PI, rule == Tangent::SourceOnRight, "{rule:?}: {swept}");
    }
}
