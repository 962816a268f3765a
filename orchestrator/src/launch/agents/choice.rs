//! Which agent source a launch uses (`[agents]`, `--agents`), and the one
//! place that builds it.
//!
//! Why here and not in the engine: the engine holds a `Box<dyn
//! AgentSource>` and nothing else about agents; choosing and configuring
//! the kind (which executable, which robots file) happens once, before the
//! launch starts.

use super::gateways::Gateways;
use super::remote::Remote;
use super::spawned::{AgentCommand, Spawned};
use super::threads::Threads;
use super::AgentSource;
use crate::mocap::PlacementConfig;
use anyhow::{Context, Result};
use bycoms_protocol::bus::zenoh::AliveWatch;
use bycoms_sim::agent_process::Transport;
use bycoms_sim::lab::robots::RobotsFile;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// What the transport hands the agent source: zenoh's liveliness watch on
/// the swarm, or the in-memory bus that threads of this process share.
#[derive(Default)]
pub struct AgentLinks {
    /// zenoh: every member's liveliness token.
    pub alive: Option<AliveWatch>,
    /// memory: the launch's bus.
    pub memory: Option<bycoms_protocol::bus::memory::MemoryBus>,
}

/// Where a launch's agents come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum AgentsKind {
    /// One `sim-agent` process per robot, started here (the default).
    #[default]
    Spawned,
    /// Started by hand on other hosts (`sim-agent --transport zenoh
    /// --connect ...`); the launch waits for every robot to register.
    Remote,
    /// Real robots: one `agent` gateway per robot of `agents.robots_file`,
    /// started here; each robot is enabled when it is deployed.
    Real,
}

/// `[agents]`: where agents come from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AgentsConfig {
    /// `spawned` (default), `remote` or `real`.
    pub source: AgentsKind,
    /// `real`: the lab's robots file (each robot's address, its gateway's
    /// address, its key file; `deploy/lab/robots.toml`).
    pub robots_file: Option<PathBuf>,
    /// `real`: the gateway executable; default `agent` next to the
    /// orchestrator.
    pub gateway_bin: Option<PathBuf>,
    /// `real`: the lab scenario (a built-in name, `exp-short` /
    /// `exp-long`, or a scenario file): the launch's start, goal and arena
    /// in metres (`launch::lab`).
    pub scenario: Option<String>,
    /// `real`: how the operator's placement of each robot at the start is
    /// confirmed (metres, lab seconds). With `[mocap] source = "natnet"`,
    /// `[mocap.natnet.placement]` is used instead.
    #[serde(default = "real_placement")]
    pub placement: PlacementConfig,
}

/// Placement of a real crawler robot (metres): within 10 cm of the start
/// for 0.5 s of motion capture; the operator has 10 minutes.
pub fn real_placement() -> PlacementConfig {
    PlacementConfig { radius: 0.1, hold: 0.5, timeout: 600.0 }
}

impl Default for AgentsConfig {
    fn default() -> Self {
        Self {
            source: AgentsKind::default(),
            robots_file: None,
            gateway_bin: None,
            scenario: None,
            placement: real_placement(),
        }
    }
}

impl AgentsConfig {
    /// Checks the choice against the rest of the launch's configuration.
    pub fn validate(&self, robots: u32, transport: Transport, lockstep: bool) -> Result<(), String> {
        let zenoh = transport == Transport::Zenoh;
        if transport == Transport::Memory && self.source != AgentsKind::Spawned {
            return Err("transport.kind = \"memory\" runs the agents as threads here: it needs agents.source = \"spawned\"".into());
        }
        if self.scenario.is_some() && self.source != AgentsKind::Real {
            return Err(
                "agents.scenario (--lab-scenario) is for real robots (agents.source = \"real\")".into()
            );
        }
        let p = &self.placement;
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !(positive(p.radius) && positive(p.timeout) && p.hold.is_finite() && p.hold >= 0.0) {
            return Err("agents.placement: radius and timeout must be positive, hold ≥ 0".into());
        }
        match self.source {
            AgentsKind::Spawned => Ok(()),
            AgentsKind::Remote if !zenoh => {
                Err("agents.source = \"remote\" needs transport.kind = \"zenoh\" (--transport zenoh)".into())
            }
            AgentsKind::Remote => Ok(()),
            AgentsKind::Real if lockstep => {
                Err("agents.source = \"real\" needs clock = \"realtime\" (a real robot cannot be stepped)"
                    .into())
            }
            AgentsKind::Real if zenoh => Err(
                "agents.source = \"real\": the gateways run on this host over ipc (transport.kind = \"ipc\")"
                    .into(),
            ),
            AgentsKind::Real if self.scenario.is_none() => Err(
                "agents.source = \"real\" needs agents.scenario (--lab-scenario exp-short|exp-long|FILE): \
                 the lab's start, goal and arena in metres"
                    .into(),
            ),
            AgentsKind::Real => match &self.robots_file {
                None => Err("agents.source = \"real\" needs agents.robots_file (--robots-file)".into()),
                Some(path) => {
                    let file = RobotsFile::read(path).map_err(|e| e.to_string())?;
                    let have = file.robots.len() as u32;
                    if have < robots {
                        return Err(format!(
                            "the robots file {} names {have} robots, the launch needs {robots}",
                            path.display()
                        ));
                    }
                    file.keys().map_err(|e| e.to_string())?;
                    Ok(())
                }
            },
        }
    }

    /// Builds the source: `sim_agent` runs spawned agents (threads on the
    /// memory bus, when `links` has it); `links.alive` is the swarm's
    /// liveliness watch over zenoh and `link_grace` how long an unreachable
    /// agent is held (remote agents use both).
    pub fn open(
        &self,
        sim_agent: AgentCommand,
        register_timeout: Duration,
        heartbeat_timeout: Duration,
        link_grace: Duration,
        links: AgentLinks,
    ) -> Result<Box<dyn AgentSource>> {
        let AgentLinks { alive, memory } = links;
        Ok(match self.source {
            // Over the in-memory bus the agents can only be threads here.
            AgentsKind::Spawned if memory.is_some() => {
                let bus = memory.context("the memory bus")?;
                Box::new(Threads::new(bus, register_timeout, heartbeat_timeout))
            }
            AgentsKind::Spawned => Box::new(Spawned::new(sim_agent, register_timeout, heartbeat_timeout)),
            AgentsKind::Remote => {
                Box::new(Remote::new(register_timeout, heartbeat_timeout, alive).with_link_grace(link_grace))
            }
            AgentsKind::Real => {
                let path = self.robots_file.as_deref().context("agents.robots_file is not set")?;
                let robots = RobotsFile::read(path)?;
                let gateway = gateway_command(self.gateway_bin.as_deref())?;
                Box::new(Gateways::new(gateway, robots, register_timeout, heartbeat_timeout))
            }
        })
    }
}

/// The gateway executable: `explicit`, else `agent` next to this executable.
fn gateway_command(explicit: Option<&Path>) -> Result<AgentCommand> {
    if let Some(program) = explicit {
        return Ok(AgentCommand { program: program.to_path_buf(), prefix: Vec::new() });
    }
    let me = std::env::current_exe().context("cannot locate the orchestrator executable")?;
    let beside = me.with_file_name(format!("agent{}", std::env::consts::EXE_SUFFIX));
    anyhow::ensure!(
        beside.is_file(),
        "no gateway executable: `agent` is not next to {} (build it with `cargo build -p bycoms-gateway`, \
         or set agents.gateway_bin)",
        me.display()
    );
    Ok(AgentCommand { program: beside, prefix: Vec::new() })
}
