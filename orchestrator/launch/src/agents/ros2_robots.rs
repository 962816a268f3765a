//! ROS 2 ground robots (`kind = "ros2"` in the robots file): one
//! `ros2-robot` agent process per robot, started here.
//!
//! Why its own source, a thin wrapper around [`Spawned`] as the gateways'
//! is: its agents are child processes like `sim-agent`'s (process group,
//! `--parent-pid` lifeline, polling, heartbeat watchdog); what differs is
//! what the core is told of them, as properties, never as a kind name:
//! an operator places each robot and motion capture confirms it, a stuck
//! robot is told `Stop`, the trusted poses are forwarded (each agent senses
//! the field at its own pose), and — unlike an acoustic robot's gateway —
//! the agents sense the beacons they are sent (the paper's §IV field, in
//! metres). A ROS 2 robot has no robot link the launch watches: its driver
//! is the graph's business, and an agent that cannot publish ends.

use super::spawned::{AgentCommand, Spawned};
use super::{AgentError, AgentPlan, AgentProperties, AgentSource, Gone, Started};
use bycoms_lab::robots::{RobotsFile, Ros2Entry};
use bycoms_ros2_robot::cli::Ros2RobotArgs;

/// Where the robots' agents join the ROS 2 graph.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Graph {
    /// The graph's zenoh router (`ros2.router`, or the launch's own endpoint).
    pub router: String,
    /// `ROS_DOMAIN_ID`.
    pub domain_id: u32,
    /// The namespace of the agents' nodes and default topics.
    pub namespace: String,
}

/// The agents of a launch's ROS 2 robots.
pub struct Ros2Robots {
    robots: Vec<Ros2Entry>,
    graph: Graph,
    inner: Spawned,
}

impl Ros2Robots {
    /// The agents of `robots`' ROS 2 robots, run by `agent` (the
    /// `ros2-robot` executable), joining `graph`.
    pub fn new(agent: AgentCommand, robots: &RobotsFile, graph: Graph) -> Self {
        Self { robots: robots.ros2.clone(), graph, inner: Spawned::new(agent) }
    }

    /// Robot `id`'s agent command line: its robot's topic, message and
    /// limits from the robots file, ε from the run's settings (metres in a
    /// lab), the graph, and the bus of the launch's agents. Started with
    /// its `to_flags`: the flags `ros2-robot` parses into the same
    /// [`Ros2RobotArgs`].
    pub fn args(&self, id: u32, plan: &AgentPlan<'_>) -> Result<Ros2RobotArgs, AgentError> {
        let entry = self.robots.iter().find(|r| r.id == id).ok_or_else(|| AgentError::NoSuchRobot {
            robot: id,
            why: format!("the robots file names ROS 2 robots 1..={}", self.robots.len()),
        })?;
        let (joining, settings) = (plan.joining, plan.settings);
        Ok(Ros2RobotArgs {
            domain_id: self.graph.domain_id,
            namespace: self.graph.namespace.clone(),
            cmd_vel: entry.cmd_vel.clone(),
            message: entry.message,
            frame_id: entry.frame_id.clone(),
            max_linear: entry.limits.linear,
            max_angular: entry.limits.angular,
            wheel_base: entry.limits.wheel_base,
            swarm_size: Some(settings.swarm_size),
            speed: settings.speed,
            heartbeat_ms: settings.heartbeat_ms,
            parent_pid: joining.parent_pid,
            bus: joining.bus.clone(),
            failsafe: joining.failsafe,
            ..Ros2RobotArgs::new(joining.swarm.clone(), id, self.graph.router.clone(), settings.eps)
        })
    }
}

/// Each ROS 2 robot of `file` among robots `1..=robots`: its velocity
/// topic (the file's, else under `namespace`), message and frame, for the
/// run metadata (`ros2_robots`) that `record export --ros2` reads.
pub fn recorded_topics(
    file: &RobotsFile,
    namespace: &str,
    robots: u32,
) -> Vec<bycoms_record::schema::Ros2RobotTopic> {
    file.ros2
        .iter()
        .filter(|r| (1..=robots).contains(&r.id))
        .map(|r| bycoms_record::schema::Ros2RobotTopic {
            robot: r.id,
            cmd_vel: r.topic(namespace),
            message: r.message.as_str().into(),
            r#type: r.message.description().name.into(),
            frame_id: r.frame_id.clone(),
        })
        .collect()
}

impl Ros2Robots {
    fn inner(&self) -> &dyn AgentSource {
        &self.inner
    }

    fn inner_mut(&mut self) -> &mut dyn AgentSource {
        &mut self.inner
    }
}

/// What ROS 2 robots' agents are: real robots, all expected at once,
/// placed by an operator, told to stop when stuck, fed the poses motion
/// capture gives and the beacons (their field is virtual); started and
/// ended as `inner` (the spawned `ros2-robot` processes) does.
pub fn properties(inner: AgentProperties) -> AgentProperties {
    AgentProperties {
        all_at_once: true,
        needs_placement: true,
        stop_when_stuck: true,
        wants_poses: true,
        senses_beacons: true,
        ticks_at_once: 1,
        keeps_commands: false,
        start_hint: "",
        robot_link_grace: None,
        ..AgentProperties { kind: "ros2_robot", ..inner }
    }
}

impl AgentSource for Ros2Robots {
    fn properties(&self) -> AgentProperties {
        properties(self.inner().properties())
    }

    fn start(&mut self, id: u32, plan: &AgentPlan<'_>) -> Result<Started, AgentError> {
        let flags = self.args(id, plan)?.to_flags();
        let pid = self.inner.spawn(id, &flags, "")?;
        Ok(Started::Process { pid })
    }

    forward_to_inner!();
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_ros2::velocity::VelocityMessage;

    fn entry(id: u32, cmd_vel: Option<&str>, message: VelocityMessage) -> Ros2Entry {
        Ros2Entry {
            id,
            cmd_vel: cmd_vel.map(String::from),
            message,
            frame_id: "base_link".into(),
            limits: bycoms_agent::wheeled::Limits::TURTLEBOT3_BURGER,
            cmd_vel_timeout: std::time::Duration::from_millis(500),
        }
    }

    #[test]
    fn the_recorded_topics_are_the_agents_own_for_the_launchs_robots() {
        let file = RobotsFile {
            robots: Vec::new(),
            ros2: vec![
                entry(1, Some("/tb3_1/cmd_vel"), VelocityMessage::Twist),
                entry(2, None, VelocityMessage::TwistStamped),
                entry(3, None, VelocityMessage::Twist),
            ],
            sim: Vec::new(),
            dir: ".".into(),
        };
        let topics = recorded_topics(&file, "/lab", 2);
        let got: Vec<_> = topics
            .iter()
            .map(|t| (t.robot, t.cmd_vel.as_str(), t.message.as_str(), t.r#type.as_str()))
            .collect();
        assert_eq!(
            got,
            [
                (1, "/tb3_1/cmd_vel", "twist", "geometry_msgs/msg/Twist"),
                (2, "/lab/robot_2/cmd_vel", "twist-stamped", "geometry_msgs/msg/TwistStamped"),
            ],
            "robot 3 is not one of the launch's two"
        );
        assert_eq!(topics[1].frame_id, "base_link");
    }
}
