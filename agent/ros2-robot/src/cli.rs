//! The `ros2-robot` command line and `main`.
//!
//! Exit codes, as the gateway's and `sim-agent`'s (the runtime's one
//! mapping, `ExitCause::exit_code`): 0 after `Shutdown` or the parent's
//! death; 130 after Ctrl-C (or SIGTERM / SIGHUP / SIGQUIT); 3 when another
//! agent holds the robot; 4 over zenoh when the orchestrator was gone past
//! `--orchestrator-grace`; 2 for a usage error; 1 for any other error
//! (bus, ROS 2 graph), printed first. The robot is sent zero velocity on
//! every way out but `kill -9` (then its driver's own `cmd_vel` timeout
//! stops it: `deploy/ros2/README.md`).
//!
//! One typed builder: whoever starts the agent fills a [`Ros2RobotArgs`]
//! and passes its [`Ros2RobotArgs::to_flags`]; the binary parses them back
//! ([`parse_from`]), and the round-trip test holds the two together.

use crate::cmd_vel::{Target, ZenohCmdVel};
use crate::core::{Ros2RobotCore, Settings};
use crate::run::{Ros2Robot, RunError};
use bycoms_agent::gateway::run::GatewayPorts;
use bycoms_agent::wheeled::Limits;
use bycoms_protocol::bus::zenoh::clock::ClockProbe;
use bycoms_protocol::bus::zenoh::AliveWatch;
use bycoms_protocol::bus::{Bus, BusError};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{NameError, RobotId, Swarm};
use bycoms_ros2::velocity::VelocityMessage;
use bycoms_runtime::failsafe::{Failsafe, FailsafeArgs};
use bycoms_runtime::lifeline::LifelineError;
use bycoms_runtime::logging::LogArgs;
use bycoms_runtime::{BusArgs, BusOpenError, ExitCause, Lifeline, OnBus};
use clap::Parser;
use std::time::Duration;

/// One ROS 2 ground robot's BYCOMS agent: senses the field virtually from
/// the beacons the launch sends and its pose from motion capture, runs the
/// paper's drive law and publishes velocity commands on the robot's
/// `cmd_vel` over rmw_zenoh.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct Ros2RobotArgs {
    /// Swarm name: the namespace of the run's topics.
    #[arg(long)]
    pub swarm: String,
    /// The robot's id (1-based deployment order).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub robot: u32,
    /// The ROS 2 graph's zenoh router (the lab's `rmw_zenohd`,
    /// `tcp/HOST:7447`), joined as a client.
    #[arg(long, value_name = "ENDPOINT")]
    pub ros2_router: String,
    /// `ROS_DOMAIN_ID` of the graph.
    #[arg(long, default_value_t = 0)]
    pub domain_id: u32,
    /// The namespace of the agent's node (`/` or `/name…`).
    #[arg(long, default_value = "/")]
    pub namespace: String,
    /// The robot's velocity topic (default `<namespace>/robot_<k>/cmd_vel`).
    #[arg(long, value_name = "TOPIC")]
    pub cmd_vel: Option<String>,
    /// Its message type: `twist` (geometry_msgs/msg/Twist) or
    /// `twist-stamped` (TwistStamped, as Jazzy's diff_drive_controller takes).
    #[arg(long, default_value_t = VelocityMessage::Twist)]
    pub message: VelocityMessage,
    /// The frame of a TwistStamped's header.
    #[arg(long, default_value = "base_link")]
    pub frame_id: String,
    /// ε, metres: the contour held around a lone stopped robot (g_th = 1/ε²).
    #[arg(long)]
    pub eps: f64,
    /// Largest forward speed, m/s (default: a TurtleBot 3 Burger's).
    #[arg(long, default_value_t = Limits::TURTLEBOT3_BURGER.linear)]
    pub max_linear: f64,
    /// Largest turn rate, rad/s.
    #[arg(long, default_value_t = Limits::TURTLEBOT3_BURGER.angular)]
    pub max_angular: f64,
    /// Distance between the wheels, m.
    #[arg(long, default_value_t = Limits::TURTLEBOT3_BURGER.wheel_base)]
    pub wheel_base: f64,
    /// One velocity command per this many ms.
    #[arg(long, default_value_t = 100, value_parser = bycoms_runtime::seconds::millis)]
    pub period_ms: u64,
    /// No pose from motion capture for this long (ms): zero velocity.
    #[arg(long, default_value_t = 300, value_parser = bycoms_runtime::seconds::millis)]
    pub pose_timeout_ms: u64,
    /// Robots in the swarm: sizes the shared-memory services, the same for
    /// every process of the swarm (default: this robot's id).
    #[arg(long)]
    pub swarm_size: Option<u32>,
    /// Speed-up of the robot's clock (an emulated lab running faster than
    /// real time): the control period, the pose timeout and the stop's
    /// repeat are divided by it; velocities stay in the robot's m/s.
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Bus heartbeat period, ms.
    #[arg(long, default_value_t = bycoms_protocol::msg::HEARTBEAT_MS, value_parser = bycoms_runtime::seconds::millis)]
    pub heartbeat_ms: u64,
    /// The orchestrator's pid; the agent exits when its parent is no
    /// longer this process (default: its parent at start).
    #[arg(long, value_parser = bycoms_runtime::lifeline::parent_pid)]
    pub parent_pid: Option<i32>,
    /// The swarm's bus: iceoryx2 on the orchestrator's host, or zenoh.
    #[command(flatten)]
    pub bus: BusArgs,
    /// zenoh: the failsafe when the orchestrator is lost.
    #[command(flatten)]
    pub failsafe: FailsafeArgs,
}

impl Ros2RobotArgs {
    /// Robot `robot` of `swarm` holding ε = `eps`, its graph's router at
    /// `ros2_router`, every other flag at its default.
    pub fn new(swarm: impl Into<String>, robot: u32, ros2_router: impl Into<String>, eps: f64) -> Self {
        Self {
            swarm: swarm.into(),
            robot,
            ros2_router: ros2_router.into(),
            domain_id: 0,
            namespace: "/".into(),
            cmd_vel: None,
            message: VelocityMessage::Twist,
            frame_id: "base_link".into(),
            eps,
            max_linear: Limits::TURTLEBOT3_BURGER.linear,
            max_angular: Limits::TURTLEBOT3_BURGER.angular,
            wheel_base: Limits::TURTLEBOT3_BURGER.wheel_base,
            period_ms: 100,
            pose_timeout_ms: 300,
            swarm_size: None,
            speed: 1.0,
            heartbeat_ms: bycoms_protocol::msg::HEARTBEAT_MS,
            parent_pid: None,
            bus: BusArgs::default(),
            failsafe: FailsafeArgs::default(),
        }
    }

    /// The robot's limits.
    pub fn limits(&self) -> Limits {
        Limits { linear: self.max_linear, angular: self.max_angular, wheel_base: self.wheel_base }
    }

    /// The velocity topic.
    pub fn cmd_vel_topic(&self) -> String {
        match &self.cmd_vel {
            Some(topic) => topic.clone(),
            None => format!("{}/robot_{}/cmd_vel", self.namespace.trim_end_matches('/'), self.robot),
        }
    }

    /// Where its velocity commands go.
    pub fn target(&self) -> Target {
        Target {
            router: self.ros2_router.clone(),
            domain_id: self.domain_id,
            namespace: self.namespace.clone(),
            robot: self.robot,
            topic: self.cmd_vel_topic(),
            message: self.message,
            frame_id: self.frame_id.clone(),
        }
    }

    /// The core's settings (their times in wall time: divided by `speed`).
    pub fn settings(&self) -> Settings {
        let wall = |d: Duration| d.div_f64(self.speed);
        let paper = Settings::new(RobotId(self.robot), self.eps, self.limits());
        Settings {
            period: wall(Duration::from_millis(self.period_ms)),
            pose_timeout: wall(Duration::from_millis(self.pose_timeout_ms)),
            stop_repeat: wall(paper.stop_repeat),
            ..paper
        }
    }

    /// Checks what clap cannot.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.eps.is_finite() && self.eps > 0.0) {
            return Err(format!("--eps must be a positive number of metres, got {}", self.eps));
        }
        self.limits().check().map_err(|e| format!("{e} (--max-linear, --max-angular, --wheel-base)"))?;
        bycoms_runtime::check_speed(self.speed).map_err(|e| format!("--speed: {e}"))?;
        if self.period_ms == 0 {
            return Err("--period-ms must be at least 1".into());
        }
        if self.pose_timeout_ms < self.period_ms {
            return Err(format!(
                "--pose-timeout-ms ({}) is shorter than a control period (--period-ms {}): the robot would never drive",
                self.pose_timeout_ms, self.period_ms
            ));
        }
        bycoms_runtime::cli::check_swarm_size(self.robot, self.swarm_size)?;
        self.failsafe.grace()?;
        self.bus.validate()
    }

    /// The flags that reproduce these arguments (what a launcher passes).
    pub fn to_flags(&self) -> Vec<String> {
        let mut v: Vec<String> = [
            ("--swarm", self.swarm.clone()),
            ("--robot", self.robot.to_string()),
            ("--ros2-router", self.ros2_router.clone()),
            ("--domain-id", self.domain_id.to_string()),
            ("--namespace", self.namespace.clone()),
            ("--message", self.message.as_str().into()),
            ("--frame-id", self.frame_id.clone()),
            ("--eps", format!("{:?}", self.eps)),
            ("--max-linear", format!("{:?}", self.max_linear)),
            ("--max-angular", format!("{:?}", self.max_angular)),
            ("--wheel-base", format!("{:?}", self.wheel_base)),
            ("--period-ms", self.period_ms.to_string()),
            ("--speed", format!("{:?}", self.speed)),
            ("--pose-timeout-ms", self.pose_timeout_ms.to_string()),
            ("--heartbeat-ms", self.heartbeat_ms.to_string()),
        ]
        .into_iter()
        .flat_map(|(flag, value)| [flag.to_string(), value])
        .collect();
        let optional = [
            ("--cmd-vel", self.cmd_vel.clone()),
            ("--swarm-size", self.swarm_size.map(|n| n.to_string())),
            ("--parent-pid", self.parent_pid.map(|n| n.to_string())),
        ];
        for (flag, value) in optional {
            if let Some(value) = value {
                v.extend([flag.to_string(), value]);
            }
        }
        v.extend(self.bus.to_flags());
        v.extend(self.failsafe.to_flags());
        v
    }
}

/// The whole `ros2-robot` command line: the agent's flags and the logging flags.
#[derive(Clone, Debug, Parser)]
#[command(name = "ros2-robot", version)]
pub struct Command {
    /// The agent.
    #[command(flatten)]
    pub robot: Ros2RobotArgs,
    /// Logging.
    #[command(flatten)]
    pub log: LogArgs,
}

/// Parses a `ros2-robot` command line (`argv[0]` first).
pub fn parse_from<I, T>(argv: I) -> Result<Command, clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    Command::try_parse_from(argv)
}

/// Why the agent could not run.
#[derive(Debug, thiserror::Error)]
pub enum Ros2RobotError {
    /// A flag has an unusable value.
    #[error("{0}")]
    Args(String),
    /// The swarm name is not a valid topic chunk.
    #[error("bad swarm name: {0}")]
    Swarm(#[from] NameError),
    /// The ROS 2 graph could not be joined, or the publisher declared.
    #[error("{0}")]
    Graph(String),
    /// The bus failed.
    #[error("bus: {0}")]
    Bus(#[from] BusError),
    /// The loop failed.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The parent-death link could not be set up.
    #[error(transparent)]
    Lifeline(#[from] LifelineError),
}

/// Runs one agent; returns the process exit code.
pub fn main_with(args: &Ros2RobotArgs) -> i32 {
    let _span = tracing::info_span!("ros2-robot", robot = args.robot).entered();
    bycoms_runtime::cli::agent_main(
        || run(args),
        |e| match e {
            Ros2RobotError::Args(_) | Ros2RobotError::Swarm(_) => 2,
            _ => 1,
        },
    )
}

fn run(args: &Ros2RobotArgs) -> Result<ExitCause, Ros2RobotError> {
    let mut lifeline = Lifeline::install(args.parent_pid)?;
    args.validate().map_err(Ros2RobotError::Args)?;
    let swarm = Swarm::new(&args.swarm)?;
    let id = RobotId(args.robot);
    let cmd_vel = ZenohCmdVel::open(&args.target()).map_err(Ros2RobotError::Graph)?;
    let size = args.swarm_size.unwrap_or(args.robot).max(args.robot);
    let node = format!("bycoms-{}-ros2-robot-{}", swarm.as_str(), id.0);
    let then = RunAgent { args, swarm: &swarm, cmd_vel, lifeline: &mut lifeline, clock: None };
    args.bus.open(&swarm, Some(Member::Agent(id)), Some(&args.failsafe), size, node, then).map_err(|e| {
        match e {
            BusOpenError::Args(a) => Ros2RobotError::Args(a),
            BusOpenError::Bus(b) => Ros2RobotError::Bus(b),
        }
    })?
}

/// The agent's loop once the bus is open.
struct RunAgent<'a> {
    args: &'a Ros2RobotArgs,
    swarm: &'a Swarm,
    cmd_vel: ZenohCmdVel,
    lifeline: &'a mut Lifeline,
    /// zenoh: this host's clock offset to the orchestrator's, measured.
    clock: Option<ClockProbe>,
}

impl OnBus for RunAgent<'_> {
    type Output = Result<ExitCause, Ros2RobotError>;
    fn clock(&mut self, probe: ClockProbe) {
        self.clock = Some(probe);
    }
    fn run<B: Bus>(self, bus: &B, failsafe: Option<(Failsafe, AliveWatch)>) -> Self::Output {
        let args = self.args;
        let ports = GatewayPorts::open(bus, self.swarm, RobotId(args.robot))?;
        let core = Ros2RobotCore::new(args.settings());
        let heartbeat = Duration::from_millis(args.heartbeat_ms);
        let mut agent = Ros2Robot::new(core, ports, self.cmd_vel, heartbeat, failsafe);
        if let Some(probe) = self.clock {
            agent.report_clock(probe);
        }
        tracing::info!(
            cmd_vel = %args.cmd_vel_topic(),
            message = args.message.as_str(),
            transport = args.bus.transport.as_str(),
            "ros2-robot driving its robot"
        );
        let cause = agent.run(self.lifeline)?;
        let sent = agent.sent();
        tracing::info!(
            ?cause,
            commands = sent.commands,
            zeros = sent.zeros,
            bad_messages = agent.traffic().total(),
            "ros2-robot exits"
        );
        Ok(cause)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_flags_a_launcher_builds_parse_back_into_the_same_arguments() {
        let mut args = Ros2RobotArgs::new("lab", 3, "tcp/127.0.0.1:7447", 0.3);
        let back =
            parse_from(std::iter::once("ros2-robot".to_string()).chain(args.to_flags())).expect("parses");
        assert_eq!(back.robot, args);
        args.cmd_vel = Some("/tb3_3/cmd_vel".into());
        args.message = VelocityMessage::TwistStamped;
        args.swarm_size = Some(5);
        args.max_linear = 0.1;
        args.speed = 3.0;
        let back =
            parse_from(std::iter::once("ros2-robot".to_string()).chain(args.to_flags())).expect("parses");
        assert_eq!(back.robot, args);
    }

    #[test]
    fn the_velocity_topic_defaults_under_the_namespace() {
        let mut args = Ros2RobotArgs::new("lab", 3, "tcp/127.0.0.1:7447", 0.3);
        assert_eq!(args.cmd_vel_topic(), "/robot_3/cmd_vel");
        args.namespace = "/bycoms".into();
        assert_eq!(args.cmd_vel_topic(), "/bycoms/robot_3/cmd_vel");
    }

    #[test]
    fn unusable_values_are_refused_naming_the_flag() {
        let base = Ros2RobotArgs::new("lab", 3, "tcp/127.0.0.1:7447", 0.3);
        let cases: [(Ros2RobotArgs, &str); 5] = [
            (Ros2RobotArgs { eps: 0.0, ..base.clone() }, "--eps"),
            (Ros2RobotArgs { max_angular: -1.0, ..base.clone() }, "--max-angular"),
            (Ros2RobotArgs { wheel_base: f64::NAN, ..base.clone() }, "--wheel-base"),
            (Ros2RobotArgs { pose_timeout_ms: 50, ..base.clone() }, "--pose-timeout-ms"),
            (Ros2RobotArgs { speed: 0.0, ..base.clone() }, "speed"),
        ];
        for (args, flag) in cases {
            let why = args.validate().expect_err(flag);
            assert!(why.contains(flag), "{why}");
        }
        assert_eq!(base.validate(), Ok(()));
    }
}
