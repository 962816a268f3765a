//! The loop on the in-memory bus with a `cmd_vel` that records: what only
//! the loop does (the rules are tested sans-IO in `core/tests.rs`).

use super::*;
use crate::core::Settings;
use bycoms_agent::wheeled::Limits;
use bycoms_protocol::bus::memory::MemoryBus;
use bycoms_protocol::bus::{BusExt, Limits as BusLimits};
use bycoms_protocol::msg::{Deploy, FromAgent, GoalBearing, Pose, ToAgent};
use bycoms_protocol::{RobotId, Swarm};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::{Arc, Mutex};
use std::time::Instant;

const ROBOT: RobotId = RobotId(2);
const WAIT: Duration = Duration::from_secs(10);

/// A `cmd_vel` that hands every command to the test, and keeps them all.
struct Recorded(Sender<Velocity>, Arc<Mutex<Vec<Velocity>>>);

impl CmdVel for Recorded {
    fn send(&mut self, velocity: Velocity) -> Result<(), String> {
        self.1.lock().expect("the list").push(velocity);
        self.0.send(velocity).map_err(|e| e.to_string())
    }
}

/// Waits (at most [`WAIT`]) for a report that `wanted` accepts; every
/// `Commanded` passed on the way is kept in `commanded`.
fn report_where(
    reports: &bycoms_protocol::bus::TypedSubscriber<<MemoryBus as Bus>::Subscriber, FromAgent>,
    commanded: &mut Vec<Velocity>,
    wanted: impl Fn(&FromAgent) -> bool,
) -> FromAgent {
    let deadline = Instant::now() + WAIT;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        assert!(!left.is_zero(), "no such report within {WAIT:?}");
        if let Some(m) = reports.recv_timeout(left).expect("recv") {
            if let FromAgent::Commanded(c) = m {
                commanded.push(Velocity { linear: c.linear, angular: c.angular });
            }
            if wanted(&m) {
                return m;
            }
        }
    }
}

/// Velocities until one that `wanted` accepts, publishing a fresh pose
/// between waits (motion capture keeps seeing the robot).
fn velocity_where(
    got: &Receiver<Velocity>,
    pose: &impl Fn(),
    wanted: impl Fn(&Velocity) -> bool,
) -> Velocity {
    let deadline = Instant::now() + WAIT;
    loop {
        assert!(Instant::now() < deadline, "no such velocity within {WAIT:?}");
        pose();
        if let Ok(v) = got.recv_timeout(Duration::from_millis(50)) {
            if wanted(&v) {
                return v;
            }
        }
    }
}

#[test]
fn the_loop_registers_drives_and_stops_with_zero_before_stop_done() {
    let bus = MemoryBus::new(BusLimits::default()).expect("bus");
    let swarm = Swarm::new("ros2loop").expect("swarm");
    let reports = bus.typed_subscriber::<FromAgent>(&swarm.from_agent(ROBOT)).expect("reports");
    let commands = bus.typed_publisher::<ToAgent>(&swarm.to_agent(ROBOT)).expect("commands");
    let poses = bus.typed_publisher::<Pose>(&swarm.pose(ROBOT)).expect("poses");
    let (tx, got) = channel();
    let published = Arc::new(Mutex::new(Vec::new()));
    let list = Arc::clone(&published);
    let ports = GatewayPorts::open(&bus, &swarm, ROBOT).expect("ports");
    let core = Ros2RobotCore::new(Settings::new(ROBOT, 0.3, Limits::TURTLEBOT3_BURGER));
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let running = std::thread::spawn(move || {
        let mut agent = Ros2Robot::new(core, ports, Recorded(tx, list), Duration::from_millis(50), None);
        let cause = agent.run(&mut Lifeline::with_flag(flag));
        (cause.map_err(|e| e.to_string()), agent.sent())
    });

    let mut reported = Vec::new();
    report_where(&reports, &mut reported, |m| matches!(m, FromAgent::Register(r) if r.robot == ROBOT));
    commands
        .publish(&ToAgent::Deploy(Deploy { robot: ROBOT, x: 0.0, y: 0.0, heading: 0.0 }))
        .expect("deploy");
    commands
        .publish(&ToAgent::GoalBearing(GoalBearing { robot: ROBOT, bearing: 0.0, step: 0 }))
        .expect("goal");
    let pose = || {
        let p = Pose { robot: ROBOT, x: 0.0, y: 0.0, heading: 0.0, step: 0, time_us: 0 };
        poses.publish(&p).expect("pose");
    };
    let driving = velocity_where(&got, &pose, |v| v.linear > 0.0);
    assert_eq!(driving, Velocity { linear: 0.22, angular: 0.0 });

    commands.publish(&ToAgent::Stop).expect("stop");
    report_where(&reports, &mut reported, |m| matches!(m, FromAgent::StopDone(d) if d.robot == ROBOT));
    let before: Vec<Velocity> = got.try_iter().collect();
    assert_eq!(before.last(), Some(&Velocity::ZERO), "the zero went out before StopDone: {before:?}");

    stop.store(true, Ordering::SeqCst);
    let (cause, sent) = running.join().expect("the agent thread");
    assert_eq!(cause, Ok(ExitCause::Signal));
    let after: Vec<Velocity> = got.try_iter().collect();
    assert!(after.iter().all(|v| *v == Velocity::ZERO), "only zeros after the stop: {after:?}");
    assert!(sent.zeros >= 2 && sent.commands > sent.zeros, "{sent:?}");
    // Every command published was reported, in order, with its very f64s.
    let published = published.lock().expect("the list").clone();
    while reported.len() < published.len() {
        report_where(&reports, &mut reported, |m| matches!(m, FromAgent::Commanded(_)));
    }
    assert_eq!(reported, published);
    assert_eq!(published.len() as u64, sent.commands);
}
