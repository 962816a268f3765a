//! Simulation testing of the launch core: whole launches in virtual time,
//! with simulated agents over a seeded simulated network and faults drawn
//! from a seed.
//!
//! Why: the launch's fleet start, partitions, deaths and forged traffic used
//! to be testable only end to end, with real processes on wall clocks.
//! Here one [`Schedule`] (drawn from one `u64` by [`Schedule::draw`]) fixes
//! every delay, loss, duplicate, partition, crash, late or missing
//! registration, second agent and forged message, and [`run`] plays a
//! launch through the real [`LaunchCore`] in virtual time in microseconds of CPU.
//! The harness runs production code on both sides: the core's [`Setup`] is
//! the launch's own (`launch::setup::setup_of`, [`Launch`]), each agent is
//! the `sim-agent` process's own [`SimAgentCore`] (its message rules, real
//! heartbeat periods), each real robot the `gateway`'s own session
//! (`bycoms_agent::gateway::GatewaySession`), both driven as their shells
//! drive them, through [`bycoms_protocol::SansIo`] on the virtual clock's
//! µs, and the summary's verdict is `summary::of`.
//! [`check`] states the properties every schedule must keep; the
//! differential properties (parity with `simulate`, forgeries and short
//! partitions change nothing) compare two runs. A failing schedule is
//! replayed exactly from its seed:
//! `BYCOMS_SIM_SEED=<seed> cargo test -p bycoms-launch --test launch_sim -- one_seed`.
//!
//! The agents run either clock: lockstep (the core is the clock: ticks,
//! answers, re-sends) or real time at a drawn speed (each agent steps on
//! its own clock from its registration; the core answers poses with
//! bearings and relays dead robots once a period). Forged poses reach the
//! core only (the simulated agents' own handling of peers' poses is the
//! agent's business).

mod agent;
mod check;
mod figures;
mod forged;
mod net;
mod real;
mod robots;
mod schedule;
#[cfg(test)]
mod tests;
mod wind;
mod world;

pub use agent::Agent;
pub use check::{check, exit_code};
pub use figures::{missing_robots, MissingFigures};
pub use net::{Net, NetFaults, Packet, Partition};
pub use real::{Body, RealRobot, ORPHAN_BOUND_US, STOP_BOUND_US};
pub use schedule::{Crash, Foreign, Placing, Schedule, PLACEMENT};
pub use wind::WoundDown;
pub use world::{run, run_logged};

use super::agents::Gone;
use super::config::{Clock, LaunchConfig, Missing, OnDeath};
use super::core::log::{Call, Logged};
use super::core::view::RunView;
use super::core::{Ending, Fault, Input, Output, Revoke, Setup, SlotState, Stop, STOP_WAIT_US};
use super::events::EventKind;
use super::summary::{Decided, Outcome, RevokedSummary, RobotEnd, StopSummary};
use bycoms_protocol::msg::{FromAgent, GateEvent, GateKind, Heartbeat, Pose, Refusal, Register, ToAgent};
use bycoms_protocol::RobotId;
use bycoms_sim::sensing::NoiseModel;
use bycoms_sim::terrain::Terrain;
use bycoms_sim::{RunConfig, Vec2};
use bycoms_sim_agent::run::Timing;
use bycoms_sim_agent::{RobotCore, RunSettings, Said, SimAgentCore};
use bycoms_study::draw::snapshot::Unit;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::os::unix::process::ExitStatusExt;

/// Virtual time after which a launch that has not ended is a failure, µs.
pub const HANG_US: u64 = 4_000_000_000;

/// The world and run parameters of a harness launch.
#[derive(Clone, Debug)]
pub struct Case {
    /// The terrain (start and goal in it).
    pub terrain: Terrain,
    /// ε.
    pub eps: f64,
    /// Sensing noise seed (none: no noise).
    pub noise: Option<u64>,
    /// Robots available.
    pub robots: u32,
    /// Simulated time limit, s.
    pub time_limit: f64,
    /// The gate's dwell, s.
    pub dwell: f64,
    /// The gate's turn rate below which a slow robot is still, rad/s (0:
    /// turning is ignored; `simulate` has the default's rule).
    pub stop_turn_rate: f64,
    /// What a dead agent means.
    pub on_death: OnDeath,
    /// What a robot whose agent never registers means.
    pub missing: Missing,
}

impl Case {
    /// A small world drawn from `seed`: a 12 × 8 arena with a wall across
    /// the start → goal line, so robots get stuck on it and later ones go
    /// around (a run of a few hundred ticks).
    pub fn small(seed: u64) -> Self {
        let mut terrain = Terrain::new(12, 8);
        terrain.set_start(Vec2::new(1.5, 4.0));
        terrain.set_goal(Vec2::new(10.5, 4.0));
        let (x, top) = (5 + (seed % 3) as usize, 2 + (seed / 3 % 3) as usize);
        for y in top..6 {
            terrain.set_blocked(x, y, true);
        }
        Self {
            terrain,
            eps: [1.0, 2.0, 3.0][(seed / 9 % 3) as usize],
            noise: (seed / 27 % 2 == 1).then_some(seed),
            robots: 2 + (seed / 54 % 4) as u32,
            time_limit: [30.0, 120.0][(seed / 216 % 2) as usize],
            dwell: 1.0,
            stop_turn_rate: crate::config::GateConfig::default().stop_turn_rate,
            on_death: OnDeath::Beacon,
            missing: Missing::Skip,
        }
    }

    /// The run configuration `simulate` uses for this case.
    pub fn run_config(&self) -> RunConfig {
        let mut run = RunConfig::paper(self.eps);
        run.noise = self.noise.map(|_| NoiseModel::paper());
        run.seed = self.noise.unwrap_or(0);
        run.max_robots = Some(self.robots);
        run.time_limit = self.time_limit;
        run
    }
}

/// What a harness launch did.
#[derive(Clone, Debug)]
pub struct Report {
    /// How it ended (none: it did not, see `failure`).
    pub ending: Option<Ending>,
    /// A failure the harness itself saw (the launch stalled or hung).
    pub failure: Option<String>,
    /// The gate events, in order.
    pub gates: Vec<GateEvent>,
    /// Every robot's end: state, active steps, last pose.
    pub robots: Vec<(SlotState, u64, Option<Pose>)>,
    /// Per robot, why its agent was lost or absent (the summary's reason).
    pub deaths: Vec<Option<String>>,
    /// Active steps charged.
    pub spent: u64,
    /// Completed lockstep ticks.
    pub ticks: u64,
    /// Commands sent again.
    pub resends: u64,
    /// Virtual time at the end, µs.
    pub end_us: u64,
    /// Inputs the core counted as bad traffic.
    pub bad: u64,
    /// Messages the network lost (drops and partitions).
    pub lost: u64,
    /// Ticks each robot's agent stepped.
    pub stepped: Vec<u64>,
    /// The last `Tick` that reached each robot's agent (none: never one).
    pub last_tick: Vec<Option<u64>>,
    /// `Tick`s that reached each robot's agent before its robot was
    /// deployed (repeats included).
    pub idle_ticks: Vec<u64>,
    /// Deployments each robot got (agents that took a `Deploy`).
    pub deploys_sent: Vec<u64>,
    /// `Stop`s sent to each robot.
    pub stops_sent: Vec<u64>,
    /// Runs of ticks (`ToAgent::Ticks`) sent to each robot, and the periods
    /// they asked for in all.
    pub runs_sent: Vec<(u64, u64)>,
    /// `Beacon`s sent to agents.
    pub beacons_sent: u64,
    /// Poses passed on to the agents (`Output::Forward`).
    pub forwarded: u64,
    /// Robots that registered after their turn was skipped.
    pub late: Vec<u32>,
    /// Virtual time of each gate event (parallel to `gates`), µs.
    pub gate_times_us: Vec<u64>,
    /// When each robot's first registration reached the core, µs.
    pub registered_us: Vec<Option<u64>>,
    /// When each robot's agent was first started, µs.
    pub started_us: Vec<Option<u64>>,
    /// What the summary states ([`super::summary::of`] at the end, with
    /// the schedule's recording failure).
    pub decided: Option<Decided>,
    /// Every `Stop` sent: when, to which robot.
    pub stop_log: Vec<(u64, u32)>,
    /// The stop asked from outside, as the core recorded it.
    pub stopped: Option<StopSummary>,
    /// The robots revoked, as the core recorded them.
    pub revoked: Vec<RevokedSummary>,
    /// What the core put out about a robot once it was revoked, in order.
    pub after_revoke: Vec<(u32, Output)>,
    /// Robots whose agents ran when the launch ended.
    pub running_at_end: Vec<u32>,
    /// Each crash of a running agent and each cut of its link, (robot, µs),
    /// while the core held it reachable.
    pub faults: Vec<(u32, u64)>,
    /// When the core noticed a robot's agent lost or unreachable (its
    /// `AgentLost` and `Unreachable` events), (robot, µs).
    pub noticed: Vec<(u32, u64)>,
    /// The lines the core noted for the terminal, in order.
    pub notes: Vec<String>,
    /// Gateway agents: safety promises the real robots broke, and robots
    /// deployed though motion capture did not see them at the start.
    pub violations: Vec<String>,
    /// Gateway agents: when the operator was first asked to place each
    /// robot, µs.
    pub asked_us: Vec<Option<u64>>,
    /// Gateway agents: robots whose telemetry said `Driving` at least once.
    pub drove: Vec<u32>,
    /// Gateway agents: robots whose gateway's failsafe stopped them.
    pub tripped: Vec<u32>,
    /// Every pose the core applied (`Output::Moved`), what the views show:
    /// when (µs), of which robot, the pose.
    pub moved: Vec<(u64, u32, Pose)>,
    /// Every forged pose handed to the core (`forged.rs`), and whether the
    /// core took it (made it its robot's latest) when it was handed: a
    /// forgery plausible by every rule the core has.
    pub forged: Vec<(Pose, bool)>,
    /// Robots whose agent (simulated, or a gateway) still ran at the end,
    /// whatever the core held of it.
    pub agents_at_end: Vec<u32>,
    /// The wind-down after the ending (none: the launch did not end).
    pub wound: Option<WoundDown>,
    /// The first time the views' fold (`RunView`) disagreed with the core
    /// (its beacon table, its robots' states), in words.
    pub view_differs: Option<String>,
}

/// Longest simulated time of a launch of real robots, s.
pub const GATEWAY_TIME_LIMIT: f64 = 6.0;

/// A crash or a cut link is noticed within this long, µs (the README's
/// promise: a dead robot or a cut link is seen within 500 ms).
pub const NOTICE_US: u64 = 500_000;

/// Who asks a harness schedule's stop, and why.
pub const STOP_WHO: &str = "the harness";
/// Why a harness schedule's stop is asked.
pub const STOP_WHY: &str = "a seeded stop";
/// Why a harness schedule's revocation is asked (by [`STOP_WHO`]).
pub const REVOKE_WHY: &str = "a seeded revocation";

/// A harness launch as a launch of the `orchestrator` would be: its
/// config, world, how its agents join and its run settings, made by the launch's
/// own functions (`launch::setup`), so the core's [`Setup`] and the
/// agents' rules are the real ones.
pub struct Launch {
    /// The launch's config.
    pub cfg: LaunchConfig,
    /// Its world.
    pub world: super::World,
    /// How every agent it starts joins it.
    pub joining: super::agents::Joining,
    /// The run's settings (the agents' and the launch's, one fingerprint).
    pub settings: RunSettings,
    /// The agents' timing, as a spawned agent computes it from its flags.
    pub timing: Timing,
}

impl Launch {
    /// The launch of `case` under `schedule`.
    pub fn of(case: &Case, schedule: &Schedule) -> Self {
        let mut cfg = LaunchConfig {
            robots: case.robots,
            eps: case.eps,
            time_limit: case.time_limit,
            placement: PLACEMENT,
            ..LaunchConfig::default()
        };
        (cfg.noise, cfg.seed) = (case.noise.is_some(), case.noise.unwrap_or(0));
        (cfg.clock, cfg.speed) = match schedule.realtime {
            Some(speed) => (Clock::Realtime, speed),
            None => (Clock::Lockstep, 1.0),
        };
        if schedule.gateways {
            // Real robots run in real time: a short launch keeps the
            // schedule's cost in check.
            cfg.time_limit = cfg.time_limit.min(GATEWAY_TIME_LIMIT);
        }
        cfg.gate.dwell = case.dwell;
        cfg.gate.stop_turn_rate = case.stop_turn_rate;
        cfg.gate.on_agent_death = case.on_death;
        cfg.supervision.missing = case.missing;
        let text = bycoms_sim::terrain::format::to_text(&case.terrain);
        let (start, goal) = (case.terrain.start(), case.terrain.goal());
        let world = match super::World::new("harness".into(), text, start, goal, Unit::Cell) {
            Ok(world) => world,
            Err(e) => unreachable!("a terrain's own text parses: {e:#}"),
        };
        let joining = super::setup::joining(&cfg, "harness".into(), Vec::new());
        let settings = super::setup::run_settings(&cfg, &world);
        let timing = bycoms_sim_agent::timing(&joining.sim_agent(1, &settings), &settings);
        Self { cfg, world, joining, settings, timing }
    }

    /// The core's setup, with the seams of `schedule`'s agents, from the
    /// launch's own [`super::setup::setup_of`] (and the schedule's starts
    /// ahead, if it sets them).
    pub fn setup(&self, schedule: &Schedule) -> Setup {
        let mut setup = super::setup::setup_of(&self.cfg, &self.world, &self.settings, &schedule.seams(), 0);
        if let Some(ahead) = schedule.starts_ahead {
            setup.starts.ahead = ahead;
        }
        setup
    }

    /// Robot `id`'s simulated agent as the process would be (process
    /// `instance`), registering first at `register_at` (never if none).
    pub fn agent(&self, id: u32, instance: u64, register_at: Option<u64>) -> Agent {
        let robot = RobotCore::new(RobotId(id), self.world.terrain.clone(), self.settings.run_config());
        let rules = self.timing.rules(instance, self.settings.fingerprint());
        Agent::new(SimAgentCore::new(robot, rules), register_at)
    }
}

/// The core's setup for `case` with agents of `schedule`'s kind and clock:
/// the launch's own ([`Launch::setup`]).
pub fn setup(case: &Case, schedule: &Schedule) -> Setup {
    Launch::of(case, schedule).setup(schedule)
}
