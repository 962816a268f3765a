//! Real robots behind `gateway` processes: one gateway per robot, started
//! here for each robot of a lab's robots file (`deploy/lab/robots.toml`),
//! or started elsewhere (a bridge host next to the robots' access point,
//! over zenoh) and awaited as remote agents are ([`GatewaysAt`]).
//!
//! Why a thin wrapper around [`Spawned`]: a gateway is a child process like
//! a `sim-agent` — same process group, same `--parent-pid` lifeline, same
//! polling and heartbeat watchdog — only its program and flags differ: it
//! is bound to the robot's gateway address with the robot's key, and needs
//! no terrain (the robot lives in the real world). Robots exist
//! independently of the launch, so every gateway is started at the
//! beginning ([`AgentProperties::all_at_once`]): each robot connects while it
//! waits, and the engine enables them one at a time with `Deploy`.
//!
//! Gateways elsewhere: the same rules, with [`Remote`] instead of
//! [`Spawned`] underneath (liveliness tokens and the heartbeat watchdog
//! instead of child processes; a late gateway takes a later turn). Nothing
//! else differs: the engine sees one kind, `gateway`.
//!
//! A robot whose link is lost (its gateway reports `Link { up: false }`
//! after 300 ms of silence) and stays lost for [`LINK_GRACE`] more is gone
//! for the launch: the core's robot-link timer (`orchestrator/launch-core/src/timers.rs`,
//! the grace from [`AgentProperties::robot_link_grace`]) judges it
//! ([`Gone::RobotLinkLost`]) and ends its gateway, and the gate applies its
//! lost-robot policy (`gate.on_agent_death`: a beacon where it was last
//! seen, as a physically stranded robot is) — within 500 ms of the cut.
//! The grace lets a WiFi hiccup, or an emulated lab that stalled for a
//! moment on a busy machine, heal (`Link { up: true }`) without costing a
//! robot. The robot's own failsafe stops its motors 500 ms after its last
//! command either way.

use super::remote::Remote;
use super::spawned::{AgentCommand, Spawned};
use super::{AgentError, AgentPlan, AgentProperties, AgentSource, Gone, Started};
use bycoms_agent::gateway::GatewayArgs;
use bycoms_lab::robots::RobotsFile;
use serde::{Deserialize, Serialize};
use std::time::Duration;

/// Where a launch's gateways run (`agents.gateways`, `--gateways`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum GatewaysAt {
    /// Started here, one per robot of `agents.robots_file` (over ipc, or
    /// over zenoh connecting to this orchestrator).
    #[default]
    Here,
    /// Started by hand on other hosts (`gateway --transport zenoh --connect
    /// ...`), awaited here; needs the zenoh transport.
    Elsewhere,
}

/// The gateways of a launch's real robots.
pub struct Gateways {
    at: At,
    link_timeout_ms: u64,
}

/// What runs the gateways underneath.
enum At {
    /// Started here from the robots file.
    Here { robots: RobotsFile, inner: Spawned },
    /// Awaited.
    Elsewhere(Remote),
}

/// How long a gateway hears nothing from its robot before it reports the
/// robot's link lost (`Link { up: false }`), in robot time (the gateway
/// divides it by the run's speed): the launch core's (it times motion
/// capture's silence by it, `orchestrator/launch-core/src/silence.rs`), owned
/// there; the gateway's own default is the same (checked when this compiles).
pub use bycoms_launch_core::LINK_TIMEOUT;
const _: () = assert!(LINK_TIMEOUT.as_millis() == bycoms_agent::gateway::cli::LINK_TIMEOUT_MS as u128);

/// How long a robot link reported lost must stay lost before the robot is
/// gone (launch time): with the gateway's 300 ms timeout, 450 ms after the
/// cut at real-time speed, under the 500 ms the gate allows itself.
pub const LINK_GRACE: Duration = Duration::from_millis(150);

impl Gateways {
    /// Gateways run here by `gateway` (the `gateway` executable) for `robots`.
    pub fn new(agent: AgentCommand, robots: RobotsFile) -> Self {
        let inner = Spawned::new(agent);
        Self::with(At::Here { robots, inner })
    }

    /// Gateways started elsewhere, awaited through `remote` (see the module
    /// docs).
    pub fn elsewhere(remote: Remote) -> Self {
        Self::with(At::Elsewhere(remote))
    }

    fn with(at: At) -> Self {
        Self { at, link_timeout_ms: LINK_TIMEOUT.as_millis() as u64 }
    }

    fn inner(&self) -> &dyn AgentSource {
        match &self.at {
            At::Here { inner, .. } => inner,
            At::Elsewhere(remote) => remote,
        }
    }

    fn inner_mut(&mut self) -> &mut dyn AgentSource {
        match &mut self.at {
            At::Here { inner, .. } => inner,
            At::Elsewhere(remote) => remote,
        }
    }

    /// The gateway command line of robot `id` (gateways started here): its
    /// robot's address and key, the run's speed and heartbeat, and the bus
    /// of the launch's agents (over zenoh: where this orchestrator listens,
    /// and the robot's own zenoh config). Started with its `to_flags`: the
    /// flags the `gateway` binary parses into the same [`GatewayArgs`].
    pub fn args(&self, id: u32, plan: &AgentPlan<'_>) -> Result<GatewayArgs, AgentError> {
        let At::Here { robots, .. } = &self.at else {
            return Err(AgentError::NoSuchRobot { robot: id, why: "its gateway runs elsewhere".into() });
        };
        let entry = robots.robots.iter().find(|r| r.id == id).ok_or_else(|| AgentError::NoSuchRobot {
            robot: id,
            why: format!("the robots file names robots 1..={}", robots.robots.len()),
        })?;
        let (joining, settings) = (plan.joining, plan.settings);
        Ok(GatewayArgs {
            swarm: joining.swarm.clone(),
            robot: id,
            bind: entry.gateway,
            key_file: robots.key_path(entry),
            swarm_size: Some(settings.swarm_size),
            speed: settings.speed,
            link_timeout_ms: self.link_timeout_ms,
            heartbeat_ms: settings.heartbeat_ms,
            parent_pid: joining.parent_pid,
            bus: joining.bus.clone(),
            failsafe: joining.failsafe,
        })
    }
}

/// What gateway agents are: real robots, one gateway each, all expected
/// at once, placed by an operator, told to stop when stuck, fed the poses
/// motion capture gives (not the beacons: the robots hear each other),
/// their robot links watched; started and ended as `inner` (the spawned
/// gateways of this host, or remote ones on `elsewhere` bridge hosts) does.
pub fn properties(inner: AgentProperties, elsewhere: bool) -> AgentProperties {
    AgentProperties {
        all_at_once: true,
        needs_placement: true,
        stop_when_stuck: true,
        wants_poses: true,
        senses_beacons: false,
        ticks_at_once: 1,
        keeps_commands: false,
        robot_link_grace: Some(LINK_GRACE),
        start_hint: if elsewhere {
            " (start each robot's gateway on its bridge host with `gateway --transport zenoh \
             --connect ENDPOINT --swarm SWARM --robot K --bind ADDR --key-file FILE`)"
        } else {
            ""
        },
        ..AgentProperties { kind: "gateway", ..inner }
    }
}

impl AgentSource for Gateways {
    fn properties(&self) -> AgentProperties {
        properties(self.inner().properties(), matches!(self.at, At::Elsewhere(_)))
    }

    fn start(&mut self, id: u32, plan: &AgentPlan<'_>) -> Result<Started, AgentError> {
        if let At::Elsewhere(remote) = &mut self.at {
            return remote.start(id, plan);
        }
        let flags = self.args(id, plan)?.to_flags();
        let At::Here { inner, .. } = &mut self.at else { unreachable!("matched above") };
        let pid = inner.spawn(id, &flags, "")?;
        Ok(Started::Process { pid })
    }

    forward_to_inner!();
}
