//! Unit tests of the switching rules, the perpendicular choice and the
//! straight/turn boundary.

use super::*;
use core::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};

fn cfg() -> ControllerConfig {
    ControllerConfig::paper(2.0) // g_th = 0.25
}

fn input(goal: f64, g: f64, field: f64, heading: f64) -> Input {
    Input { goal_bearing: goal, field_intensity: g, field_direction: field, heading, dt: 0.1 }
}

#[test]
fn paper_parameters() {
    let c = ControllerConfig::paper(2.0);
    assert_eq!(c.g_th, 0.25);
    assert_eq!(c.speed, 1.0);
    assert_eq!(c.turn_rate, PI / 6.0);
    assert_eq!(c.straight_tolerance, PI / 36.0);
    assert!((c.radius() - 2.0).abs() < 1e-15);
}

#[test]
fn starts_in_mode_one_and_heads_for_goal() {
    let mut c = Controller::new(cfg());
    assert_eq!(c.mode(), Mode::Goal);
    let out = c.step(&input(0.3, 0.0, 0.0, 0.3));
    assert_eq!(out.mode, Mode::Goal);
    assert_eq!(out.target, 0.3);
    assert_eq!(out.motion, Motion::Straight);
    assert_eq!(out.advance, 0.1);
    assert_eq!(out.rotate, 0.0);
}

#[test]
fn mode_one_to_two_needs_threshold_and_field_ahead() {
    let g_th = cfg().g_th;
    // Field at threshold (inclusive) and straight ahead: switch.
    assert_eq!(next_mode(Mode::Goal, &input(0.0, g_th, 0.0, 0.0), g_th), Mode::Bypass);
    // Just below threshold: stay.
    let below = g_th * (1.0 - 1e-12);
    assert_eq!(next_mode(Mode::Goal, &input(0.0, below, 0.0, 0.0), g_th), Mode::Goal);
    // Strong field but behind (θfg > π/2): stay.
    assert_eq!(next_mode(Mode::Goal, &input(0.0, 10.0, FRAC_PI_2 + 1e-9, 0.0), g_th), Mode::Goal);
    // θfg exactly π/2 counts as ahead (≤).
    assert_eq!(next_mode(Mode::Goal, &input(0.0, 10.0, FRAC_PI_2, 0.0), g_th), Mode::Bypass);
}

#[test]
fn mode_two_to_one_needs_heading_towards_goal_and_field_behind() {
    let g_th = cfg().g_th;
    // Field behind, heading towards goal: back to mode 1 whatever g is.
    assert_eq!(next_mode(Mode::Bypass, &input(0.0, 10.0, PI, 0.2), g_th), Mode::Goal);
    // Field behind, heading exactly perpendicular to goal (θrg = π/2 is not < π/2): stay.
    assert_eq!(next_mode(Mode::Bypass, &input(0.0, 10.0, PI, FRAC_PI_2), g_th), Mode::Bypass);
    // Heading towards goal, field exactly perpendicular (θfg = π/2 is not > π/2): stay.
    assert_eq!(next_mode(Mode::Bypass, &input(0.0, 10.0, FRAC_PI_2, 0.0), g_th), Mode::Bypass);
    // Field ahead: stay even with no field at all left (g is not part of this rule).
    assert_eq!(next_mode(Mode::Bypass, &input(0.0, 0.0, 0.1, 0.0), g_th), Mode::Bypass);
}

#[test]
fn perpendicular_closer_to_goal_is_chosen() {
    // Gradient pointing north-east of the goal (goal east): the clockwise
    // perpendicular (south-east) is closer.
    let t = tangent_towards(FRAC_PI_4, 0.0);
    assert!((t - (-FRAC_PI_4)).abs() < 1e-15);
    // Gradient south-east: counter-clockwise (north-east) is closer.
    let t = tangent_towards(-FRAC_PI_4, 0.0);
    assert!((t - FRAC_PI_4).abs() < 1e-15);
    // Exact tie (gradient along the goal bearing): counter-clockwise.
    let t = tangent_towards(0.0, 0.0);
    assert!((t - FRAC_PI_2).abs() < 1e-15);
    // Wrapping across ±π.
    let t = tangent_towards(PI - 0.1, PI);
    assert!(between(t, PI - 0.1 + FRAC_PI_2) < 1e-12);
}

#[test]
fn mode_two_target_is_tangent() {
    let mut c = Controller::new(cfg());
    // Beacon straight ahead, slightly to the left of the goal direction.
    let out = c.step(&input(0.0, 1.0, 0.2, 0.0));
    assert_eq!(out.mode, Mode::Bypass);
    assert!((out.target - (0.2 - FRAC_PI_2)).abs() < 1e-15);
    assert_eq!(out.motion, Motion::TurnCw);
    assert!((out.rotate + PI / 60.0).abs() < 1e-15);
}

#[test]
fn straight_turn_boundary_at_pi_over_36() {
    let tol = PI / 36.0;
    assert_eq!(choose_motion(tol, tol), Motion::Straight);
    assert_eq!(choose_motion(-tol, tol), Motion::Straight);
    let above = tol * (1.0 + 1e-12);
    assert_eq!(choose_motion(above, tol), Motion::TurnCcw);
    assert_eq!(choose_motion(-above, tol), Motion::TurnCw);
    assert_eq!(choose_motion(0.0, tol), Motion::Straight);
}

#[test]
fn turns_the_short_way_round() {
    let mut c = Controller::new(cfg());
    // Goal just clockwise across the ±π seam: turn ccw (error is +0.2).
    let out = c.step(&input(-PI + 0.1, 0.0, 0.0, PI - 0.1));
    assert_eq!(out.motion, Motion::TurnCcw);
    let out = c.step(&input(PI - 0.1, 0.0, 0.0, -PI + 0.1));
    assert_eq!(out.motion, Motion::TurnCw);
}

#[test]
fn full_bypass_cycle() {
    // Approach a beacon, go round it, come back to mode 1.
    let mut c = Controller::new(cfg());
    assert_eq!(c.step(&input(0.0, 0.1, 0.0, 0.0)).mode, Mode::Goal);
    assert_eq!(c.step(&input(0.0, 0.3, 0.0, 0.0)).mode, Mode::Bypass);
    assert_eq!(c.step(&input(0.0, 0.3, 1.2, -0.4)).mode, Mode::Bypass);
    let out = c.step(&input(0.0, 0.2, 2.0, -0.3));
    assert_eq!(out.mode, Mode::Goal);
    assert_eq!(out.target, 0.0);
}

#[test]
fn cached_steps_equal_plain_steps_bit_for_bit() {
    // Runs of turns with the same field and goal angles (the cache reused),
    // then new angles (refreshed), through both modes; seeded xorshift.
    let mut state = 0x5eed_cafe_f00d_0001u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut plain, mut cached) = (Controller::new(cfg()), Controller::new(cfg()));
    let mut cache = FieldGoal::default();
    let mut modes = [0usize; 2];
    for _ in 0..2_000 {
        let (goal, field, g) = (TAU * next() - PI, TAU * next() - PI, 0.5 * next());
        for _ in 0..8 {
            let i = input(goal, g, field, TAU * next() - PI);
            let (a, b) = (plain.step(&i), cached.step_cached(&i, &mut cache));
            assert_eq!((a.mode, a.motion), (b.mode, b.motion), "{i:?}");
            assert_eq!(a.target.to_bits(), b.target.to_bits(), "{i:?}");
            modes[a.mode as usize - 1] += 1;
        }
    }
    assert!(modes.iter().all(|&n| n > 1_000), "both modes visited: {modes:?}");
}

#[test]
fn cached_tangent_equals_the_compared_one_near_ties() {
    // The field direction at and around the goal bearing and its opposite,
    // float by float and by up to 1e-6 rad (the cache's sign rule and its
    // fallback on either side of the margin).
    let mut seen = 0;
    for goal in [0.0, 0.7, -2.9, PI, -PI + 1e-12, FRAC_PI_2] {
        for base in [goal, wrap(goal + PI)] {
            let mut fields: Vec<f64> =
                (-20i64..=20).map(|d| f64::from_bits((base.to_bits() as i64 + d) as u64)).collect();
            fields.extend((-60..=60).map(|e| base + f64::from(e) * 1.7e-8));
            for field in fields.into_iter().map(wrap) {
                let i = input(goal, 1.0, field, 0.0);
                let mut cache = FieldGoal::default();
                let mut c = Controller::new(cfg());
                c.mode = Mode::Bypass;
                let out = c.step_cached(&i, &mut cache);
                if out.mode == Mode::Bypass {
                    assert_eq!(out.target.to_bits(), tangent_towards(field, goal).to_bits(), "{i:?}");
                    seen += 1;
                }
            }
        }
    }
    assert!(seen > 500, "{seen} bypass periods");
}
