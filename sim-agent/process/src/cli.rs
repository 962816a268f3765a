//! `sim-agent`'s `main`: read the world, open the bus, run the loop, exit
//! with a code that says how it ended.
//!
//! Where the run's settings come from: the flags (`--terrain`, `--eps`,
//! ...), or, over zenoh without them, the orchestrator ([`settings::fetch`]
//! before the agent is seen as a member). An agent started with settings
//! flags over zenoh fetches the launch's too and exits when they differ,
//! naming the first difference.
//!
//! Exit codes ([`ExitCause::exit_code`], as the gateway's): 0 after
//! `Shutdown` or the parent's death (orderly ends), 130 after a signal
//! (SIGINT, SIGTERM, SIGHUP, SIGQUIT: interrupted, as the orchestrator and
//! the gateway say it), 2 for a usage error (bad flags or values, a bad swarm
//! name or `--connect` endpoint), 3 when the
//! orchestrator refused the agent (its robot already has one or is not one
//! of the launch's, other settings, a short grace) or its settings differ
//! from the launch's, 4 when the
//! failsafe stopped the robot and exited (orchestrator lost), 1 for any
//! other error (unreadable terrain, bus failure, no settings from the
//! orchestrator in time), printed on stderr first.

use super::options::AgentArgs;
use super::run::{Agent, AgentPorts, Timing};
use super::settings::{self, FetchError, RunSettings};
use super::RobotCore;
use bycoms_protocol::bus::zenoh::clock::ClockProbe;
use bycoms_protocol::bus::zenoh::{AliveWatch, ZenohBus};
use bycoms_protocol::bus::{Bus, BusError};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{NameError, RobotId, Swarm};
use bycoms_runtime::failsafe::Failsafe;
use bycoms_runtime::lifeline::{ExitCause, Lifeline, LifelineError};
use bycoms_runtime::{BusOpenError, OnBus};
use bycoms_sim::terrain::{self, ReadError, Terrain};
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
    /// The run's settings could not be had from the orchestrator.
    #[error("{0}")]
    Settings(#[from] FetchError),
    /// The orchestrator's settings are not usable (another build's values).
    #[error("the orchestrator's run settings: {0}")]
    LaunchSettings(String),
    /// The run's settings are not the launch's.
    #[error("this agent's run settings are not the launch's: {0}")]
    SettingsDiffer(String),
}

/// Runs one agent with `args`; returns the process exit code.
pub fn main_with(args: &AgentArgs) -> i32 {
    // Every event of this agent carries its robot id (text: `sim-agent{robot=3}: …`).
    let _span = tracing::info_span!("sim-agent", robot = args.robot).entered();
    bycoms_runtime::cli::agent_main(
        || run(args),
        |e| match e {
            // Bad values are usage errors, like clap's own (exit code 2).
            AgentError::Args(_) | AgentError::Swarm(_) => 2,
            // The launch would refuse it: as a refusal.
            AgentError::SettingsDiffer(_) | AgentError::Settings(FetchError::Refused { .. }) => 3,
            _ => 1,
        },
    )
}

/// The terrain's text from `path` (`-`: stdin), checked to parse.
fn read_terrain_text(path: &Path) -> Result<String, AgentError> {
    let read = if path.as_os_str() == "-" {
        terrain::read_text(std::io::stdin().lock())
    } else {
        terrain::read_text_file(path)
    };
    let text = read.map_err(|source| AgentError::Terrain { path: path.to_path_buf(), source })?;
    // A malformed file is this agent's error, before any bus is opened.
    terrain::parse(&text)
        .map_err(|e| AgentError::Terrain { path: path.to_path_buf(), source: ReadError::Parse(e) })?;
    Ok(text)
}

fn run(args: &AgentArgs) -> Result<ExitCause, AgentError> {
    // First, before anything slow: never outlive the orchestrator.
    let mut lifeline = Lifeline::install(args.parent_pid)?;
    args.validate().map_err(AgentError::Args)?;
    let swarm = Swarm::new(&args.swarm)?;
    // The settings of the flags, if any; else the orchestrator's (fetched
    // once the bus is open, `RunAgent::prepare`).
    let own = match &args.terrain {
        Some(path) => RunSettings::of(args, read_terrain_text(path)?),
        None => None,
    };
    let id = RobotId(args.robot);
    let node = format!("bycoms-{}-robot-{}", swarm.as_str(), id.0);
    let then = RunAgent { args, swarm: &swarm, own, launch: None, lifeline: &mut lifeline, clock: None };
    args.bus
        .open(&swarm, Some(Member::Agent(id)), Some(&args.failsafe), args.swarm_size(), node, then)
        .map_err(|e| match e {
            BusOpenError::Args(a) => AgentError::Args(a),
            BusOpenError::Bus(b) => AgentError::Bus(b),
        })?
}

/// Longest wait for the launch's settings of an agent that has its own.
const CHECK_WAIT: Duration = Duration::from_secs(3);

/// [`run_on`] once the bus is open.
struct RunAgent<'a> {
    args: &'a AgentArgs,
    swarm: &'a Swarm,
    /// The settings of the flags.
    own: Option<RunSettings>,
    /// zenoh: the launch's settings, as the orchestrator handed them over.
    launch: Option<RunSettings>,
    lifeline: &'a mut Lifeline,
    /// zenoh: this host's clock offset to the orchestrator's, measured.
    clock: Option<ClockProbe>,
}

impl OnBus for RunAgent<'_> {
    type Output = Result<ExitCause, AgentError>;

    fn wait_for_orchestrator(&self) -> Option<Duration> {
        // Without settings the agent waits for the launch (it may start
        // first); with its own it fails at once, as it always did.
        self.own.is_none().then(|| Duration::from_secs_f64(self.args.settings_timeout))
    }

    fn prepare(&mut self, bus: &ZenohBus) -> Result<(), Self::Output> {
        let mut wait = Duration::from_secs_f64(self.args.settings_timeout);
        if self.own.is_some() {
            // Only a check (the launch refuses other settings anyway): a
            // launch that does not answer soon does not hold the agent up.
            wait = wait.min(CHECK_WAIT);
        }
        let robot = RobotId(self.args.robot);
        let launch = match (settings::fetch(bus, self.swarm, robot, wait), &self.own) {
            (Ok(launch), _) => launch,
            // With settings of its own the agent can go on: the launch
            // refuses its `Register` if the fingerprints differ.
            (Err(e @ FetchError::NoAnswer { .. }), Some(own)) => {
                tracing::warn!(
                    fingerprint = format_args!("{:016x}", own.fingerprint()),
                    "{e}; registering with this agent's own settings"
                );
                return Ok(());
            }
            (Err(e), _) => return Err(Err(e.into())),
        };
        if let Some(own) = &self.own {
            if let Some(difference) = own.first_difference(&launch) {
                return Err(Err(AgentError::SettingsDiffer(difference)));
            }
        }
        launch.validate().map_err(|e| Err(AgentError::LaunchSettings(e)))?;
        self.launch = Some(launch);
        Ok(())
    }

    fn run<B: Bus>(self, bus: &B, failsafe: Option<(Failsafe, AliveWatch)>) -> Self::Output {
        let Some(settings) = self.own.or(self.launch) else {
            return Err(AgentError::Args("no run settings: give --terrain and --eps".into()));
        };
        let path = self.args.terrain.clone().unwrap_or_else(|| "(the orchestrator's settings)".into());
        let terrain = terrain::parse(&settings.terrain)
            .map_err(|e| AgentError::Terrain { path, source: ReadError::Parse(e) })?;
        run_on(bus, self.args, &settings, self.swarm, terrain, self.lifeline, failsafe, self.clock)
    }

    fn clock(&mut self, probe: ClockProbe) {
        self.clock = Some(probe);
    }
}

/// The agent's loop on `bus`, whatever its backend: an agent process runs
/// it on the bus of its `--transport`; a launch over the in-memory bus runs
/// it on a thread of its own process (`orchestrator`'s `orchestrator/launch/src/agents/
/// threads.rs`) with a [`Lifeline::with_flag`] for its end. The robot runs
/// `settings` (`terrain` is their terrain, parsed) and registers with their
/// fingerprint; `args` give its id. Over zenoh it watches the
/// orchestrator (`failsafe`) and reports its clock offset (`clock`).
#[allow(clippy::too_many_arguments)]
pub fn run_on<B: Bus>(
    bus: &B,
    args: &AgentArgs,
    settings: &RunSettings,
    swarm: &Swarm,
    terrain: Terrain,
    lifeline: &mut Lifeline,
    failsafe: Option<(Failsafe, AliveWatch)>,
    clock: Option<ClockProbe>,
) -> Result<ExitCause, AgentError> {
    let id = RobotId(args.robot);
    let ports = AgentPorts::open(bus, swarm, id)?;
    let fingerprint = settings.fingerprint();
    tracing::debug!(
        swarm = swarm.as_str(),
        clock = ?settings.clock,
        speed = settings.speed,
        settings = format_args!("{fingerprint:016x}"),
        "agent on the bus"
    );
    let cfg = settings.run_config();
    let mut agent = Agent::new(RobotCore::new(id, terrain, cfg), ports, timing(args, settings));
    agent.set_settings(fingerprint);
    if let Some((failsafe, watch)) = failsafe {
        agent.watch_orchestrator(failsafe, watch);
    }
    if let Some(probe) = clock {
        agent.report_clock(probe);
    }
    let cause = agent.run(lifeline)?;
    let (warnings, notes) = exit_notes(&agent.stats());
    let s = agent.stats();
    let fields = (s.traffic.total(), s.stale_bearings, s.missed);
    if !warnings.is_empty() {
        tracing::warn!(
            ?cause,
            bad_messages = fields.0,
            stale_bearings = fields.1,
            missed_periods = fields.2,
            "exiting: {}",
            warnings.join(", ")
        );
    }
    if !notes.is_empty() {
        tracing::debug!(?cause, "exiting: {}", notes.join(", "));
    }
    Ok(cause)
}

/// The timing of an agent started with `args` running `settings`: its
/// period on either clock and its heartbeats (the launch harness's agents
/// take theirs from here too).
pub fn timing(args: &AgentArgs, settings: &RunSettings) -> Timing {
    let dt = settings.run_config().kinematics.dt;
    Timing {
        clock: settings.clock,
        period: Duration::from_secs_f64(dt / settings.speed),
        dt_us: (dt * 1e6).round() as u64,
        heartbeat: Duration::from_millis(settings.heartbeat_ms),
        // The launch's own agents are told; one started by hand beats as usual.
        parked_heartbeat: Duration::from_millis(
            args.parked_heartbeat_ms.unwrap_or(settings.heartbeat_ms).max(settings.heartbeat_ms),
        ),
    }
}

/// What an agent says as it exits: the warnings (something went wrong:
/// bad messages, real-time periods it was too late for) and the notes.
///
/// Stale goal bearings are a note: in lockstep only the robot the gate
/// watches is sent a bearing each tick, so a robot the gate has judged
/// (stuck, a beacon) but that is not parked keeps stepping on its last
/// bearing until the launch ends — by design, and in almost every agent of
/// a large swarm (295 warnings in a 300-robot run said nothing was wrong).
fn exit_notes(s: &super::run::AgentStats) -> (Vec<String>, Vec<String>) {
    let mut warnings = Vec::new();
    if s.traffic.total() > 0 {
        warnings.push(format!("bad messages: {}", s.traffic));
    }
    if s.missed > 0 {
        warnings.push(format!("{} of {} real-time periods missed", s.missed, s.missed + s.periods));
    }
    let notes = if s.stale_bearings > 0 {
        vec![format!("{} ticks stepped on an earlier tick's goal bearing", s.stale_bearings)]
    } else {
        Vec::new()
    };
    (warnings, notes)
}

#[cfg(test)]
mod tests {
    use super::super::run::AgentStats;
    use super::exit_notes;
    use bycoms_runtime::lifeline::ExitCause;

    #[test]
    fn stale_bearings_of_a_judged_robot_are_no_warning() {
        // The agent of a robot judged stuck (not parked) in a healthy run.
        let healthy = AgentStats { stale_bearings: 412, ..AgentStats::default() };
        let (warnings, notes) = exit_notes(&healthy);
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(notes, ["412 ticks stepped on an earlier tick's goal bearing"]);
        let late = AgentStats { missed: 3, periods: 97, stale_bearings: 1, ..AgentStats::default() };
        assert_eq!(exit_notes(&late).0, ["3 of 100 real-time periods missed"]);
    }

    #[test]
    fn an_interrupted_agent_exits_130_as_the_gateway_and_the_orchestrator() {
        assert_eq!(ExitCause::Signal.exit_code(), 130);
        assert_eq!(ExitCause::Shutdown.exit_code(), 0);
        assert_eq!(ExitCause::ParentGone.exit_code(), 0);
        assert_eq!(ExitCause::Refused.exit_code(), 3);
        assert_eq!(ExitCause::OrchestratorLost.exit_code(), 4);
    }
}
