//! Which agent source a launch uses (`[agents]`, `--agents`), and the one
//! place that builds it.
//!
//! Why here and not in the engine: the engine holds a `Box<dyn
//! AgentSource>` and nothing else about agents; choosing and configuring
//! the kind (which executable, which robots file) happens once, before the
//! launch starts.

use super::gateways::{Gateways, GatewaysAt};
use super::mixed::Mixed;
use super::remote::Remote;
use super::ros2_robots::{Graph, Ros2Robots};
use super::spawned::{AgentCommand, Spawned};
use super::threads::Threads;
use super::AgentSource;
use anyhow::{Context, Result};
use bycoms_lab::robots::{Kind, RobotsFile};
use bycoms_protocol::bus::zenoh::AliveWatch;
use bycoms_runtime::Transport;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// What the transport hands the agent source: zenoh's liveliness watch on
/// the swarm, or the in-memory bus that threads of this process share.
#[derive(Default)]
pub struct AgentLinks {
    /// zenoh: every member's liveliness token.
    pub alive: Option<AliveWatch>,
    /// memory: the launch's bus.
    pub memory: Option<bycoms_protocol::bus::memory::MemoryBus>,
}

/// Where a launch's agents come from (`agents.source`, `--agents`): which
/// [`AgentSource`](super::AgentSource) [`AgentsConfig::open`] builds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum AgentSourceKind {
    /// One `sim-agent` process per robot, started here (the default).
    #[default]
    Spawned,
    /// Started by hand on other hosts (`sim-agent --transport zenoh
    /// --connect ...`); the launch waits for every robot to register.
    Remote,
    /// Real robots: one `gateway` per acoustic robot, started here for
    /// each robot of `agents.robots_file` or elsewhere (`agents.gateways`),
    /// or one `ros2-robot` per ROS 2 robot (`kind = "ros2"` in the robots
    /// file); each robot is enabled when it is deployed.
    Real,
}

/// `[agents]`: where agents come from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default, expecting = "an [agents] table")]
pub struct AgentsConfig {
    /// `spawned` (default), `remote` or `real`.
    pub source: AgentSourceKind,
    /// `real`: the lab's robots file (each robot's address, its gateway's
    /// address, its key file; `deploy/lab/robots.toml`).
    pub robots_file: Option<PathBuf>,
    /// `real`: the gateway executable; default `gateway` next to the
    /// orchestrator.
    pub gateway_bin: Option<PathBuf>,
    /// `real` with ROS 2 robots: the `ros2-robot` executable; default
    /// `ros2-robot` next to the orchestrator.
    pub ros2_robot_bin: Option<PathBuf>,
    /// `real`: where the gateways run: `here` (started by this launch, one
    /// per robot of the robots file) or `elsewhere` (started by hand on a
    /// bridge host over zenoh, awaited as remote agents are).
    pub gateways: GatewaysAt,
    /// `real`: the lab scenario (a built-in name, `exp-short` /
    /// `exp-long`, or a scenario file): the launch's start, goal and arena
    /// in metres (`launch::lab`).
    pub scenario: Option<String>,
}

impl Default for AgentsConfig {
    fn default() -> Self {
        Self {
            source: AgentSourceKind::default(),
            robots_file: None,
            gateway_bin: None,
            ros2_robot_bin: None,
            gateways: GatewaysAt::Here,
            scenario: None,
        }
    }
}

impl AgentsConfig {
    /// Whether this launch starts its agents' processes (spawned agents,
    /// gateways here), rather than awaiting them.
    pub fn started_here(&self) -> bool {
        match self.source {
            AgentSourceKind::Spawned => true,
            AgentSourceKind::Remote => false,
            AgentSourceKind::Real => self.gateways == GatewaysAt::Here,
        }
    }

    /// Checks the choice against the rest of the launch's configuration;
    /// `graph`: whether a ROS 2 graph is reachable (`ros2.router`, or the
    /// launch's own zenoh session), which ROS 2 robots need.
    pub fn validate(
        &self,
        robots: u32,
        transport: Transport,
        lockstep: bool,
        graph: bool,
    ) -> Result<(), String> {
        let zenoh = transport == Transport::Zenoh;
        if transport == Transport::Memory && self.source != AgentSourceKind::Spawned {
            return Err("transport.kind = \"memory\" runs the agents as threads here: it needs agents.source = \"spawned\"".into());
        }
        if self.scenario.is_some() && self.source != AgentSourceKind::Real {
            return Err(
                "agents.scenario (--lab-scenario) is for real robots (agents.source = \"real\")".into()
            );
        }
        if self.gateways == GatewaysAt::Elsewhere && self.source != AgentSourceKind::Real {
            return Err("agents.gateways (--gateways) is for real robots (agents.source = \"real\")".into());
        }
        if self.gateways == GatewaysAt::Elsewhere && !zenoh {
            return Err(
                "agents.gateways = \"elsewhere\" needs transport.kind = \"zenoh\" (--transport zenoh): \
                        gateways on other hosts join over zenoh"
                    .into(),
            );
        }
        match self.source {
            AgentSourceKind::Spawned => Ok(()),
            AgentSourceKind::Remote if !zenoh => {
                Err("agents.source = \"remote\" needs transport.kind = \"zenoh\" (--transport zenoh)".into())
            }
            AgentSourceKind::Remote => Ok(()),
            AgentSourceKind::Real if lockstep && !self.all_simulated() => {
                Err("agents.source = \"real\" needs clock = \"realtime\" (a real robot cannot be stepped)"
                    .into())
            }
            AgentSourceKind::Real if self.scenario.is_none() => Err(
                "agents.source = \"real\" needs agents.scenario (--lab-scenario exp-short|exp-long|FILE): \
                 the lab's start, goal and arena in metres"
                    .into(),
            ),
            // The robots file (addresses, keys) is the gateways' business.
            AgentSourceKind::Real if self.gateways == GatewaysAt::Elsewhere => Ok(()),
            AgentSourceKind::Real => match &self.robots_file {
                None => Err("agents.source = \"real\" needs agents.robots_file (--robots-file)".into()),
                Some(path) => check_robots_file(path, robots, graph),
            },
        }
    }

    /// Whether the robots file names simulated robots only (`kind =
    /// "sim"`): a swarm simulated in a lab's arena, which may be stepped.
    fn all_simulated(&self) -> bool {
        let file = self.robots_file.as_deref().and_then(|p| RobotsFile::read(p).ok());
        file.is_some_and(|f| f.kind() == Some(Kind::Sim))
    }

    /// Builds the source: `sim_agent` runs spawned agents (threads on the
    /// memory bus, when `links` has it); `links.alive` is the swarm's
    /// liveliness watch over zenoh (remote agents and gateways elsewhere);
    /// `graph` is where ROS 2 robots' agents join the ROS 2 graph.
    /// The supervision timeouts are the core's (`orchestrator/launch/src/setup.rs`).
    pub fn open(
        &self,
        sim_agent: AgentCommand,
        links: AgentLinks,
        graph: Option<Graph>,
    ) -> Result<Box<dyn AgentSource>> {
        let AgentLinks { alive, memory } = links;
        Ok(match self.source {
            // Over the in-memory bus the agents can only be threads here.
            AgentSourceKind::Spawned if memory.is_some() => {
                let bus = memory.context("the memory bus")?;
                Box::new(Threads::new(bus))
            }
            AgentSourceKind::Spawned => Box::new(Spawned::new(sim_agent)),
            AgentSourceKind::Remote => Box::new(Remote::new(alive)),
            AgentSourceKind::Real if self.gateways == GatewaysAt::Elsewhere => {
                Box::new(Gateways::elsewhere(Remote::new(alive)))
            }
            AgentSourceKind::Real => {
                let path = self.robots_file.as_deref().context("agents.robots_file is not set")?;
                let robots = RobotsFile::read(path)?;
                match (robots.sim.is_empty(), self.real_robots(&robots, graph)?) {
                    (true, Some(real)) => real,
                    (false, Some(real)) => Box::new(Mixed::new(sim_agent, robots.sim.clone(), real)),
                    // All simulated: the launch's own agents in the lab's
                    // arena, as any simulated swarm (the parity path).
                    (_, None) => Box::new(Spawned::new(sim_agent)),
                }
            }
        })
    }

    /// The agents of the robots file's real robots: a `ros2-robot` per ROS
    /// 2 robot on `graph`, or a `gateway` per acoustic robot; none when
    /// every robot is simulated.
    fn real_robots(&self, robots: &RobotsFile, graph: Option<Graph>) -> Result<Option<Box<dyn AgentSource>>> {
        Ok(match robots.kind() {
            Some(Kind::Sim) => None,
            Some(Kind::Ros2) => {
                let graph = graph.context("ROS 2 robots need a ROS 2 graph (ros2.router)")?;
                let agent = super::executable::ros2_robot_command(self.ros2_robot_bin.as_deref())?;
                Some(Box::new(Ros2Robots::new(agent, robots, graph)))
            }
            _ => {
                let gateway = super::executable::gateway_command(self.gateway_bin.as_deref())?;
                Some(Box::new(Gateways::new(gateway, robots.clone())))
            }
        })
    }
}

/// A robots file a launch of `robots` robots can use: enough robots of
/// one real kind, or ROS 2 robots beside simulated members (a mixed
/// swarm); acoustic ones with their keys, ROS 2 ones with a `graph`.
fn check_robots_file(path: &std::path::Path, robots: u32, graph: bool) -> Result<(), String> {
    let file = RobotsFile::read(path).map_err(|e| e.to_string())?;
    let mixed = !file.sim.is_empty();
    let kind = match file.kind() {
        Some(Kind::Acoustic) if mixed => {
            return Err(format!(
            "the robots file {} has acoustic and simulated robots: an acoustic robot hears its companions' \
                 tones and a simulated one makes none; a mixed swarm takes ROS 2 robots (kind = \"ros2\")",
            path.display()
        ))
        }
        Some(Kind::Acoustic) => "acoustic",
        Some(Kind::Ros2) if mixed => "ROS 2 and simulated",
        Some(Kind::Ros2) => "ROS 2",
        Some(Kind::Sim) => "simulated",
        None => {
            return Err(format!(
                "the robots file {} has acoustic and ROS 2 robots: a launch drives robots of one kind",
                path.display()
            ))
        }
    };
    let have = file.len() as u32;
    if have < robots || (mixed && have != robots) {
        return Err(format!(
            "the robots file {} names {have} {kind} robots, the launch needs {robots}{}",
            path.display(),
            if mixed { " (a mixed swarm is its robots file: launch it with --robots as many)" } else { "" }
        ));
    }
    match file.kind() {
        Some(Kind::Ros2) if !graph => Err(format!(
            "the ROS 2 robots of {} need the ROS 2 graph their drivers are on: set ros2.router \
             (--ros2-router tcp/HOST:7447, the lab's rmw_zenohd) or use transport.kind = \"zenoh\"",
            path.display()
        )),
        Some(Kind::Ros2 | Kind::Sim) => Ok(()),
        _ => file.keys().map(|_| ()).map_err(|e| e.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn real(gateways: GatewaysAt) -> AgentsConfig {
        AgentsConfig {
            source: AgentSourceKind::Real,
            gateways,
            scenario: Some("exp-short".into()),
            ..AgentsConfig::default()
        }
    }

    #[test]
    fn gateways_run_here_over_either_bus_or_elsewhere_over_zenoh() {
        // Here: the robots file names each robot's gateway, over ipc or zenoh.
        for transport in [Transport::Ipc, Transport::Zenoh] {
            let err = real(GatewaysAt::Here).validate(2, transport, false, false).unwrap_err();
            assert!(err.contains("agents.robots_file"), "{transport:?}: {err}");
        }
        // Elsewhere: no robots file here (it is the gateways'), but zenoh.
        assert_eq!(real(GatewaysAt::Elsewhere).validate(2, Transport::Zenoh, false, false), Ok(()));
        let err = real(GatewaysAt::Elsewhere).validate(2, Transport::Ipc, false, false).unwrap_err();
        assert!(err.contains("--transport zenoh"), "{err}");
        // Only real robots have gateways.
        let spawned = AgentsConfig { source: AgentSourceKind::Spawned, ..real(GatewaysAt::Elsewhere) };
        let err = AgentsConfig { scenario: None, ..spawned }
            .validate(2, Transport::Zenoh, false, false)
            .unwrap_err();
        assert!(err.contains("agents.gateways"), "{err}");
        // Real robots are never stepped, wherever their gateways run.
        let err = real(GatewaysAt::Elsewhere).validate(2, Transport::Zenoh, true, false).unwrap_err();
        assert!(err.contains("realtime"), "{err}");
    }

    #[test]
    fn a_mixed_robots_file_takes_ros2_robots_beside_simulated_ones_and_as_many_robots_as_it_names() {
        let dir = tempfile::tempdir().expect("temp dir");
        let write = |name: &str, kinds: &[&str]| {
            let text: String = kinds
                .iter()
                .enumerate()
                .map(|(i, k)| format!("[[robot]]\nid = {}\nkind = \"{k}\"\n{}", i + 1, acoustic_keys(k, i)))
                .collect();
            let path = dir.path().join(name);
            std::fs::write(&path, text).expect("robots file");
            path
        };
        let mixed = write("mixed.toml", &["sim", "ros2", "sim"]);
        assert_eq!(check_robots_file(&mixed, 3, true), Ok(()));
        let err = check_robots_file(&mixed, 2, true).unwrap_err();
        assert!(err.contains("names 3 ROS 2 and simulated robots, the launch needs 2"), "{err}");
        let err = check_robots_file(&mixed, 3, false).unwrap_err();
        assert!(err.contains("need the ROS 2 graph"), "{err}");
        let all = write("all.toml", &["sim", "sim"]);
        assert_eq!(check_robots_file(&all, 2, false), Ok(()), "no real robot, no graph needed");
        let acoustic = write("acoustic.toml", &["acoustic", "sim"]);
        let err = check_robots_file(&acoustic, 2, true).unwrap_err();
        assert!(err.contains("acoustic and simulated robots"), "{err}");
    }

    /// An acoustic robot's keys for robot `i + 1` of kind `kind` (none for other kinds).
    fn acoustic_keys(kind: &str, i: usize) -> String {
        match kind {
            "acoustic" => format!(
                "address = \"127.0.0.1:{}\"\ngateway = \"127.0.0.1:{}\"\nkey_file = \"k\"\n",
                47100 + i,
                47000 + i
            ),
            _ => String::new(),
        }
    }

    #[test]
    fn only_agents_started_here_are_started_here() {
        assert!(AgentsConfig::default().started_here());
        assert!(real(GatewaysAt::Here).started_here());
        assert!(!real(GatewaysAt::Elsewhere).started_here());
        let remote = AgentsConfig { source: AgentSourceKind::Remote, ..AgentsConfig::default() };
        assert!(!remote.started_here());
    }
}
