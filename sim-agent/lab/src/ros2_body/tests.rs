//! The ROS 2 body in virtual time: 5 ms steps, commands at chosen lab times.

use super::*;
use crate::body::arena_walls;

const DT: Duration = Duration::from_millis(5);
const BURGER: Limits = Limits::TURTLEBOT3_BURGER;

fn exact(timeout_ms: u64) -> DiffDriveConfig {
    DiffDriveConfig { slip: 0.0, ..DiffDriveConfig::new(BURGER, 0.1, Duration::from_millis(timeout_ms)) }
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// Runs `body` for `steps` steps from `from`, commanding `v` every
/// `every` steps (never when `every` is 0).
fn run(body: &mut DiffDrive, from: Duration, steps: u32, every: u32, v: Velocity, obstacles: &[Obstacle]) {
    for k in 0..steps {
        let now = from + DT * k;
        if every > 0 && k % every == 0 {
            body.command(now, v);
        }
        body.step(now, DT, obstacles, &[]);
    }
}

fn velocity(linear: f64, angular: f64) -> Velocity {
    Velocity { linear, angular }
}

#[test]
fn a_forward_command_drives_straight_at_v_after_the_latency() {
    let mut b = DiffDrive::new(exact(500), 0.0, 0.0, 0.0, 1);
    run(&mut b, Duration::ZERO, 1000, 20, velocity(0.2, 0.0), &[]);
    // 1000 steps of 5 ms; the first 4 (20 ms) wait out the latency.
    assert!((b.x - 0.2 * 0.005 * 996.0).abs() < 1e-9, "{b:?}");
    assert!(b.y.abs() < 1e-12 && b.heading == 0.0, "{b:?}");
}

#[test]
fn a_turn_command_turns_in_place_counter_clockwise() {
    let mut b = DiffDrive::new(exact(500), 1.0, 1.0, 0.0, 1);
    run(&mut b, Duration::ZERO, 200, 20, velocity(0.0, 1.0), &[]);
    assert!((b.heading - 1.0 * 0.005 * 196.0).abs() < 1e-9, "{b:?}");
    assert!((b.x - 1.0).abs() < 1e-12 && (b.y - 1.0).abs() < 1e-12, "{b:?}");
    // A turn while driving: an arc to the left.
    let mut b = DiffDrive::new(exact(500), 1.0, 1.0, 0.0, 1);
    run(&mut b, Duration::ZERO, 200, 20, velocity(0.1, 0.5), &[]);
    assert!(b.y > 1.0 && b.heading > 0.4, "{b:?}");
}

#[test]
fn the_wheel_limits_clamp_each_wheel_and_the_turn_rate() {
    let too_fast = wheel_speeds(velocity(1.0, 0.0), &BURGER);
    assert_eq!(too_fast, (0.22, 0.22));
    // ω clamped to 2.84 rad/s, then each wheel (±0.2272 m/s) to 0.22 m/s.
    let spin = body_velocity(wheel_speeds(velocity(0.0, 10.0), &BURGER), BURGER.wheel_base);
    assert!(spin.linear.abs() < 1e-12 && (spin.angular - 0.44 / 0.16).abs() < 1e-9, "{spin:?}");
    // Full speed and a turn: the outer wheel saturates, both v and ω give.
    let arc = body_velocity(wheel_speeds(velocity(0.22, 1.0), &BURGER), BURGER.wheel_base);
    assert!((arc.linear - 0.18).abs() < 1e-9 && (arc.angular - 0.5).abs() < 1e-9, "{arc:?}");
    let mut b = DiffDrive::new(exact(500), 0.0, 0.0, 0.0, 1);
    run(&mut b, Duration::ZERO, 204, 20, velocity(5.0, 0.0), &[]);
    assert!((b.x - 0.22).abs() < 1e-9, "one second at the limit: {b:?}");
}

#[test]
fn a_command_acts_only_after_the_latency() {
    let mut b = DiffDrive::new(exact(500), 0.0, 0.0, 0.0, 1);
    b.command(ms(100), velocity(0.2, 0.0));
    let mut moved_at = None;
    for k in 0..60 {
        let now = DT * k;
        b.step(now, DT, &[], &[]);
        if moved_at.is_none() && b.x > 0.0 {
            moved_at = Some(now);
        }
    }
    assert_eq!(moved_at, Some(ms(120)), "arrived at 100 ms, acts 20 ms later");
    assert_eq!(b.acting(), velocity(0.2, 0.0));
}

#[test]
fn without_commands_for_the_timeout_the_driver_stops_it() {
    let mut b = DiffDrive::new(exact(300), 0.0, 0.0, 0.0, 1);
    b.command(Duration::ZERO, velocity(0.2, 0.0));
    run(&mut b, Duration::ZERO, 400, 0, Velocity::ZERO, &[]);
    // Heard at 20 ms, stopped at 320 ms: 300 ms at 0.2 m/s.
    assert!((b.x - 0.06).abs() < 1e-9, "{b:?}");
    assert_eq!(b.acting(), Velocity::ZERO);
    assert!(!b.stuck);
    // A new command drives it again.
    run(&mut b, ms(2000), 100, 20, velocity(0.2, 0.0), &[]);
    assert!(b.x > 0.1, "{b:?}");
    // A command that is not a number stops it.
    b.command(ms(3000), velocity(f64::NAN, 0.0));
    let x = b.x;
    run(&mut b, ms(3000), 100, 0, Velocity::ZERO, &[]);
    assert!((b.x - x).abs() < 0.005 && b.x.is_finite(), "{b:?}");
}

#[test]
fn slip_is_seeded_small_and_deterministic() {
    let slipping = DiffDriveConfig::new(BURGER, 0.1, ms(500));
    let trip = |seed| {
        let mut b = DiffDrive::new(slipping, 0.0, 0.0, 0.0, seed);
        run(&mut b, Duration::ZERO, 1000, 20, velocity(0.2, 0.0), &[]);
        b
    };
    let (a, again, other) = (trip(7), trip(7), trip(8));
    assert_eq!((a.x, a.y, a.heading), (again.x, again.y, again.heading), "same seed, same trip");
    assert_ne!((a.x, a.y, a.heading), (other.x, other.y, other.heading), "another seed, another trip");
    let nominal = 0.2 * 0.005 * 996.0;
    assert!((a.x - nominal).abs() < 0.02 * nominal, "{a:?}");
    assert!(a.heading != 0.0 && a.heading.abs() < 0.1, "the wheels slip unevenly: {a:?}");
}

#[test]
fn a_wall_or_another_body_stops_it_where_it_touched() {
    let walls = arena_walls(2.0, 2.0);
    let mut b = DiffDrive::new(exact(500), 1.0, 1.0, 0.0, 1);
    run(&mut b, Duration::ZERO, 2000, 20, velocity(0.2, 0.0), &walls);
    assert!(b.stuck, "{b:?}");
    assert!(b.x < 2.0 - 0.1 && b.x > 2.0 - 0.1 - 0.002, "stopped a radius from the wall: {b:?}");
    assert_eq!(b.acting(), Velocity::ZERO);
    let x = b.x;
    run(&mut b, ms(10_000), 100, 20, velocity(-0.2, 0.0), &walls);
    assert_eq!(b.x, x, "stuck for good");
    let mut b = DiffDrive::new(exact(500), 0.0, 0.0, 0.0, 1);
    for k in 0..1000 {
        if k % 20 == 0 {
            b.command(DT * k, velocity(0.2, 0.0));
        }
        b.step(DT * k, DT, &[], &[(1.0, 0.0)]);
    }
    assert!(b.stuck && (1.0 - b.x - 0.2).abs() < 0.002, "{b:?}");
}
