//! Simulation testing of the launch core: whole launches in virtual time,
//! with simulated agents over a seeded simulated network and faults drawn
//! from a seed.
//!
//! Why: the launch's fleet start, partitions, deaths and forged traffic used
//! to be testable only end to end, with real processes on wall clocks.
//! Here one [`Schedule`] (drawn from one `u64` by [`Schedule::draw`]) fixes
//! every delay, loss, duplicate, partition, crash, late or missing
//! registration, second agent and forged message, and [`run`] plays a
//! launch through the real [`Core`] in virtual time in microseconds of CPU.
//! [`check`] states the properties every schedule must keep; the
//! differential properties (parity with `simulate`, forgeries and short
//! partitions change nothing) compare two runs. A failing schedule is
//! replayed exactly from its seed:
//! `BYCOMS_SIM_SEED=<seed> cargo test -p bycoms-orchestrator --test launch_sim -- one_seed`.
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
mod schedule;
mod world;

pub use agent::{Agent, Sent};
pub use check::{check, exit_code};
pub use figures::{missing_robots, MissingFigures};
pub use net::{Link, Net, Packet, Partition};
pub use schedule::{Crash, Foreign, Schedule};
use world::play;

use super::agents::Gone;
use super::config::{LaunchConfig, Missing, OnDeath};
use super::core::log::{Call, Logged};
use super::core::{AgentTraits, Ending, Input, Output, Setup, SlotState};
use super::events::EventKind;
use super::summary::Outcome;
use crate::gate::GateParams;
use bycoms_protocol::msg::{FromAgent, GateEvent, GateKind, Heartbeat, Pose, Register, ToAgent};
use bycoms_protocol::RobotId;
use bycoms_sim::sensing::NoiseModel;
use bycoms_sim::terrain::Terrain;
use bycoms_sim::{RunConfig, Vec2};
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::os::unix::process::ExitStatusExt;

/// Virtual time after which a launch that has not ended is a failure, µs.
pub const HANG_US: u64 = 4_000_000_000;

/// The fingerprint of every harness launch's settings: its agents register
/// with it, a forged agent with another one is refused.
pub(super) const SETTINGS: u64 = 0x5e77_1465_b1c0_0001;

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
    /// Deployments each robot got (agents that took a `Deploy`).
    pub deploys_sent: Vec<u64>,
    /// Robots that registered after their turn was skipped.
    pub late: Vec<u32>,
    /// Virtual time of each gate event (parallel to `gates`), µs.
    pub gate_times_us: Vec<u64>,
    /// When each robot's first registration reached the core, µs.
    pub registered_us: Vec<Option<u64>>,
    /// Each crash of a running agent and each cut of its link, (robot, µs),
    /// while the core held it reachable.
    pub faults: Vec<(u32, u64)>,
    /// When the core noticed a robot's agent lost or unreachable (its
    /// `AgentLost` and `LinkLost` events), (robot, µs).
    pub noticed: Vec<(u32, u64)>,
}

/// A crash or a cut link is noticed within this long, µs (the README's
/// promise: a dead robot or a cut link is seen within 500 ms).
pub const NOTICE_US: u64 = 500_000;

/// The core's setup for `case` with agents of `schedule`'s kind and clock.
pub fn setup(case: &Case, schedule: &Schedule) -> Setup {
    let remote = schedule.remote;
    let speed = schedule.realtime.unwrap_or(1.0);
    let mut cfg = LaunchConfig::default();
    // The harness's agents beat every 0.5 s (`agent.rs`): the quiet rule
    // (four beats) follows the beat the agents keep.
    cfg.supervision.heartbeat_interval = 0.5;
    let run = case.run_config();
    let period_us = (run.kinematics.dt * 1e6).round() as u64;
    Setup {
        robots: case.robots,
        lockstep: schedule.realtime.is_none(),
        params: GateParams {
            goal: case.terrain.goal(),
            goal_radius: run.success_radius,
            stop_speed: cfg.gate.stop_speed,
            stop_turn_rate: cfg.gate.stop_turn_rate,
            dwell_us: (case.dwell * 1e6).round() as u64,
            period_us,
        },
        step_limit: run.step_limit(),
        wall_period_us: (period_us as f64 / speed) as u64,
        speed,
        tick_timeout_us: (cfg.supervision.tick_timeout * 1e6) as u64,
        on_death: case.on_death,
        missing: case.missing,
        prespawn: true,
        start: case.terrain.start(),
        goal: case.terrain.goal(),
        max_speed: cfg.gate.max_speed,
        link_grace_s: cfg.supervision.link_grace,
        register_timeout_s: cfg.supervision.register_timeout,
        agents: AgentTraits {
            kind: if remote { "remote" } else { "spawned" }.into(),
            all_at_once: remote,
            stop_when_stuck: false,
            start_hint: String::new(),
            placement: None,
            forward_poses: false,
            beacons: true,
        },
        unix_base_ms: 0,
        settings: SETTINGS,
        supervision: super::setup::supervision(&cfg, remote, None),
    }
}

/// Plays one launch of `case` under `schedule` to its end.
pub fn run(case: &Case, schedule: &Schedule) -> Report {
    play(case, schedule, false).0
}

/// [`run`], with the core's setup and every call made on it, as a launch
/// records them (`launch::core::log`).
pub fn run_logged(case: &Case, schedule: &Schedule) -> (Report, Setup, Vec<Call>) {
    let (report, calls) = play(case, schedule, true);
    (report, setup(case, schedule), calls)
}
