//! `sim-agent lab` with a ROS 2 robot, in-process: a zenoh router on a free
//! port plays the lab's rmw_zenohd and carries the lab's bus too; the test
//! plays the operator's launch (a placement request on
//! `bycoms/<swarm>/operator`) and the robot's agent (`Twist` samples put on
//! the robot's `cmd_vel` key, as rmw_zenoh puts them), and watches the pose
//! the lab publishes on `robot/1/pose`. Every wait has a deadline.

use crate::process::{run_with, LabArgs};
use bycoms_protocol::bus::zenoh::{Mode, ZenohBus};
use bycoms_protocol::bus::BusExt;
use bycoms_protocol::msg::{Deploy, Pose};
use bycoms_protocol::{RobotId, Swarm};
use bycoms_ros2::msgs::{RosMessage, Twist};
use bycoms_ros2::rmw_zenoh::topic_key_expr;
use bycoms_runtime::lifeline::Lifeline;
use bycoms_runtime::{zenoh_config, BusArgs, Transport};
use std::net::{Ipv4Addr, TcpListener};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use zenoh::Wait;

const SCENARIO: &str =
    "name = \"one\"\nwidth = 3.0\nheight = 2.0\nstart = { x = 0.5, y = 0.5, heading = 0.0 }\n\
                        goal = { x = 2.5, y = 1.5 }\ngoal_radius = 0.15\ntones = [224.0]\n";
const ROBOTS: &str = "[[robot]]\nid = 1\nkind = \"ros2\"\ncmd_vel_timeout = 0.3\n";

fn free_endpoint() -> String {
    let port =
        TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).and_then(|l| l.local_addr()).expect("a free port").port();
    format!("tcp/127.0.0.1:{port}")
}

/// The newest pose received within `wait`, if any.
fn latest(poses: &impl Fn(Duration) -> Option<Pose>, wait: Duration) -> Option<Pose> {
    let deadline = Instant::now() + wait;
    let mut last = None;
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        if let Some(p) = poses(left.min(Duration::from_millis(20))) {
            last = Some(p);
        }
    }
    last
}

#[test]
fn the_lab_process_drives_a_ros2_robot_by_its_cmd_vel_and_its_driver_stops_it() {
    let endpoint = free_endpoint();
    let _router =
        ZenohBus::open(zenoh_config(Mode::Router, vec![endpoint.clone()], vec![], None)).expect("router");
    let dir = tempfile::tempdir().expect("temp dir");
    let (scenario, robots) = (dir.path().join("one.toml"), dir.path().join("robots.toml"));
    std::fs::write(&scenario, SCENARIO).expect("scenario");
    std::fs::write(&robots, ROBOTS).expect("robots");
    let swarm_name = format!("ros2lab{}", std::process::id());
    let mut args = LabArgs::new(scenario.display().to_string(), robots, swarm_name.clone());
    args.speed = 2.0;
    args.ros2_router = Some(endpoint.clone());
    args.bus = BusArgs { transport: Transport::Zenoh, connect: vec![endpoint.clone()], zenoh_config: None };
    let stop = Arc::new(AtomicBool::new(false));
    let lifeline = Lifeline::with_flag(Arc::clone(&stop));
    // The lab's thread says when it ended, so the test waits on that, bounded.
    let (ended_tx, ended) = std::sync::mpsc::channel();
    let lab = std::thread::spawn(move || {
        let result = run_with(&args, lifeline).map_err(|e| e.to_string());
        let _ = ended_tx.send(());
        result
    });

    let bus = ZenohBus::open(zenoh_config(Mode::Client, vec![], vec![endpoint], None)).expect("test's bus");
    let swarm = Swarm::new(&swarm_name).expect("swarm");
    let poses = bus.typed_subscriber::<Pose>(&swarm.pose(RobotId(1))).expect("poses");
    let operator = bus.typed_publisher::<Deploy>(&swarm.operator()).expect("operator");
    let next = |wait| poses.recv_timeout(wait).ok().flatten();
    // The operator is asked until the robot shows up at the start.
    let deadline = Instant::now() + Duration::from_secs(30);
    let placed = loop {
        assert!(Instant::now() < deadline, "the lab never placed the robot");
        operator.publish(&Deploy { robot: RobotId(1), x: 0.5, y: 0.5, heading: 0.0 }).expect("ask");
        if let Some(p) = latest(&next, Duration::from_millis(200)) {
            break p;
        }
    };
    assert_eq!((placed.x, placed.y, placed.heading), (0.5, 0.5, 0.0));

    // The agent: an undecodable sample, then 0.15 m/s and 0.5 rad/s (within the
    // Burger's wheel limits) at 20 Hz for 1 s (2 s of lab time).
    let key = topic_key_expr(0, "/robot_1/cmd_vel", Twist::DESCRIPTION.name, &Twist::DESCRIPTION.rihs01());
    let session = bus.session();
    session.put(key.as_str(), vec![0u8, 1, 0, 0, 7]).wait().expect("put garbage");
    let driving = Instant::now() + Duration::from_secs(1);
    while Instant::now() < driving {
        session.put(key.as_str(), Twist::planar(0.15, 0.5).to_cdr()).wait().expect("put a Twist");
        latest(&next, Duration::from_millis(50));
    }
    // Its driver stops it 0.3 s of lab time (0.15 s here) after the last one.
    let settled = latest(&next, Duration::from_millis(500)).expect("poses while settling");
    let still = latest(&next, Duration::from_millis(700)).expect("poses while still");
    stop.store(true, Ordering::SeqCst);
    assert!(ended.recv_timeout(Duration::from_secs(10)).is_ok(), "the lab did not stop when told");
    assert!(lab.join().expect("the lab's thread").is_ok(), "the lab ran and stopped cleanly");

    let chord = (settled.x - placed.x).hypot(settled.y - placed.y);
    assert!(chord > 0.1 && chord < 0.6, "moved as commanded, about 0.3 m: {settled:?}");
    assert!(settled.y > placed.y && settled.heading > 0.3, "turned left: {settled:?}");
    // An arc of curvature ω/v = 3.33 per metre: its chord is 2 sin(θ/2) / curvature.
    let curvature = 2.0 * (settled.heading / 2.0).sin() / chord;
    assert!((3.0..3.7).contains(&curvature), "curvature {curvature}: {settled:?}");
    assert_eq!((still.x, still.y, still.heading), (settled.x, settled.y, settled.heading), "stopped");
    assert!(still.time_us > settled.time_us, "poses kept coming: {settled:?} {still:?}");
}
