//! The ROS 2 robot's rules on a hand-driven clock: no bus, no zenoh.

use super::*;
use bycoms_agent::gateway::{Input, Session};
use bycoms_protocol::msg::{Deploy, GoalBearing};
use bycoms_protocol::SansIo;
use bycoms_runtime::failsafe::{Failsafe, OnOrchestratorLost};
use std::f64::consts::FRAC_PI_2;

const ME: RobotId = RobotId(3);

/// `n` ms, in the core's µs.
fn ms(n: u64) -> Micros {
    n * 1000
}

fn core() -> Ros2RobotCore {
    Ros2RobotCore::new(Settings::new(ME, 0.3, Limits::TURTLEBOT3_BURGER))
}

fn pose(x: f64, y: f64, heading: f64) -> Pose {
    Pose { robot: ME, x, y, heading, step: 0, time_us: 0 }
}

fn deploy() -> ToAgent {
    ToAgent::Deploy(Deploy { robot: ME, x: 0.0, y: 0.0, heading: 0.0 })
}

fn goal(bearing: f64) -> ToAgent {
    ToAgent::GoalBearing(GoalBearing { robot: ME, bearing, step: 0 })
}

fn beacon(robot: u32, x: f64, y: f64, seq: u32) -> ToAgent {
    ToAgent::Beacon(Beacon { robot: RobotId(robot), x, y, seq })
}

/// Everything queued, in order.
fn drain(c: &mut impl RobotSide<Output = Output>) -> Vec<Output> {
    std::iter::from_fn(|| c.poll()).collect()
}

fn velocities(outs: &[Output]) -> Vec<Velocity> {
    outs.iter()
        .filter_map(|o| match o {
            Output::Velocity(v) => Some(*v),
            Output::Report(_) => None,
        })
        .collect()
}

/// The `Status` reports among `outs`.
fn statuses(outs: &[Output]) -> Vec<Status> {
    outs.iter()
        .filter_map(|o| match o {
            Output::Report(FromAgent::Status(s)) => Some(*s),
            _ => None,
        })
        .collect()
}

/// A deployed robot at the origin facing +x with the goal ahead, polled once.
fn driving(t0: Micros) -> Ros2RobotCore {
    let mut c = core();
    c.on_command(t0, &deploy()).expect("deploy");
    c.on_command(t0, &goal(0.0)).expect("goal");
    c.on_pose(&pose(0.0, 0.0, 0.0));
    c.advance(t0);
    c
}

#[test]
fn a_deployed_robot_with_goal_and_pose_drives_once_per_period() {
    let t0: Micros = 0;
    let mut c = driving(t0);
    let outs = drain(&mut c);
    assert_eq!(velocities(&outs), [Velocity { linear: 0.22, angular: 0.0 }]);
    assert!(matches!(statuses(&outs)[..], [Status { mode: 1, step: 1, .. }]), "{outs:?}");
    assert_eq!(c.deadline(), Some(t0 + ms(100)));
    c.advance(t0 + ms(50));
    assert!(drain(&mut c).is_empty(), "nothing between periods");
    c.on_pose(&pose(0.02, 0.0, 0.0));
    c.advance(t0 + ms(100));
    assert_eq!(velocities(&drain(&mut c)).len(), 1);
}

#[test]
fn before_deploy_nothing_is_sent() {
    let t0: Micros = 0;
    let mut c = core();
    c.on_command(t0, &goal(0.0)).expect("goal");
    c.on_pose(&pose(0.0, 0.0, 0.0));
    c.advance(t0);
    assert!(drain(&mut c).is_empty());
    assert_eq!(c.deadline(), None);
}

#[test]
fn without_a_fresh_pose_or_a_goal_it_sends_zero() {
    let t0: Micros = 0;
    let mut c = core();
    c.on_command(t0, &deploy()).expect("deploy");
    c.on_pose(&pose(0.0, 0.0, 0.0));
    c.advance(t0);
    assert_eq!(velocities(&drain(&mut c)), [Velocity::ZERO], "no goal yet");
    c.on_command(t0, &goal(0.0)).expect("goal");
    c.advance(t0 + ms(100));
    assert_eq!(velocities(&drain(&mut c)), [Velocity { linear: 0.22, angular: 0.0 }]);
    // Motion capture falls silent: 300 ms after the last pose, zero.
    c.advance(t0 + ms(200));
    assert_ne!(velocities(&drain(&mut c)), [Velocity::ZERO]);
    c.advance(t0 + ms(300));
    assert_eq!(velocities(&drain(&mut c)), [Velocity::ZERO]);
}

#[test]
fn stop_sends_zero_at_once_then_every_period_for_a_second_and_answers_after_it() {
    let t0: Micros = 0;
    let mut c = driving(t0);
    drain(&mut c);
    let t = t0 + ms(30);
    assert_eq!(c.on_command(t, &ToAgent::Stop), Ok(false));
    let outs = drain(&mut c);
    assert_eq!(outs[0], Output::Velocity(Velocity::ZERO), "zero first");
    assert!(matches!(outs[1], Output::Report(FromAgent::Commanded(_))), "{outs:?}");
    assert_eq!(outs[2], Output::Report(FromAgent::StopDone(StopDone { robot: ME, on_link: true })));
    let mut zeros = 0;
    let mut now = t;
    while let Some(due) = c.deadline() {
        assert!(due > now, "the deadline moves on");
        now = due;
        c.advance(now);
        let sent = velocities(&drain(&mut c));
        assert!(sent.iter().all(|v| *v == Velocity::ZERO), "{sent:?}");
        zeros += sent.len();
    }
    assert_eq!(zeros, 9, "every 100 ms for a second after the first");
    assert!(now <= t + ms(1100));
    // Poses and goals after a stop move nothing.
    c.on_command(now, &goal(1.0)).expect("goal");
    c.advance(now + ms(500));
    assert!(drain(&mut c).is_empty());
}

#[test]
fn shutdown_and_the_agents_own_end_send_zero() {
    let t0: Micros = 0;
    let mut c = driving(t0);
    drain(&mut c);
    assert_eq!(c.on_command(t0, &ToAgent::Shutdown), Ok(true));
    assert_eq!(velocities(&drain(&mut c)), [Velocity::ZERO]);
    let mut c = driving(t0);
    drain(&mut c);
    c.stop_robot(t0);
    assert_eq!(velocities(&drain(&mut c)), [Velocity::ZERO]);
    assert!(!c.enabled());
}

#[test]
fn the_field_is_the_simulations_sum_over_the_beacons_in_robot_order() {
    let t0: Micros = 0;
    let mut c = core();
    c.on_command(t0, &beacon(2, 1.0, 0.0, 1)).expect("beacon");
    c.on_command(t0, &beacon(1, 0.0, 2.0, 2)).expect("beacon");
    let mut sim = Beacons::new(1.0);
    sim.push(Vec2::new(0.0, 2.0));
    sim.push(Vec2::new(1.0, 0.0));
    let p = Vec2::new(0.25, 0.5);
    let field = c.field_at(p);
    assert_eq!(field.intensity.to_bits(), sim.sample(p).intensity.to_bits());
    assert_eq!(field.gradient, Some(sim.sample(p).direction()));
    // A creeping beacon moves; robot 2 now farther away.
    c.on_command(t0, &beacon(2, 3.0, 0.0, 3)).expect("beacon");
    assert!(c.field_at(p).intensity < field.intensity);
    assert_eq!(core().field_at(p), FieldReading { intensity: 0.0, gradient: None });
}

#[test]
fn bad_commands_are_refused_and_change_nothing() {
    let t0: Micros = 0;
    let mut c = core();
    assert_eq!(c.on_command(t0, &beacon(3, 1.0, 1.0, 1)), Err(Refused::WrongRobot { got: 3, mine: 3 }));
    assert_eq!(c.on_command(t0, &beacon(1, f64::NAN, 1.0, 1)), Err(Refused::NotFinite));
    assert_eq!(c.field_at(Vec2::new(0.0, 0.0)).gradient, None);
    let other = ToAgent::Deploy(Deploy { robot: RobotId(4), x: 0.0, y: 0.0, heading: 0.0 });
    assert!(c.on_command(t0, &other).is_err());
    assert!(!c.enabled());
    assert_eq!(c.on_command(t0, &goal(f64::INFINITY)), Err(Refused::NotFinite));
    let tick = ToAgent::Tick(bycoms_protocol::msg::Tick { step: 1 });
    assert_eq!(c.on_command(t0, &tick), Err(Refused::Tick));
}

#[test]
fn near_a_beacon_ahead_it_turns_along_the_field() {
    let t0: Micros = 0;
    let mut c = core();
    c.on_command(t0, &beacon(1, 0.25, 0.0, 1)).expect("beacon");
    c.on_command(t0, &deploy()).expect("deploy");
    c.on_command(t0, &goal(0.0)).expect("goal");
    c.on_pose(&pose(0.0, 0.0, 0.0));
    c.advance(t0);
    let outs = drain(&mut c);
    assert!(matches!(statuses(&outs)[..], [Status { mode: 2, .. }]), "{outs:?}");
    let turn = velocities(&outs)[0].angular;
    assert!(turn.abs() > 1.0, "it turns hard towards a tangent: {turn}");
    // Facing the tangent, it drives on.
    c.on_pose(&pose(0.0, 0.0, FRAC_PI_2 * turn.signum()));
    c.advance(t0 + ms(100));
    assert!(velocities(&drain(&mut c))[0].linear > 0.1);
}

#[test]
fn the_sessions_failsafe_stops_the_robot_with_zero() {
    let t0: Micros = 0;
    let failsafe = Failsafe::new(Duration::from_millis(500), OnOrchestratorLost::Exit);
    let mut s = Session::new(driving(t0), Duration::from_millis(100), 9, Some(failsafe));
    s.handle(t0, Input::Start).expect("started");
    s.handle(t0, Input::Orchestrator { alive: true }).expect("alive");
    assert_eq!(advance_session(&mut s, t0), None);
    drain_session(&mut s);
    s.handle(t0 + ms(10), Input::Orchestrator { alive: false }).expect("lost");
    assert_eq!(advance_session(&mut s, t0 + ms(400)), None, "within the grace");
    drain_session(&mut s);
    let exit = advance_session(&mut s, t0 + ms(520));
    assert_eq!(exit, Some(bycoms_runtime::ExitCause::OrchestratorLost));
    let outs = drain_session(&mut s);
    assert!(velocities(&outs).contains(&Velocity::ZERO), "{outs:?}");
    assert!(!s.core().enabled());
}

fn drain_session(s: &mut Session<Ros2RobotCore>) -> Vec<Output> {
    std::iter::from_fn(|| s.poll()).collect()
}

/// Advances the session to `now`: why it ended, if it did.
fn advance_session(s: &mut Session<Ros2RobotCore>, now: Micros) -> Option<bycoms_runtime::ExitCause> {
    s.advance(now);
    s.exit()
}

#[test]
fn a_period_without_a_new_pose_waits_for_it_and_commands_as_it_comes() {
    let t0: Micros = 0;
    let mut c = driving(t0);
    assert_eq!(velocities(&drain(&mut c)).len(), 1);
    // Due at 100 ms, no new pose: nothing yet, the deadline at the pose timeout.
    c.advance(t0 + ms(100));
    assert!(drain(&mut c).is_empty(), "no command from a pose already used");
    assert_eq!(c.deadline(), Some(t0 + ms(300)));
    // The pose comes at 130 ms: the command goes out with it.
    c.on_pose(&pose(0.02, 0.0, 0.0));
    c.advance(t0 + ms(130));
    assert_eq!(velocities(&drain(&mut c)), [Velocity { linear: 0.22, angular: 0.0 }]);
    assert_eq!(c.deadline(), Some(t0 + ms(230)), "the next period from this command");
}

/// Each velocity output and the report right after it.
fn commanded_pairs(outs: &[Output]) -> Vec<(Velocity, Commanded)> {
    outs.iter()
        .enumerate()
        .filter_map(|(i, o)| match (o, outs.get(i + 1)) {
            (Output::Velocity(v), Some(Output::Report(FromAgent::Commanded(c)))) => Some((*v, *c)),
            (Output::Velocity(v), next) => panic!("{v:?} not followed by its Commanded but {next:?}"),
            _ => None,
        })
        .collect()
}

#[test]
fn every_command_is_reported_right_after_it_with_the_very_f64s_and_the_field() {
    let t0: Micros = 0;
    let mut c = core();
    let mut outs = Vec::new();
    c.on_command(t0, &beacon(1, 0.25, 0.1, 1)).expect("beacon");
    c.on_command(t0, &deploy()).expect("deploy");
    c.advance(t0);
    outs.extend(drain(&mut c)); // no goal yet: a zero no field decided
    c.on_command(t0, &goal(0.3)).expect("goal");
    let mut now = t0;
    for k in 1..=5u32 {
        now = t0 + ms(100 * u64::from(k));
        c.on_pose(&pose(0.01 * f64::from(k), 0.0, 0.1 * f64::from(k)));
        c.advance(now);
        outs.extend(drain(&mut c));
    }
    c.on_command(now + ms(10), &ToAgent::Stop).expect("stop");
    outs.extend(drain(&mut c));
    while let Some(due) = c.deadline() {
        c.advance(due);
        outs.extend(drain(&mut c));
    }
    let pairs = commanded_pairs(&outs);
    assert_eq!(pairs.len(), velocities(&outs).len(), "one report per command");
    assert_eq!(pairs.len(), 1 + 5 + 10, "a zero, five driven, a stop's ten zeros");
    for (v, cmd) in &pairs {
        assert_eq!(cmd.robot, ME);
        assert_eq!((cmd.linear.to_bits(), cmd.angular.to_bits()), (v.linear.to_bits(), v.angular.to_bits()));
    }
    let driven = &pairs[1..6];
    for (k, ((_, cmd), status)) in driven.iter().zip(statuses(&outs)).enumerate() {
        assert_eq!(cmd.step, status.step, "the command's step is its Status's");
        let at = 0.01 * (k + 1) as f64;
        let field = c.field_at(Vec2::new(at, 0.0));
        let sensed = Sensed { intensity: field.intensity, gradient: field.gradient };
        assert_eq!(cmd.sensed, Some(sensed), "the field at the pose it came from");
    }
    assert!(driven.iter().any(|(v, _)| *v != Velocity::ZERO), "it drove");
    assert_eq!((pairs[0].1.step, pairs[0].1.sensed), (0, None));
    for (v, cmd) in &pairs[6..] {
        assert_eq!((*v, cmd.step, cmd.sensed), (Velocity::ZERO, 5, None), "a stop's zeros");
    }
}
