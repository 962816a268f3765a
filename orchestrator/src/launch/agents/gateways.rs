//! Real robots behind `agent` gateways: one gateway per robot, started
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
//! beginning ([`AgentSource::all_at_once`]): each robot connects while it
//! waits, and the engine enables them one at a time with `Deploy`.
//!
//! Gateways elsewhere: the same rules, with [`Remote`] instead of
//! [`Spawned`] underneath (liveliness tokens and the heartbeat watchdog
//! instead of child processes; a late gateway takes a later turn). Nothing
//! else differs: the engine sees one kind, `gateway`.
//!
//! A robot whose link is lost (its gateway reports `Link { up: false }`
//! after 300 ms of silence) and stays lost for [`LINK_GRACE`] more is gone
//! for the launch: [`AgentSource::poll`] reports it
//! ([`Gone::RobotLinkLost`]) and ends its gateway, and the gate applies its
//! lost-robot policy (`gate.on_agent_death`: a beacon where it was last
//! seen, as a physically stranded robot is) — within 500 ms of the cut.
//! The grace lets a WiFi hiccup, or an emulated lab that stalled for a
//! moment on a busy machine, heal (`Link { up: true }`) without costing a
//! robot. The robot's own failsafe stops its motors 500 ms after its last
//! command either way.

use super::remote::Remote;
use super::spawned::{AgentCommand, Spawned};
use super::{AgentError, AgentPlan, AgentSource, Gone, Reach, Started};
use bycoms_agent::gateway::GatewayArgs;
use bycoms_sim::lab::robots::RobotsFile;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// Where a launch's gateways run (`agents.gateways`, `--gateways`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum GatewaysAt {
    /// Started here, one per robot of `agents.robots_file` (over ipc, or
    /// over zenoh connecting to this orchestrator).
    #[default]
    Here,
    /// Started by hand on other hosts (`agent --transport zenoh --connect
    /// ...`), awaited here; needs the zenoh transport.
    Elsewhere,
}

/// The gateways of a launch's real robots.
pub struct Gateways {
    at: At,
    link_timeout_ms: u64,
    /// Robots whose link was reported lost, since when (not yet reported
    /// by `poll`, not restored).
    lost_links: BTreeMap<u32, Instant>,
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
/// divides it by the run's speed).
pub const LINK_TIMEOUT: Duration = Duration::from_millis(300);

/// How long a robot link reported lost must stay lost before the robot is
/// gone (wall time): with the gateway's 300 ms timeout, 450 ms after the
/// cut at real-time speed, under the 500 ms the gate allows itself.
pub const LINK_GRACE: Duration = Duration::from_millis(150);

impl Gateways {
    /// Gateways run here by `agent` (the `agent` executable) for `robots`.
    pub fn new(
        agent: AgentCommand,
        robots: RobotsFile,
        register_timeout: Duration,
        heartbeat_timeout: Duration,
    ) -> Self {
        let inner = Spawned::new(agent, register_timeout, heartbeat_timeout);
        Self::with(At::Here { robots, inner })
    }

    /// Gateways started elsewhere, awaited through `remote` (see the module
    /// docs).
    pub fn elsewhere(remote: Remote) -> Self {
        Self::with(At::Elsewhere(remote))
    }

    fn with(at: At) -> Self {
        Self { at, link_timeout_ms: LINK_TIMEOUT.as_millis() as u64, lost_links: BTreeMap::new() }
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
    /// flags the `agent` binary parses into the same [`GatewayArgs`].
    pub fn args(&self, id: u32, plan: &AgentPlan<'_>) -> Result<GatewayArgs, AgentError> {
        let At::Here { robots, .. } = &self.at else {
            return Err(AgentError::NoSuchRobot { robot: id, why: "its gateway runs elsewhere".into() });
        };
        let entry = robots.robots.iter().find(|r| r.id == id).ok_or_else(|| AgentError::NoSuchRobot {
            robot: id,
            why: format!("the robots file names robots 1..={}", robots.robots.len()),
        })?;
        let a = plan.args;
        Ok(GatewayArgs {
            swarm: a.swarm.clone(),
            robot: id,
            bind: entry.gateway,
            key_file: robots.key_path(entry),
            swarm_size: a.swarm_size,
            speed: a.speed,
            link_timeout_ms: self.link_timeout_ms,
            heartbeat_ms: a.heartbeat_ms,
            parent_pid: a.parent_pid,
            bus: a.bus.clone(),
            failsafe: a.failsafe,
        })
    }
}

impl AgentSource for Gateways {
    fn needs_placement(&self) -> bool {
        true
    }

    fn stop_when_stuck(&self) -> bool {
        true
    }

    fn wants_poses(&self) -> bool {
        true
    }

    fn senses_beacons(&self) -> bool {
        false
    }

    fn kind(&self) -> &'static str {
        "gateway"
    }

    fn all_at_once(&self) -> bool {
        true
    }

    fn start_hint(&self) -> &'static str {
        match self.at {
            At::Here { .. } => "",
            At::Elsewhere(_) => {
                " (start each robot's gateway on its bridge host with `agent --transport zenoh \
                 --connect ENDPOINT --swarm SWARM --robot K --bind ADDR --key-file FILE`)"
            }
        }
    }

    fn ended_by(&self) -> &'static str {
        self.inner().ended_by()
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

    fn heard(&mut self, id: u32) {
        self.inner_mut().heard(id);
    }

    fn is_running(&self, id: u32) -> bool {
        self.inner().is_running(id)
    }

    fn pid(&self, id: u32) -> Option<u32> {
        self.inner().pid(id)
    }

    fn poll(&mut self, force: bool) -> Vec<(u32, Gone)> {
        let mut gone = self.inner_mut().poll(force);
        let now = Instant::now();
        let due: Vec<u32> = self
            .lost_links
            .iter()
            .filter(|(_, since)| now.duration_since(**since) >= LINK_GRACE)
            .map(|(id, _)| *id)
            .collect();
        for id in due {
            self.lost_links.remove(&id);
            // Ended here (or dropped from the launch), so never reported
            // twice (nor by the source underneath later).
            if self.inner_mut().kill(id) {
                gone.push((id, Gone::RobotLinkLost));
            }
        }
        gone
    }

    fn robot_link(&mut self, id: u32, up: bool) {
        if up {
            if self.lost_links.remove(&id).is_some() {
                tracing::info!(robot = id, "robot {id}'s link is back within the grace: it stays");
            }
        } else if self.inner().is_running(id) {
            self.lost_links.entry(id).or_insert_with(Instant::now);
        }
    }

    fn reach(&mut self) -> Vec<(u32, Reach)> {
        self.inner_mut().reach()
    }

    fn last_error(&mut self, id: u32) -> Option<String> {
        self.inner_mut().last_error(id)
    }

    fn kill(&mut self, id: u32) -> bool {
        self.lost_links.remove(&id);
        self.inner_mut().kill(id)
    }

    fn wind_down(&mut self, grace: Duration) -> Vec<u32> {
        self.inner_mut().wind_down(grace)
    }
}
