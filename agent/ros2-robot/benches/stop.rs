//! `Stop` → zero velocity on the robot's `cmd_vel`, and a fresh pose → the
//! next command, as a ROS 2 subscriber sees them: the agent's real loop on a
//! thread, its swarm bus iceoryx2 or zenoh, its `cmd_vel` a real rmw_zenoh
//! publisher on a zenoh router of this process; a stand-in orchestrator
//! deploys it, gives it a goal and poses, then stops it, again and again.
//!
//! `cargo bench -p bycoms-ros2-robot --bench stop` (`BYCOMS_BENCH_SAMPLES=N` for more or
//! fewer rounds; default 300 per transport). Prints p50, p99 and the worst
//! of each figure. Wall-clock figures belong here, never in a test.

use bycoms_agent::gateway::run::GatewayPorts;
use bycoms_agent::wheeled::Limits;
use bycoms_protocol::bus::ipc::{IpcBus, IpcConfig};
use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
use bycoms_protocol::bus::{Bus, BusExt};
use bycoms_protocol::msg::{Deploy, FromAgent, GoalBearing, Pose, ToAgent};
use bycoms_protocol::{RobotId, Swarm};
use bycoms_ros2::msgs::Twist;
use bycoms_ros2::rmw_zenoh::topic_key_expr;
use bycoms_ros2::velocity::VelocityMessage;
use bycoms_ros2_robot::cmd_vel::{Target, ZenohCmdVel};
use bycoms_ros2_robot::core::{Ros2RobotCore, Settings};
use bycoms_ros2_robot::run::Ros2Robot;
use bycoms_runtime::stats::quantile;
use bycoms_runtime::{ipc_config, Lifeline};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver};
use std::sync::Arc;
use std::time::{Duration, Instant};
use zenoh::Wait;

const ROBOT: RobotId = RobotId(1);
const WAIT: Duration = Duration::from_secs(5);

fn main() {
    let rounds: usize =
        std::env::var("BYCOMS_BENCH_SAMPLES").ok().and_then(|s| s.parse().ok()).unwrap_or(300);
    let (router, endpoint) = ZenohBus::loopback_router(|e| ZenohConfig {
        mode: Mode::Router,
        listen: vec![e.to_string()],
        ..ZenohConfig::default()
    })
    .expect("a zenoh router");
    let commands = subscribe_cmd_vel(&router);
    println!("ros2-robot: Stop → zero on cmd_vel, pose → command (ms), {rounds} rounds each");
    let ipc = measure("ipc", rounds, &commands, &endpoint, |swarm| {
        let config = IpcConfig { node_name: Some(format!("bycoms-bench-{swarm}")), ..ipc_config(1) };
        IpcBus::new(config).expect("iceoryx2")
    });
    let zenoh_endpoint = endpoint.clone();
    let zenoh = measure("zenoh", rounds, &commands, &endpoint, move |_| {
        let config = bycoms_runtime::zenoh_config(Mode::Client, vec![], vec![zenoh_endpoint.clone()], None);
        ZenohBus::open(config).expect("a zenoh client")
    });
    for (name, figures) in [("ipc", ipc), ("zenoh", zenoh)] {
        print_figures(name, &figures);
    }
}

/// The two figures of one transport, ns.
struct Figures {
    stop: Vec<u64>,
    pose: Vec<u64>,
}

fn print_figures(name: &str, f: &Figures) {
    let ms = |v: &[u64], q: f64| quantile(v, q).map_or(f64::NAN, |n| n as f64 / 1e6);
    let worst = |v: &[u64]| v.iter().max().map_or(f64::NAN, |&n| n as f64 / 1e6);
    println!(
        "  {name:5}  Stop → zero: p50 {:.3}  p99 {:.3}  worst {:.3}   pose → command: p50 {:.3}  p99 {:.3}  worst {:.3}",
        ms(&f.stop, 0.5),
        ms(&f.stop, 0.99),
        worst(&f.stop),
        ms(&f.pose, 0.5),
        ms(&f.pose, 0.99),
        worst(&f.pose)
    );
}

/// Every `cmd_vel` sample of robot 1, decoded, with when it arrived.
fn subscribe_cmd_vel(router: &ZenohBus) -> Receiver<(Instant, Twist)> {
    let description = VelocityMessage::Twist.description();
    let key = topic_key_expr(0, "/robot_1/cmd_vel", description.name, &description.rihs01());
    let (tx, rx) = channel();
    let subscriber = router
        .session()
        .declare_subscriber(key)
        .callback(move |sample| {
            if let Ok(twist) = Twist::from_cdr(&sample.payload().to_bytes()) {
                let _ = tx.send((Instant::now(), twist));
            }
        })
        .wait()
        .expect("cmd_vel subscriber");
    // Held for the whole bench.
    std::mem::forget(subscriber);
    rx
}

/// One transport's rounds: the agent on a thread over the bus `open` makes.
fn measure<B: Bus + 'static>(
    name: &str,
    rounds: usize,
    commands: &Receiver<(Instant, Twist)>,
    endpoint: &str,
    open: impl Fn(&str) -> B + Send + Clone + 'static,
) -> Figures {
    let swarm = Swarm::new(&format!("r2bench{name}{}", std::process::id())).expect("swarm");
    let stop = Arc::new(AtomicBool::new(false));
    let agent = spawn_agent(&swarm, endpoint, Arc::clone(&stop), open.clone());
    let bus = open(&format!("{}-orchestrator", swarm.as_str()));
    let reports = bus.typed_subscriber::<FromAgent>(&swarm.from_agent(ROBOT)).expect("reports");
    let to_agent = bus.typed_publisher::<ToAgent>(&swarm.to_agent(ROBOT)).expect("commands");
    let poses = bus.typed_publisher::<Pose>(&swarm.pose(ROBOT)).expect("poses");
    wait_for(&|| reports.recv_timeout(WAIT).ok().flatten(), |m| matches!(m, FromAgent::Register(_)));
    let mut figures = Figures { stop: Vec::with_capacity(rounds), pose: Vec::with_capacity(rounds) };
    let pose = Pose { robot: ROBOT, x: 0.0, y: 0.0, heading: 0.0, step: 0, time_us: 0 };
    for _ in 0..rounds {
        while commands.try_recv().is_ok() {}
        to_agent
            .publish(&ToAgent::Deploy(Deploy { robot: ROBOT, x: 0.0, y: 0.0, heading: 0.0 }))
            .expect("deploy");
        to_agent
            .publish(&ToAgent::GoalBearing(GoalBearing { robot: ROBOT, bearing: 0.0, step: 0 }))
            .expect("goal");
        let posed = Instant::now();
        poses.publish(&pose).expect("pose");
        let (at, _) = next_where(commands, |t| t.linear.0.x > 0.0);
        figures.pose.push(at.duration_since(posed).as_nanos() as u64);
        let asked = Instant::now();
        to_agent.publish(&ToAgent::Stop).expect("stop");
        let (at, _) = next_where(commands, |t| t.linear.0.x == 0.0 && t.angular.0.z == 0.0);
        figures.stop.push(at.duration_since(asked).as_nanos() as u64);
        wait_for(&|| reports.recv_timeout(WAIT).ok().flatten(), |m| matches!(m, FromAgent::StopDone(_)));
    }
    stop.store(true, Ordering::SeqCst);
    agent.join().expect("the agent thread");
    figures
}

/// The agent's real loop on its own thread (an iceoryx2 bus is confined
/// to the thread that opened it), a control period of 20 ms.
fn spawn_agent<B: Bus + 'static>(
    swarm: &Swarm,
    endpoint: &str,
    stop: Arc<AtomicBool>,
    open: impl Fn(&str) -> B + Send + 'static,
) -> std::thread::JoinHandle<()> {
    let (swarm, endpoint) = (*swarm, endpoint.to_string());
    std::thread::spawn(move || {
        let bus = open(&format!("{}-agent", swarm.as_str()));
        let ports = GatewayPorts::open(&bus, &swarm, ROBOT).expect("ports");
        let settings = Settings {
            period: Duration::from_millis(20),
            ..Settings::new(ROBOT, 0.3, Limits::TURTLEBOT3_BURGER)
        };
        let target = Target {
            router: endpoint,
            domain_id: 0,
            namespace: "/".into(),
            robot: ROBOT.0,
            topic: "/robot_1/cmd_vel".into(),
            message: VelocityMessage::Twist,
            frame_id: "base_link".into(),
        };
        let cmd_vel = ZenohCmdVel::open(&target).expect("cmd_vel");
        let mut agent =
            Ros2Robot::new(Ros2RobotCore::new(settings), ports, cmd_vel, Duration::from_millis(100), None);
        agent.run(&mut Lifeline::with_flag(stop)).expect("the agent's loop");
    })
}

/// The next sample that `wanted` accepts (at most [`WAIT`] away).
fn next_where(commands: &Receiver<(Instant, Twist)>, wanted: impl Fn(&Twist) -> bool) -> (Instant, Twist) {
    let deadline = Instant::now() + WAIT;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let (at, twist) = commands.recv_timeout(left).expect("a cmd_vel sample within 5 s");
        if wanted(&twist) {
            return (at, twist);
        }
    }
}

/// Waits (at most [`WAIT`]) until `next` gives a report `wanted` accepts.
fn wait_for(next: &dyn Fn() -> Option<FromAgent>, wanted: impl Fn(&FromAgent) -> bool) {
    let deadline = Instant::now() + WAIT;
    while Instant::now() < deadline {
        if next().is_some_and(|m| wanted(&m)) {
            return;
        }
    }
    panic!("no such report within {WAIT:?}");
}
