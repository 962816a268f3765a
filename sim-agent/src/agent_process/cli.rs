//! `sim-agent`'s `main`: read the world, open the bus, run the loop, exit
//! with a code that says how it ended.
//!
//! Exit codes: 0 after `Shutdown`, a signal or the parent's death (all
//! orderly ends), 2 for a usage error (bad flags or values, a bad swarm
//! name or `--connect` endpoint), 3 when the
//! orchestrator refused the agent (its robot already has one), 4 when the
//! failsafe stopped the robot and exited (orchestrator lost), 1 for any
//! other error (unreadable terrain, bus failure), printed on stderr first.

use super::bus_args::{BusOpenError, OnBus};
use super::failsafe::Failsafe;
use super::lifeline::{ExitCause, Lifeline, LifelineError};
use super::options::AgentArgs;
use super::run::{Agent, AgentPorts, Timing};
use super::AgentCore;
use crate::terrain::{self, ReadError, Terrain};
use bycoms_protocol::bus::zenoh::AliveWatch;
use bycoms_protocol::bus::{Bus, BusError};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{NameError, RobotId, Swarm};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Why an agent could not run.
#[derive(Debug, thiserror::Error)]
pub enum AgentError {
    /// A flag has an unusable value.
    #[error("{0}")]
    Args(String),
    /// The terrain could not be read: unreadable, too large, not text, or
    /// malformed (the size limit is the terrain module's, as everywhere).
    #[error("cannot read terrain {}: {source}", path.display())]
    Terrain {
        /// The file (`-` for stdin).
        path: PathBuf,
        /// What went wrong.
        source: ReadError,
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
        Ok(ExitCause::Refused) => 3,
        Ok(ExitCause::OrchestratorLost) => 4,
        Ok(cause) => {
            tracing::debug!(?cause, "agent exits");
            0
        }
        Err(e) => {
            tracing::error!("{e}");
            // Bad values are usage errors, like clap's own (exit code 2).
            if matches!(e, AgentError::Args(_) | AgentError::Swarm(_)) {
                2
            } else {
                1
            }
        }
    }
}

/// The zenoh runtime of our processes (see
/// [`bycoms_protocol::bus::zenoh::tune_runtime`]), for binaries that reach
/// zenoh through this crate.
pub fn tune_zenoh_runtime() {
    bycoms_protocol::bus::zenoh::tune_runtime();
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

fn read_terrain(path: &Path) -> Result<Terrain, AgentError> {
    let read = if path.as_os_str() == "-" {
        terrain::read_terrain(std::io::stdin().lock())
    } else {
        terrain::read_terrain_file(path)
    };
    read.map_err(|source| AgentError::Terrain { path: path.to_path_buf(), source })
}

fn run(args: &AgentArgs) -> Result<ExitCause, AgentError> {
    // First, before anything slow: never outlive the orchestrator.
    let mut lifeline = Lifeline::install(args.parent_pid)?;
    args.validate().map_err(AgentError::Args)?;
    let swarm = Swarm::new(&args.swarm)?;
    let terrain = read_terrain(&args.terrain)?;
    let id = RobotId(args.robot);
    let node = format!("bycoms-{}-robot-{}", swarm.as_str(), id.0);
    let then = RunAgent { args, swarm: &swarm, terrain, lifeline: &mut lifeline };
    args.bus
        .open(&swarm, Some(Member::Agent(id)), Some(&args.failsafe), args.swarm_size(), node, then)
        .map_err(|e| match e {
            BusOpenError::Args(a) => AgentError::Args(a),
            BusOpenError::Bus(b) => AgentError::Bus(b),
        })?
}

/// [`run_on`] once the bus is open.
struct RunAgent<'a> {
    args: &'a AgentArgs,
    swarm: &'a Swarm,
    terrain: Terrain,
    lifeline: &'a mut Lifeline,
}

impl OnBus for RunAgent<'_> {
    type Output = Result<ExitCause, AgentError>;
    fn run<B: Bus>(self, bus: &B, failsafe: Option<(Failsafe, AliveWatch)>) -> Self::Output {
        run_on(bus, self.args, self.swarm, self.terrain, self.lifeline, failsafe)
    }
}

/// The agent's loop on `bus`, whatever its backend: an agent process runs
/// it on the bus of its `--transport`; a launch over the in-memory bus runs
/// it on a thread of its own process (`orchestrator`'s `launch/agents/
/// threads.rs`) with a [`Lifeline::with_flag`] for its end.
pub fn run_on<B: Bus>(
    bus: &B,
    args: &AgentArgs,
    swarm: &Swarm,
    terrain: Terrain,
    lifeline: &mut Lifeline,
    failsafe: Option<(Failsafe, AliveWatch)>,
) -> Result<ExitCause, AgentError> {
    let id = RobotId(args.robot);
    let ports = AgentPorts::open(bus, swarm, id)?;
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
    if let Some((failsafe, watch)) = failsafe {
        agent.watch_orchestrator(failsafe, watch);
    }
    let cause = agent.run(lifeline)?;
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
