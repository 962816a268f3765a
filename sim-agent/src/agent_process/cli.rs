//! `sim-agent`'s `main`: read the world, open the bus, run the loop, exit
//! with a code that says how it ended.
//!
//! Exit codes: 0 after `Shutdown`, a signal or the parent's death (all
//! orderly ends), 2 for a usage error (bad flags or values), 1 for any other
//! error (unreadable terrain, bus failure), printed on stderr first.

use super::lifeline::{ExitCause, Lifeline, LifelineError};
use super::options::AgentArgs;
use super::run::{Agent, AgentPorts, Timing};
use super::{ipc_config, AgentCore};
use crate::terrain::{parse, ParseError};
use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::bus::BusError;
use bycoms_protocol::{NameError, RobotId, Swarm};
use std::io::Read;
use std::path::PathBuf;
use std::time::Duration;

/// Why an agent could not run.
#[derive(Debug, thiserror::Error)]
pub enum AgentError {
    /// A flag has an unusable value.
    #[error("{0}")]
    Args(String),
    /// The terrain could not be read.
    #[error("cannot read terrain {}: {source}", path.display())]
    ReadTerrain {
        /// The file (`-` for stdin).
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The terrain text is malformed.
    #[error("bad terrain {}: {source}", path.display())]
    Terrain {
        /// The file (`-` for stdin).
        path: PathBuf,
        /// Where and what.
        source: ParseError,
    },
    /// The swarm name is not a valid topic chunk.
    #[error("bad swarm name: {0}")]
    Swarm(#[from] NameError),
    /// The bus failed.
    #[error("bus: {0}")]
    Bus(#[from] BusError),
    /// The parent-death link could not be set up.
    #[error(transparent)]
    Lifeline(#[from] LifelineError),
}

/// Runs one agent with `args`; returns the process exit code.
pub fn main_with(args: &AgentArgs) -> i32 {
    quiet_iceoryx2();
    // Every event of this agent carries its robot id (text: `sim-agent{robot=3}: …`).
    let _span = tracing::info_span!("sim-agent", robot = args.robot).entered();
    match run(args) {
        Ok(cause) => {
            tracing::debug!(?cause, "agent exits");
            0
        }
        Err(e) => {
            tracing::error!("{e}");
            // Bad values are usage errors, like clap's own (exit code 2).
            if matches!(e, AgentError::Args(_)) {
                2
            } else {
                1
            }
        }
    }
}

/// iceoryx2 warns on every process start that it runs without a config
/// file (by design here: the defaults are what we want). Show only errors,
/// unless `IOX2_LOG_LEVEL` asks for more; as `tracing` events (target
/// `iceoryx2`), so they follow `--log-format`.
pub fn quiet_iceoryx2() {
    use iceoryx2::prelude::{set_log_level_from_env_or, LogLevel};
    bycoms_logging::iceoryx2::forward_to_tracing();
    set_log_level_from_env_or(LogLevel::Error);
}

fn read_terrain(path: &PathBuf) -> Result<String, AgentError> {
    let read_error = |source| AgentError::ReadTerrain { path: path.clone(), source };
    if path.as_os_str() == "-" {
        let mut text = String::new();
        std::io::stdin().read_to_string(&mut text).map_err(read_error)?;
        Ok(text)
    } else {
        std::fs::read_to_string(path).map_err(read_error)
    }
}

fn run(args: &AgentArgs) -> Result<ExitCause, AgentError> {
    // First, before anything slow: never outlive the orchestrator.
    let mut lifeline = Lifeline::install(args.parent_pid)?;
    args.validate().map_err(AgentError::Args)?;
    let text = read_terrain(&args.terrain)?;
    let terrain =
        parse(&text).map_err(|source| AgentError::Terrain { path: args.terrain.clone(), source })?;
    let swarm = Swarm::new(&args.swarm)?;
    let id = RobotId(args.robot);
    let mut config = ipc_config(args.swarm_size());
    config.node_name = Some(format!("bycoms-{}-robot-{}", swarm.as_str(), id.0));
    let bus = IpcBus::new(config)?;
    let ports = AgentPorts::open(&bus, &swarm, id, args.peer_ids())?;
    tracing::debug!(swarm = swarm.as_str(), clock = ?args.clock, speed = args.speed, "agent on the bus");
    let cfg = args.run_config();
    let dt = cfg.kinematics.dt;
    let timing = Timing {
        clock: args.clock,
        period: Duration::from_secs_f64(dt / args.speed),
        dt_us: (dt * 1e6).round() as u64,
        heartbeat: Duration::from_millis(args.heartbeat_ms),
    };
    let mut agent = Agent::new(AgentCore::new(id, terrain, cfg), ports, timing);
    let cause = agent.run(&mut lifeline)?;
    let s = agent.stats();
    let mut notes = Vec::new();
    if s.traffic.total() > 0 {
        notes.push(format!("bad messages: {}", s.traffic));
    }
    if s.stale_bearings > 0 {
        notes.push(format!("{} stale goal bearings", s.stale_bearings));
    }
    if s.missed > 0 {
        notes.push(format!("{} of {} real-time periods missed", s.missed, s.missed + s.periods));
    }
    if !notes.is_empty() {
        tracing::warn!(
            ?cause,
            bad_messages = s.traffic.total(),
            stale_bearings = s.stale_bearings,
            missed_periods = s.missed,
            "exiting: {}",
            notes.join(", ")
        );
    }
    Ok(cause)
}
