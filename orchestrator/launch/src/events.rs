//! The launch's own JSON channels in a recording, each with a JSON schema:
//! the run's metadata (`bycoms/<swarm>/run`), the agents' comings and
//! goings (`bycoms/<swarm>/events`) and the summary
//! (`bycoms/<swarm>/summary`, [`super::Summary`]).
//!
//! Why typed and not `json!`: a channel's schema comes from the type
//! (`schemars`, like the scene's JSON channels in `bycoms_record::scene::json`), so
//! what is written and what the schema says cannot drift, and Foxglove or
//! any script reads the fields by name.

use super::summary::Point;
use schemars::JsonSchema;
use serde::Serialize;

/// Schema names of the run metadata, events and summary channels (defined
/// with every other schema name in `bycoms_record::schema`).
pub use bycoms_record::schema::{EVENT as EVENT_SCHEMA, RUN as RUN_SCHEMA, SUMMARY as SUMMARY_SCHEMA};

/// What happened to a robot's agent.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum EventKind {
    /// Its agent was started here, or is awaited (remote, a robot's gateway).
    Spawned,
    /// Its agent was lost (see `reason`).
    AgentLost,
    /// Its agent could not be reached any more (link cut or silent); the
    /// launch holds it for the unreachable grace
    /// (`supervision.unreachable_grace`). Named `link_lost` in the
    /// recording's events channel (documented, docs/LAUNCH.md).
    #[serde(rename = "link_lost")]
    Unreachable,
    /// Its agent was heard from again within the unreachable grace. Named
    /// `link_back` in the recording's events channel.
    #[serde(rename = "link_back")]
    Reachable,
    /// Skipped at its turn: its agent never registered (see `reason`).
    Absent,
    /// Its agent registered after its turn was skipped; it takes a later turn.
    JoinedLate,
    /// Its agent's failsafe stopped it: the agent had not heard the
    /// orchestrator for longer than its grace (see `reason`).
    FailsafeFired,
    /// Told `Stop` by a stop asked from outside (`orchestrator stop --now`,
    /// the ROS 2 stop service; `reason` names who and why).
    Stopped,
    /// Revoked (`orchestrator revoke`; `reason` names who and why): told
    /// `Stop`, its agent refused and its reports dropped from then on.
    Revoked,
}

/// One event of a robot's agent.
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
pub struct LaunchEvent {
    /// The robot.
    pub robot: u32,
    /// What happened.
    pub event: EventKind,
    /// `spawned`: the agent's pid when it is a process on this host.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pid: Option<u32>,
    /// `spawned`: the agent source (`spawned`, `remote`, `gateway`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// `agent_lost`: why.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// `agent_lost`: the robot's state in the launch when it was lost.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub state: Option<String>,
}

/// The run's metadata, written first: enough to draw and replay the run.
#[derive(Clone, Debug, Serialize, JsonSchema)]
pub struct RunMeta<'a> {
    /// The swarm name (topic namespace).
    pub swarm: &'a str,
    /// Where the terrain came from (a file or a built-in scenario).
    pub terrain: &'a str,
    /// The terrain in the text format.
    pub terrain_text: &'a str,
    /// The start.
    #[schemars(with = "Point")]
    pub start: bycoms_sim::Vec2,
    /// The goal.
    #[schemars(with = "Point")]
    pub goal: bycoms_sim::Vec2,
    /// The launch configuration, as `deploy/launch.toml` documents it.
    #[schemars(with = "serde_json::Map<String, serde_json::Value>")]
    pub config: &'a super::LaunchConfig,
    /// The poses the launch core applied are on `core/moved`: readers
    /// draw and export those, not the bus's pose topics (which hold every
    /// pose delivered, refused ones too). Absent in older recordings.
    pub applied_poses: bool,
    /// Each ROS 2 robot's velocity topic and message type (robots of
    /// `kind = "ros2"`): where `record export --ros2` puts the commands
    /// their agents reported. Absent without ROS 2 robots.
    #[serde(default, skip_serializing_if = "<[_]>::is_empty")]
    pub ros2_robots: &'a [bycoms_record::schema::Ros2RobotTopic],
    /// The robots with a real body (`lab::real_robots`): every robot of a
    /// launch of real robots but a mixed swarm's simulated members. Absent
    /// when every robot is simulated (and in older recordings).
    #[serde(default, skip_serializing_if = "<[_]>::is_empty")]
    pub real: &'a [u32],
}
