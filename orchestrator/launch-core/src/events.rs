//! What happened to a robot's agent, as the core puts it out
//! (`Output::Event`): one [`LaunchEvent`] of an [`EventKind`].
//!
//! Why here: the core decides every event, so it owns their type; the
//! recording writes them on its events channel (`bycoms/<swarm>/events`,
//! with a JSON schema: `bycoms_launch::events`, which re-exports them at
//! their old path).

use schemars::JsonSchema;
use serde::Serialize;

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
