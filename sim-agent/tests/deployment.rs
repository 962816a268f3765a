//! The runner's [`Deployment::step`] skips work (cached samples on turns,
//! no goal bearing in mode 1 below threshold); these check that it is
//! exact: it follows `SimRobot::step` — the bearing computed every period —
//! bit for bit, and its cheap mode-1 decision never disagrees with the
//! controller's, even for goal vectors on and next to the boundaries.

use bycoms_agent::angle::wrap;
use bycoms_agent::point::choose_motion;
use bycoms_agent::ControllerConfig;
use bycoms_sim::body::{HeadingTable, Kinematics};
use bycoms_sim::field::Beacons;
use bycoms_sim::robot::{Deployment, MotionCones, SimRobot};
use bycoms_sim::sensing::{NoiseModel, SensingNoise};
use bycoms_sim::Vec2;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// A field of a count drawn from `count` beacons, each somewhere between
/// the start (15.5, 15.5) and the goal (44.5, 44.5).
fn random_beacons(rng: &mut Xoshiro256PlusPlus, count: std::ops::Range<usize>) -> Beacons {
    let mut beacons = Beacons::new(1.0);
    for _ in 0..rng.gen_range(count) {
        beacons.push(Vec2::new(rng.gen_range(16.0..44.0), rng.gen_range(16.0..44.0)));
    }
    beacons
}

#[test]
fn deployment_follows_sim_robot_step_bit_for_bit() {
    let kin = Kinematics::paper();
    let (start, goal) = (Vec2::new(15.5, 15.5), Vec2::new(44.5, 44.5));
    let table = HeadingTable::new(&kin, start.bearing_to(goal)).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
    let (mut cheap_periods, mut turns, mut bypass) = (0usize, 0usize, 0usize);
    for case in 0..60u64 {
        let beacons = random_beacons(&mut rng, 0..40);
        let config = ControllerConfig::paper(rng.gen_range(1.0..5.0));
        let cones = MotionCones::new(&table, config.straight_tolerance);
        let noise = (case % 2 == 1).then(|| SensingNoise::new(NoiseModel::paper(), case));
        let mut plain = SimRobot::new(start, config, noise.clone(), kin.dt);
        let mut d =
            Deployment::new(SimRobot::new(start, config, noise, kin.dt), &table, &cones, &beacons, goal);
        for period in 0..4000 {
            let out = plain.step(&table, &beacons, plain.body.pos.bearing_to(goal));
            let motion = d.step();
            assert_eq!(motion, out.motion, "case {case} period {period}");
            assert_eq!(d.robot.body.state(), plain.body.state(), "case {case} period {period}");
            assert_eq!(d.robot.mode(), plain.mode(), "case {case} period {period}");
            turns += usize::from(motion != bycoms_agent::Motion::Straight);
            bypass += usize::from(plain.mode() == bycoms_agent::Mode::Bypass);
            cheap_periods += usize::from(plain.mode() == bycoms_agent::Mode::Goal);
        }
    }
    assert!(turns > 10_000 && bypass > 10_000 && cheap_periods > 10_000, "{turns} {bypass} {cheap_periods}");
}

/// The bench's field: 100 beacons over the whole arena with ε = 1, where
/// mode 1 spends long stretches near the threshold and the disk bounds are
/// used and renewed most.
#[test]
fn deployment_follows_sim_robot_step_in_a_field_near_threshold() {
    let kin = Kinematics::paper();
    let (start, goal) = (Vec2::new(15.5, 15.5), Vec2::new(44.5, 44.5));
    let table = HeadingTable::new(&kin, start.bearing_to(goal)).unwrap();
    let config = ControllerConfig::paper(1.0);
    let cones = MotionCones::new(&table, config.straight_tolerance);
    for case in 0..8u64 {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(100 + case);
        let mut beacons = Beacons::new(1.0);
        for _ in 0..100 {
            beacons.push(Vec2::new(rng.gen_range(0.0..60.0), rng.gen_range(0.0..60.0)));
        }
        let noise = (case % 2 == 1).then(|| SensingNoise::new(NoiseModel::paper(), case));
        let mut plain = SimRobot::new(start, config, noise.clone(), kin.dt);
        let mut d =
            Deployment::new(SimRobot::new(start, config, noise, kin.dt), &table, &cones, &beacons, goal);
        for period in 0..3000 {
            let out = plain.step(&table, &beacons, plain.body.pos.bearing_to(goal));
            assert_eq!(d.step(), out.motion, "case {case} period {period}");
            assert_eq!(d.robot.body.state(), plain.body.state(), "case {case} period {period}");
            assert_eq!(d.robot.mode(), plain.mode(), "case {case} period {period}");
        }
    }
}

/// Turns in place without noise are done in runs (`Deployment::skip_known_turns`,
/// as the runner does after every turn): after each run the robot must be
/// where `SimRobot::step`, period by period, puts it, in the same mode.
#[test]
fn skipped_turns_follow_sim_robot_step_bit_for_bit() {
    let kin = Kinematics::paper();
    let (start, goal) = (Vec2::new(15.5, 15.5), Vec2::new(44.5, 44.5));
    let table = HeadingTable::new(&kin, start.bearing_to(goal)).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(35);
    let (mut skipped, mut runs) = (0u64, 0u64);
    for case in 0..80u64 {
        let beacons = random_beacons(&mut rng, 1..30);
        let config = ControllerConfig::paper(rng.gen_range(1.0..5.0));
        let cones = MotionCones::new(&table, config.straight_tolerance);
        let mut plain = SimRobot::new(start, config, None, kin.dt);
        let mut d =
            Deployment::new(SimRobot::new(start, config, None, kin.dt), &table, &cones, &beacons, goal);
        let mut period = 0u64;
        while period < 6000 {
            let out = plain.step(&table, &beacons, plain.body.pos.bearing_to(goal));
            let motion = d.step();
            period += 1;
            assert_eq!(motion, out.motion, "case {case} period {period}");
            if motion != bycoms_agent::Motion::Straight {
                // At most to period 6000, as the runner stops at its limit.
                let turns = d.skip_known_turns(6000 - period);
                for _ in 0..turns {
                    let again = plain.step(&table, &beacons, plain.body.pos.bearing_to(goal));
                    assert_eq!(again.motion, motion, "case {case} period {period}: a skipped turn differs");
                }
                period += u64::from(turns);
                skipped += u64::from(turns);
                runs += u64::from(turns > 0);
            }
            assert_eq!(d.robot.body.state(), plain.body.state(), "case {case} period {period}");
            assert_eq!(d.robot.mode(), plain.mode(), "case {case} period {period}");
        }
    }
    assert!(skipped > 100_000 && runs > 5_000, "{skipped} turns skipped in {runs} runs");
}

#[test]
fn cheap_mode_one_decision_agrees_with_the_controller_at_the_boundaries() {
    let kin = Kinematics::paper();
    let config = ControllerConfig::paper(1.0);
    let tol = config.straight_tolerance;
    let table = HeadingTable::new(&kin, 0.7).unwrap();
    let cones = MotionCones::new(&table, tol);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let (mut decided, mut declined) = (0usize, 0usize);
    for _ in 0..200_000 {
        let k = rng.gen_range(0..table.len());
        let h = table.heading(k);
        // Angles on, next to and between the boundaries ±tol, 0 and π.
        let base = [h, h + tol, h - tol, h + core::f64::consts::PI, h + rng.gen_range(-3.2..3.2)]
            [rng.gen_range(0..5)];
        let nudge = [0.0, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9, 1e-6, -1e-6][rng.gen_range(0..9)];
        let len = libm::exp(rng.gen_range(-8.0..5.0));
        let (vx, vy) = (len * libm::cos(base + nudge), len * libm::sin(base + nudge));
        let exact = choose_motion(wrap(libm::atan2(vy, vx) - h), tol);
        match cones.decide(k, vx, vy) {
            Some(m) => {
                assert_eq!(m, exact, "k {k} v ({vx}, {vy})");
                decided += 1;
            }
            None => declined += 1,
        }
    }
    // Nearly everything is decided cheaply; only the near-boundary cases are declined.
    assert!(decided > 100_000 && declined > 10_000, "{decided} decided, {declined} declined");
}

/// Mode 2's noisy turns decided from the offset (`bycoms_sim::bypass`):
/// offsets on, next to and between every boundary of the decision (θfg at
/// 0, ±π/2, ±π; the heading error at ±tol and π on either tangent; goal
/// bearings at ±π/2 from a heading) give the controller's motion, or are
/// declined; a period in which the controller leaves mode 2 is declined.
#[test]
fn noisy_bypass_decision_agrees_with_the_controller_at_the_boundaries() {
    use bycoms_agent::{Controller, Input, Mode};
    use bycoms_sim::bypass::TurnGeometry;
    use core::f64::consts::{FRAC_PI_2, PI};
    let kin = Kinematics::paper();
    let config = ControllerConfig::paper(1.0);
    let tol = config.straight_tolerance;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(36);
    // A controller in mode 2: the field reached straight ahead.
    let mut bypass = Controller::new(config);
    let ahead =
        Input { goal_bearing: 0.0, field_intensity: 1e9, field_direction: 0.0, heading: 0.0, dt: kin.dt };
    assert_eq!(bypass.step(&ahead).mode, Mode::Bypass);
    let (mut decided, mut declined, mut exits, mut no_table) = (0usize, 0usize, 0usize, 0usize);
    for case in 0..4000 {
        let table = HeadingTable::new(&kin, rng.gen_range(-PI..PI)).unwrap();
        let geometry = TurnGeometry::new(&table, tol).expect("the paper's table is regular");
        let k = rng.gen_range(0..table.len());
        let h = table.heading(k);
        let nudge = |rng: &mut Xoshiro256PlusPlus| {
            [0.0, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9, 2e-8, -2e-8, 1e-6][rng.gen_range(0..10)]
        };
        let fd = rng.gen_range(-PI..PI);
        let fg = match case % 3 {
            0 => h + [FRAC_PI_2, -FRAC_PI_2][rng.gen_range(0..2)] + nudge(&mut rng),
            _ => rng.gen_range(-PI..PI),
        };
        let fg = wrap(fg);
        let Some(at) = geometry.at(fd, fg) else {
            no_table += 1;
            continue;
        };
        for _ in 0..50 {
            let boundary = [
                fg - fd + [0.0, FRAC_PI_2, -FRAC_PI_2, PI][rng.gen_range(0..4)],
                h + FRAC_PI_2 - fd + [tol, -tol, PI][rng.gen_range(0..3)],
                h - FRAC_PI_2 - fd + [tol, -tol, PI][rng.gen_range(0..3)],
            ][rng.gen_range(0..3)];
            let offset = match wrap(boundary) + nudge(&mut rng) {
                o if o.abs() <= PI / 6.0 && rng.gen_bool(0.7) => o,
                _ => rng.gen_range(-PI / 6.0..PI / 6.0),
            };
            let input = Input {
                goal_bearing: fg,
                field_intensity: 1e9,
                field_direction: wrap(fd + offset),
                heading: h,
                dt: kin.dt,
            };
            let out = bypass.clone().step(&input);
            exits += usize::from(out.mode == Mode::Goal);
            match at.decide(offset, k) {
                Some((motion, next)) => {
                    assert_eq!(out.mode, Mode::Bypass, "case {case}: decided a period that leaves mode 2");
                    assert_eq!(motion, out.motion, "case {case}: fd {fd} fg {fg} k {k} offset {offset}");
                    let mut body = bycoms_sim::body::Body { pos: Vec2::new(0.0, 0.0), k };
                    body.apply(motion, &table);
                    assert_eq!(next, body.k, "case {case}");
                    decided += 1;
                }
                None => declined += 1,
            }
        }
    }
    assert!(decided > 100_000 && declined > 10_000, "{decided} decided, {declined} declined");
    assert!(exits > 1000 && no_table > 100, "{exits} exits, {no_table} positions without a table");
}
