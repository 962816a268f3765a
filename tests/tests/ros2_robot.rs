//! A ROS 2 ground robot's agent (`ros2-robot`) seen by a ROS 2-over-zenoh
//! client that is not ours (`tests/python/ros2_listen.py`: eclipse-zenoh,
//! rosbags, xxhash), and its failsafe.
//!
//! The client plays the lab's router (rmw_zenohd's place); the agent joins
//! it twice, as a swarm member over zenoh and as a ROS 2 node, and a
//! stand-in orchestrator on the same router deploys it, gives it a goal and
//! its poses. The client finds the agent's `cmd_vel` publisher through its
//! liveliness token (its node `bycoms_robot_2`), decodes every sample with
//! rosbags and checks its attachment. Then the agent is ended — the
//! stand-in's liveliness goes (past `--orchestrator-grace` the agent sends
//! zero and exits with 4), or Ctrl-C (zero, then 130) — and the last
//! command the client saw is zero, the last the agent sent. ros2-client's
//! zenoh backend, an independent Rust rmw_zenoh, subscribes to the same
//! `cmd_vel` and decodes the same commands with its own CDR.
//!
//! Needs python3 with the PyPI packages: `#[ignore = "needs …"]`, run by
//! `.ci/run` (which installs them) with `--include-ignored`.

use bycoms_protocol::bus::zenoh::{Mode, ZenohBus};
use bycoms_protocol::bus::BusExt;
use bycoms_protocol::msg::{Deploy, FromAgent, GoalBearing, Pose, ToAgent};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{RobotId, Swarm};
use bycoms_tests::{bin, swarm_name, Proc, PythonClient};
use std::net::TcpListener;
use std::time::{Duration, Instant};

const ROBOT: RobotId = RobotId(2);

/// A `ros2-robot` for robot 2 on a router the independent client plays,
/// deployed by a stand-in orchestrator and driven for twenty control
/// periods.
struct Driven {
    client: PythonClient,
    /// The stand-in orchestrator's liveliness token (`None`: gone).
    alive: Option<bycoms_protocol::bus::zenoh::AliveToken>,
    agent: Proc,
    /// ros2-client's context (kept alive) and its subscription of the
    /// agent's `cmd_vel`.
    oracle: (ros2_client::zenoh::Context, ros2_client::zenoh::Subscription<OracleTwist>),
}

impl Driven {
    fn start() -> Self {
        let port = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port();
        let router = format!("tcp/127.0.0.1:{port}");
        let client = PythonClient::start("ros2_listen.py", &[&router, "0", "0"]);
        assert_eq!(client.line("ready line"), "ready");
        let swarm = Swarm::new(&swarm_name("ros2robot")).expect("swarm");
        let bus =
            ZenohBus::open(bycoms_runtime::zenoh_config(Mode::Client, vec![], vec![router.clone()], None))
                .expect("the stand-in orchestrator's session");
        let alive = bus.declare_alive(&swarm, Member::Orchestrator).expect("orchestrator token");
        let reports = bus.typed_subscriber::<FromAgent>(&swarm.from_agent(ROBOT)).expect("reports");
        let commands = bus.typed_publisher::<ToAgent>(&swarm.to_agent(ROBOT)).expect("commands");
        let poses = bus.typed_publisher::<Pose>(&swarm.pose(ROBOT)).expect("poses");
        let args: Vec<String> = [
            "--swarm",
            swarm.as_str(),
            "--robot",
            "2",
            "--ros2-router",
            &router,
            "--eps",
            "0.3",
            "--transport",
            "zenoh",
            "--connect",
            &router,
            "--orchestrator-grace",
            "0.3",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        // ros2-client's zenoh backend, a second (Rust) client, subscribed as well.
        let oracle = ros2_client_cmd_vel(&router);
        let agent = Proc::start(&bin("ros2-robot"), &args);
        wait_report(&reports, "Register", |m| matches!(m, FromAgent::Register(r) if r.robot == ROBOT));
        commands
            .publish(&ToAgent::Deploy(Deploy { robot: ROBOT, x: 0.0, y: 0.0, heading: 0.0 }))
            .expect("deploy");
        commands
            .publish(&ToAgent::GoalBearing(GoalBearing { robot: ROBOT, bearing: 0.5, step: 0 }))
            .expect("goal");
        // Twenty control periods driving: a fresh pose before each wait.
        let mut driving = 0;
        let deadline = Instant::now() + Duration::from_secs(30);
        while driving < 20 {
            assert!(Instant::now() < deadline, "the agent did not drive 20 periods within 30 s");
            let pose = Pose { robot: ROBOT, x: 0.0, y: 0.0, heading: 0.0, step: 0, time_us: 0 };
            poses.publish(&pose).expect("pose");
            if let Some(FromAgent::Status(s)) = reports.recv_timeout(Duration::from_millis(50)).expect("recv")
            {
                driving += u32::from(s.mode == 1);
            }
        }
        Self { client, alive: Some(alive), agent, oracle }
    }

    /// The agent's end (`code`), and what the client saw: the agent's
    /// `cmd_vel` found in the graph, every sample decoded, none lost, and
    /// the last one zero and the last the agent sent.
    fn ended(mut self, code: i32) -> serde_json::Value {
        let done = self.agent.wait(Duration::from_secs(10));
        assert_eq!(done.status.code(), Some(code), "{}", done.stderr);
        drop(self.alive);
        let report = self.client.report();
        let cmd_vel = &report["topics"]["/robot_2/cmd_vel"];
        assert_eq!(cmd_vel["type"], "geometry_msgs/msg/Twist", "{report}");
        assert_eq!(cmd_vel["node"], "bycoms_robot_2", "{report}");
        assert!(
            report["nodes"]
                .as_array()
                .expect("nodes")
                .iter()
                .any(|n| n.as_str().is_some_and(|n| n.ends_with("/bycoms_robot_2"))),
            "{report}"
        );
        for bad in ["undecoded", "bad_attachment", "bad_gid"] {
            assert_eq!(report[bad], 0, "{bad}: {report}");
        }
        assert_eq!(cmd_vel["contiguous"], true, "no command lost: {report}");
        assert!(cmd_vel["moving"].as_u64().expect("moving") >= 20, "{report}");
        assert_eq!(cmd_vel["last"], serde_json::json!([0.0, 0.0]), "the last command is zero: {report}");
        let sent = sent_commands(&done.stderr);
        assert_eq!(
            cmd_vel["last_seq"].as_u64(),
            Some(sent),
            "the client saw the agent's last command: {report}"
        );
        let mut oracle = Vec::new();
        while let Ok(Some((twist, _info))) = self.oracle.1.try_take() {
            oracle.push(twist);
        }
        let moving = oracle.iter().filter(|t| t.linear.0 != 0.0 || t.angular.2 != 0.0).count();
        assert!(moving >= 20, "ros2-client decoded {moving} moving commands: {oracle:?}");
        let last = oracle.last().expect("ros2-client got commands");
        assert_eq!((last.linear.0, last.angular.2), (0.0, 0.0), "ros2-client's last command is zero too");
        report
    }
}

#[test]
#[ignore = "needs python3 with eclipse-zenoh==1.10.2, rosbags==0.11.9 and xxhash==4.1.0"]
fn a_ros2_client_decodes_every_cmd_vel_and_the_failsafe_ends_with_zero() {
    let mut driven = Driven::start();
    // The orchestrator goes: past the grace the failsafe sends zero and
    // the agent exits with 4.
    driven.alive = None;
    driven.ended(4);
}

/// Ctrl-C (SIGINT; SIGTERM, SIGHUP and SIGQUIT take the same way): zero
/// velocity goes out before the agent exits with 130.
#[test]
#[ignore = "needs python3 with eclipse-zenoh==1.10.2, rosbags==0.11.9 and xxhash==4.1.0"]
fn ctrl_c_sends_zero_before_the_agent_exits() {
    let driven = Driven::start();
    bycoms_tests::signal(driven.agent.pid(), nix::sys::signal::Signal::SIGINT);
    driven.ended(130);
}
/// `geometry_msgs/msg/Twist` as ros2-client's serde CDR reads it (its two
/// vectors, positional), written from the message's definition.
#[derive(serde::Deserialize, Debug)]
struct OracleTwist {
    linear: (f64, f64, f64),
    angular: (f64, f64, f64),
}

/// ros2-client's zenoh backend (an independent Rust rmw_zenoh) on a client
/// session of `router`: its context (kept alive by the caller) and a
/// subscription of robot 2's `cmd_vel` (it listens on any type hash).
fn ros2_client_cmd_vel(
    router: &str,
) -> (ros2_client::zenoh::Context, ros2_client::zenoh::Subscription<OracleTwist>) {
    use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};
    let mut config = zenoh::Config::default();
    for (key, value) in [
        ("mode", "\"client\"".to_owned()),
        ("connect/endpoints", format!("[\"{router}\"]")),
        ("scouting/multicast/enabled", "false".to_owned()),
    ] {
        config.insert_json5(key, &value).unwrap_or_else(|e| panic!("{key}: {e}"));
    }
    let options = ros2_client::zenoh::ContextOptions::new().domain_id(0).zenoh_config(config);
    let context = ros2_client::zenoh::Context::with_options(options).expect("ros2-client's context");
    let name = NodeName::new("/", "oracle").expect("a node name");
    let node = context.new_node(name, NodeOptions::new().enable_rosout(false)).expect("a node");
    let topic = node.create_topic(
        &Name::new("/robot_2", "cmd_vel").expect("a topic name"),
        MessageTypeName::new("geometry_msgs", "Twist"),
        &QosProfile::subscription_default(),
    );
    let subscription = node.create_subscription::<OracleTwist>(&topic, None).expect("a subscription");
    (context, subscription)
}

/// Waits (at most 30 s) for a report `wanted` accepts.
fn wait_report(
    reports: &bycoms_protocol::bus::TypedSubscriber<
        <ZenohBus as bycoms_protocol::bus::Bus>::Subscriber,
        FromAgent,
    >,
    what: &str,
    wanted: impl Fn(&FromAgent) -> bool,
) {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        assert!(!left.is_zero(), "no {what} within 30 s");
        if reports.recv_timeout(left).expect("recv").is_some_and(|m| wanted(&m)) {
            return;
        }
    }
}

/// The commands the agent says it sent, from its exit line (`commands=N`).
fn sent_commands(stderr: &str) -> u64 {
    let line = stderr
        .lines()
        .rev()
        .find(|l| l.contains("ros2-robot exits"))
        .unwrap_or_else(|| panic!("no exit line:\n{stderr}"));
    let field = line
        .split_whitespace()
        .find_map(|w| w.strip_prefix("commands="))
        .unwrap_or_else(|| panic!("no commands= in {line}"));
    field.trim_matches(|c: char| !c.is_ascii_digit()).parse().expect("a count")
}
