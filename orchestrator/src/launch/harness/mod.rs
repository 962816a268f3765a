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
mod net;
mod schedule;

pub use agent::{Agent, Sent};
pub use net::{Link, Net, Packet, Partition};
pub use schedule::{Crash, Foreign, Schedule};

use super::agents::{Gone, Reach};
use super::config::{LaunchConfig, Missing, OnDeath};
use super::core::log::{Call, Logged};
use super::core::{AgentTraits, Ending, Input, Output, Setup, SlotState};
use super::gate::GateParams;
use super::summary::Outcome;
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
    /// Ticks each robot's agent stepped.
    pub stepped: Vec<u64>,
    /// Deployments each robot got (agents that took a `Deploy`).
    pub deploys_sent: Vec<u64>,
    /// Robots that registered after their turn was skipped.
    pub late: Vec<u32>,
    /// Virtual time of each gate event (parallel to `gates`), µs.
    pub gate_times_us: Vec<u64>,
    /// When each robot's first registration reached the core, µs.
    pub registered_us: Vec<Option<u64>>,
}

#[derive(Clone, Debug, PartialEq)]
enum Event {
    Crash(u32),
    Tell(Input),
    Forge(Foreign),
    SecondAgent(u32),
    Interrupt,
}

/// A launch in virtual time.
struct World<'a> {
    case: &'a Case,
    schedule: &'a Schedule,
    core: Logged,
    net: Net,
    agents: Vec<Option<Agent>>,
    impostors: Vec<Agent>,
    started_at: Vec<Option<u64>>,
    heard_at: Vec<Option<u64>>,
    unreachable: Vec<bool>,
    events: BinaryHeap<Reverse<(u64, u64, usize)>>,
    event_list: Vec<Option<Event>>,
    seq: u64,
    now: u64,
    report: Report,
    register_timeout_us: u64,
    heartbeat_timeout_us: u64,
    link_grace_us: u64,
    early_deaths_left: Vec<u32>,
}

/// The core's setup for `case` with agents of `schedule`'s kind and clock.
pub fn setup(case: &Case, schedule: &Schedule) -> Setup {
    let remote = schedule.remote;
    let speed = schedule.realtime.unwrap_or(1.0);
    let cfg = LaunchConfig::default();
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
        },
        unix_base_ms: 0,
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

fn play(case: &Case, schedule: &Schedule, logged: bool) -> (Report, Vec<Call>) {
    let cfg = LaunchConfig::default();
    let n = case.robots as usize;
    let mut world = World {
        case,
        schedule,
        core: Logged::new(setup(case, schedule), logged),
        net: Net::new(schedule.link.clone(), schedule.partitions.clone(), schedule.seed),
        agents: (0..n).map(|_| None).collect(),
        impostors: Vec::new(),
        started_at: vec![None; n],
        heard_at: vec![None; n],
        unreachable: vec![false; n],
        events: BinaryHeap::new(),
        event_list: Vec::new(),
        seq: 0,
        now: 0,
        report: Report {
            ending: None,
            failure: None,
            gates: Vec::new(),
            robots: Vec::new(),
            spent: 0,
            ticks: 0,
            resends: 0,
            end_us: 0,
            bad: 0,
            stepped: vec![0; n],
            deploys_sent: vec![0; n],
            late: Vec::new(),
            gate_times_us: Vec::new(),
            registered_us: vec![None; n],
        },
        register_timeout_us: (cfg.supervision.register_timeout * 1e6) as u64,
        heartbeat_timeout_us: (cfg.supervision.heartbeat_timeout * 1e6) as u64,
        link_grace_us: (cfg.supervision.link_grace * 1e6) as u64,
        early_deaths_left: schedule.early_deaths.clone(),
    };
    world.plan();
    world.play();
    let calls = world.core.take_calls();
    (world.finish(), calls)
}

impl World<'_> {
    fn at(&mut self, at: u64, event: Event) {
        self.seq += 1;
        self.event_list.push(Some(event));
        self.events.push(Reverse((at, self.seq, self.event_list.len() - 1)));
    }

    /// Puts the schedule's own events on the timeline.
    fn plan(&mut self) {
        let s = self.schedule;
        for c in &s.crashes {
            self.at(c.at_us, Event::Crash(c.robot));
        }
        for &(robot, at) in &s.second_agents {
            self.at(at, Event::SecondAgent(robot));
        }
        for (at, f) in &s.foreign {
            self.at(*at, Event::Forge(*f));
        }
        if let Some(at) = s.interrupt_at_us {
            self.at(at, Event::Interrupt);
        }
        if s.remote {
            let lease = 400_000;
            for p in &s.partitions {
                let lost = p.from_us + lease;
                if lost >= p.until_us {
                    continue;
                }
                self.at(lost, Event::Tell(Input::Reach(p.robot, Reach::Lost)));
                if p.until_us - lost <= self.link_grace_us {
                    self.at(p.until_us, Event::Tell(Input::Reach(p.robot, Reach::Back)));
                } else {
                    let grace_ms = self.link_grace_us / 1000;
                    self.at(
                        lost + self.link_grace_us,
                        Event::Tell(Input::Gone(p.robot, Gone::Unreachable { grace_ms })),
                    );
                }
            }
        }
    }

    fn play(&mut self) {
        let mut idle_rounds = 0u32;
        loop {
            let now = self.now;
            self.core.advance(now);
            self.carry_out();
            if self.core.ending().is_some() {
                return;
            }
            let next = [
                self.core.deadline(),
                self.net.next_at(),
                self.events.peek().map(|Reverse((at, _, _))| *at),
                self.agents.iter().flatten().filter(|a| a.alive).filter_map(|a| a.next_beat).min(),
                self.agents.iter().flatten().filter(|a| a.alive).filter_map(|a| a.next_period).min(),
                self.watchdog_due(),
            ]
            .into_iter()
            .flatten()
            .min();
            let Some(next) = next else {
                self.report.failure = Some(format!("stalled at {} µs: nothing to wait for, no ending", now));
                return;
            };
            if next <= now {
                idle_rounds += 1;
                if idle_rounds > 1000 {
                    self.report.failure = Some(format!("spins at {now} µs without progress"));
                    return;
                }
            } else {
                idle_rounds = 0;
            }
            self.now = next.max(now);
            if self.now > HANG_US {
                self.report.failure =
                    Some(format!("did not end within {} s of virtual time", HANG_US / 1_000_000));
                return;
            }
            self.deliver();
        }
    }

    fn carry_out(&mut self) {
        while let Some(out) = self.core.poll_output() {
            let now = self.now;
            match out {
                Output::Start(id) => self.start(id),
                Output::Send(id, msg) => {
                    if matches!(msg, ToAgent::Deploy(_)) {
                        if let Some(d) = self.report.deploys_sent.get_mut(id as usize - 1) {
                            *d += 1;
                        }
                    }
                    self.net.send(now, id, Packet::ToAgent(id, msg));
                }
                Output::Relay(pose) => {
                    self.net.send(now, 0, Packet::Pose { topic: pose.robot.0, pose, relay: true });
                }
                Output::Gate(e) => {
                    self.report.gates.push(e);
                    self.report.gate_times_us.push(now);
                }
                Output::Kill(id) => {
                    if let Some(Some(a)) = self.agents.get_mut(id as usize - 1) {
                        a.alive = false;
                    }
                    self.started_at[id as usize - 1] = None;
                }
                Output::Heard(id) => {
                    if let Some(h) = self.heard_at.get_mut(id as usize - 1) {
                        *h = Some(now);
                    }
                }
                Output::Bad(..) => self.report.bad += 1,
                Output::Forward(_)
                | Output::Event(_)
                | Output::Note(_)
                | Output::RobotLink(..)
                | Output::SimTime(_)
                | Output::AskOperator(_)
                | Output::Carried(..) => {}
            }
        }
    }

    /// Real time: one control period in wall µs.
    fn wall_period_us(&self) -> Option<u64> {
        self.schedule.realtime.map(|speed| (self.case.run_config().kinematics.dt * 1e6 / speed) as u64)
    }

    fn start(&mut self, id: u32) {
        let i = id as usize - 1;
        if self.schedule.remote && self.agents[i].as_ref().is_some_and(|a| a.alive) {
            // A remote agent exists on its own: expected again, not made.
            self.started_at[i] = Some(self.now);
            let now = self.now;
            self.core.handle(now, Input::Started { robot: id, pid: None, how: "awaiting its agent".into() });
            return;
        }
        let delay = self.schedule.register_delay_us.get(i).copied().unwrap_or(Some(50_000));
        let instance = 0x1000 + u64::from(id);
        let agent = Agent::new(
            id,
            instance,
            self.case.terrain.clone(),
            self.case.run_config(),
            delay.map(|d| self.now + d),
            self.wall_period_us(),
        );
        self.agents[i] = Some(agent);
        self.started_at[i] = Some(self.now);
        if let Some(left) = self.early_deaths_left.get_mut(i).filter(|n| **n > 0) {
            *left -= 1;
            let at = self.now + 5_000;
            self.at(at, Event::Crash(id));
        }
        let now = self.now;
        let (pid, how) = if self.schedule.remote {
            (None, "awaiting its agent")
        } else {
            (Some(10_000 + id), "agent started")
        };
        self.core.handle(now, Input::Started { robot: id, pid, how: how.into() });
    }

    /// The agent source's timers: registration and heartbeat timeouts.
    fn watchdog_due(&self) -> Option<u64> {
        (0..self.agents.len())
            .filter_map(|i| {
                let started = self.started_at[i]?;
                match self.heard_at[i] {
                    None => Some(started + self.register_timeout_us),
                    Some(_) if self.unreachable[i] => None,
                    Some(h) => Some(h + self.heartbeat_timeout_us),
                }
            })
            .min()
    }

    fn watchdog(&mut self) {
        let now = self.now;
        for i in 0..self.agents.len() {
            let Some(started) = self.started_at[i] else { continue };
            let gone = match self.heard_at[i] {
                None if now >= started + self.register_timeout_us => Some(Gone::NeverRegistered),
                Some(h) if !self.unreachable[i] && now >= h + self.heartbeat_timeout_us => Some(Gone::Silent),
                _ => None,
            };
            if let Some(gone) = gone {
                self.started_at[i] = None;
                // A remote agent that never registered still exists on its
                // host (it may come late); anything else was killed.
                let outlives = self.schedule.remote && gone == Gone::NeverRegistered;
                if let Some(a) = self.agents[i].as_mut().filter(|_| !outlives) {
                    a.alive = false;
                }
                self.core.handle(now, Input::Gone(i as u32 + 1, gone));
            }
        }
    }

    /// Everything due now, in time then sending order.
    fn deliver(&mut self) {
        let now = self.now;
        while let Some(Reverse((at, _, index))) = self.events.peek().copied() {
            if at > now {
                break;
            }
            self.events.pop();
            if let Some(event) = self.event_list[index].take() {
                self.happen(event);
            }
        }
        while let Some(packet) = self.net.pop_due(now) {
            self.arrive(packet);
        }
        let mut sent = Vec::new();
        for a in self.agents.iter_mut().flatten().filter(|a| a.alive) {
            if a.next_beat.is_some_and(|t| t <= now) {
                a.beat(now, &mut sent);
            }
            if a.next_period.is_some_and(|t| t <= now) {
                let before = a.stepped;
                a.period(now, &mut sent);
                self.report.stepped[a.id() as usize - 1] += a.stepped - before;
            }
            for s in sent.drain(..) {
                Self::send_from(&mut self.net, now, a.id(), s);
            }
        }
        self.watchdog();
    }

    fn send_from(net: &mut Net, now: u64, id: u32, sent: Sent) {
        match sent {
            Sent::Report(r) => net.send(now, id, Packet::Report(r)),
            Sent::Pose(p) => net.send(now, id, Packet::Pose { topic: id, pose: p, relay: false }),
        }
    }

    fn happen(&mut self, event: Event) {
        let now = self.now;
        match event {
            Event::Crash(id) => {
                let alive =
                    self.agents.get(id as usize - 1).and_then(Option::as_ref).is_some_and(|a| a.alive);
                if alive && self.started_at[id as usize - 1].is_some() {
                    if let Some(Some(a)) = self.agents.get_mut(id as usize - 1) {
                        a.alive = false;
                    }
                    self.started_at[id as usize - 1] = None;
                    let gone = if self.schedule.remote {
                        Gone::Disconnected
                    } else {
                        Gone::Exited(std::process::ExitStatus::from_raw(9))
                    };
                    // The process's end is seen within a few milliseconds.
                    self.at(now + 5_000, Event::Tell(Input::Gone(id, gone)));
                }
            }
            Event::Tell(input) => {
                if let Input::Reach(id, r) = &input {
                    self.unreachable[*id as usize - 1] = *r == Reach::Lost;
                    if *r == Reach::Back {
                        self.heard_at[*id as usize - 1] = Some(now);
                    }
                }
                if let Input::Gone(id, _) = &input {
                    self.started_at[*id as usize - 1] = None;
                    if let Some(Some(a)) = self.agents.get_mut(*id as usize - 1) {
                        a.alive = false;
                    }
                }
                self.core.handle(now, input);
            }
            Event::Forge(f) => match f.input(self) {
                Some(input) => self.core.handle(now, input),
                // Not possible yet (the robot has no pose): a little later,
                // while the launch runs.
                None if self.core.ending().is_none() => self.at(now + 10_000, Event::Forge(f)),
                None => {}
            },
            Event::SecondAgent(id) if !self.registered(id) => {
                // A second agent for a registered robot: later, once it is.
                if self.core.ending().is_none() {
                    self.at(now + 10_000, Event::SecondAgent(id));
                }
            }
            Event::SecondAgent(id) => {
                let mut a = Agent::new(
                    id,
                    0xbad0 + u64::from(id),
                    self.case.terrain.clone(),
                    self.case.run_config(),
                    Some(now),
                    self.wall_period_us(),
                );
                let mut sent = Vec::new();
                a.beat(now, &mut sent);
                for s in sent {
                    Self::send_from(&mut self.net, now, id, s);
                }
                self.impostors.push(a);
            }
            Event::Interrupt => self.core.handle(now, Input::Interrupt),
        }
    }

    fn arrive(&mut self, packet: Packet) {
        let now = self.now;
        match packet {
            Packet::Report(r) => {
                let i = r.robot().0 as usize;
                if matches!(r, FromAgent::Register(_)) && (1..=self.report.registered_us.len()).contains(&i) {
                    self.report.registered_us[i - 1].get_or_insert(now);
                }
                self.core.handle(now, Input::Report(r));
            }
            Packet::Pose { topic, pose, relay } => {
                if !relay {
                    self.core.handle(now, Input::Pose { topic, pose });
                }
                for a in self.agents.iter_mut().flatten() {
                    if !self.net.cut(a.id(), now) {
                        a.peer_pose(topic, &pose);
                    }
                }
            }
            Packet::ToAgent(id, cmd) => {
                let mut sent = Vec::new();
                if let Some(Some(a)) = self.agents.get_mut(id as usize - 1) {
                    let before = a.stepped;
                    a.command(&cmd, &mut sent);
                    self.report.stepped[id as usize - 1] += a.stepped - before;
                }
                for imp in self.impostors.iter_mut().filter(|a| a.id() == id) {
                    imp.command(&cmd, &mut Vec::new());
                }
                for s in sent {
                    Self::send_from(&mut self.net, now, id, s);
                }
            }
        }
    }

    fn finish(mut self) -> Report {
        let core = &self.core;
        self.report.ending = core.ending().cloned();
        self.report.robots = core.slots().iter().map(|s| (s.state(), s.steps(), s.last_pose())).collect();
        self.report.late = core.slots().iter().filter(|s| s.joined_late()).map(|s| s.id()).collect();
        self.report.spent = core.spent();
        self.report.ticks = core.ticks();
        self.report.resends = core.resends();
        self.report.end_us = self.now;
        self.report
    }

    /// Whether robot `id` has a registered agent.
    fn registered(&self, id: u32) -> bool {
        self.core
            .slots()
            .get(id as usize - 1)
            .is_some_and(|s| s.alive() && !matches!(s.state(), SlotState::Waiting | SlotState::Spawned))
    }

    /// Robot `id`'s true latest pose (its agent's), for forgeries.
    fn true_pose(&self, id: u32) -> Option<Pose> {
        self.core.slots().get(id as usize - 1).and_then(|s| s.last_pose())
    }
}

impl Foreign {
    /// The forged input at the world's current state (none if it makes no
    /// sense now, e.g. a pose of a robot never seen).
    fn input(self, w: &World<'_>) -> Option<Input> {
        let goal = w.case.terrain.goal();
        let tick = w.core.ticks();
        match self {
            Foreign::StepFromTheFuture(id) => {
                let mut p = w.true_pose(id)?;
                p.step = u64::MAX;
                p.time_us = u64::MAX;
                Some(Input::Pose { topic: id, pose: p })
            }
            Foreign::HugeStep(id) => {
                let mut p = w.true_pose(id)?;
                p.step = u64::MAX;
                Some(Input::Pose { topic: id, pose: p })
            }
            Foreign::NotFinite(id) => {
                let mut p = w.true_pose(id)?;
                p.x = f64::NAN;
                p.step += 1;
                Some(Input::Pose { topic: id, pose: p })
            }
            Foreign::AtTheGoal(id) => {
                let p = w.true_pose(id)?;
                // Only a jump no robot could drive is a forgery.
                if Vec2::new(p.x, p.y).distance(goal) < 3.0 {
                    return None;
                }
                let forged =
                    Pose { x: goal.x, y: goal.y, step: p.step + 1, time_us: p.time_us + 100_000, ..p };
                Some(Input::Pose { topic: id, pose: forged })
            }
            Foreign::OtherRobotsPose { topic, robot } => {
                let p = Pose {
                    robot: RobotId(robot),
                    x: goal.x,
                    y: goal.y,
                    heading: 0.0,
                    step: tick,
                    time_us: tick * 100_000,
                };
                Some(Input::Pose { topic, pose: p })
            }
            Foreign::WrongVersion(id) => Some(Input::Report(FromAgent::Register(Register {
                robot: RobotId(id),
                kind: bycoms_protocol::msg::AgentKind::Simulated,
                protocol_version: bycoms_protocol::PROTOCOL_VERSION + 1,
                instance: 0xf0e1,
            }))),
            Foreign::UnknownRobot => {
                Some(Input::Report(FromAgent::Heartbeat(Heartbeat { robot: RobotId(999), seq: 1 })))
            }
        }
    }
}

/// The exit code a launch with this ending has (the README's table).
pub fn exit_code(ending: &Ending) -> i32 {
    match ending.outcome {
        Outcome::Arrived => 0,
        Outcome::RobotsExhausted | Outcome::TimeLimit => 3,
        Outcome::Interrupted => 130,
        Outcome::Error => 1,
    }
}

/// The properties every schedule keeps; the first broken one, in words.
pub fn check(report: &Report, schedule: &Schedule) -> Result<(), String> {
    if let Some(f) = &report.failure {
        return Err(f.clone());
    }
    let Some(ending) = &report.ending else { return Err("no ending".into()) };
    if (ending.outcome == Outcome::Error) != ending.error.is_some() {
        return Err(format!("outcome {:?} with error {:?}", ending.outcome, ending.error));
    }
    if ending.error.as_ref().is_some_and(|e| e.trim().is_empty()) {
        return Err("an error without words".into());
    }
    let _ = exit_code(ending);
    // Deployments: each robot at most once, in id order (but for robots
    // that joined late, which take a later turn); each verdict follows its
    // robot's deployment and precedes the next one.
    let mut open: Option<u32> = None;
    let mut last_deployed = 0;
    for g in &report.gates {
        let id = g.robot.0;
        match g.kind {
            GateKind::Deployed => {
                if let Some(o) = open {
                    return Err(format!("robot {id} deployed while robot {o} was still under watch"));
                }
                if id <= last_deployed && !report.late.contains(&id) {
                    return Err(format!("robot {id} deployed after robot {last_deployed}"));
                }
                last_deployed = last_deployed.max(id);
                open = Some(id);
            }
            _ => {
                if open != Some(id) {
                    return Err(format!("a verdict ({:?}) on robot {id}, which was not under watch", g.kind));
                }
                open = None;
            }
        }
    }
    for (i, &sent) in report.deploys_sent.iter().enumerate() {
        let deployed =
            report.gates.iter().filter(|g| g.robot.0 == i as u32 + 1 && g.kind == GateKind::Deployed).count();
        if deployed > 1 {
            return Err(format!("robot {} deployed {deployed} times", i + 1));
        }
        let _ = sent;
    }
    // Nothing charged twice: the budget is the robots' active steps, and no
    // robot has more active steps than ticks ran or than its agent stepped.
    let sum: u64 = report.robots.iter().map(|r| r.1).sum();
    if sum != report.spent {
        return Err(format!("spent {} but the robots' steps sum to {sum}", report.spent));
    }
    // Periods that ran: lockstep ticks, or real time's wall time × speed.
    let periods = match schedule.realtime {
        None => report.ticks,
        Some(speed) => (report.end_us as f64 * speed / 100_000.0) as u64 + 2,
    };
    for (i, r) in report.robots.iter().enumerate() {
        if r.1 > periods {
            return Err(format!("robot {} charged {} steps in {periods} periods", i + 1, r.1));
        }
        if let Some(p) = r.2 {
            if !(p.x.is_finite() && p.y.is_finite()) {
                return Err(format!("robot {} ended at a non-finite pose", i + 1));
            }
        }
    }
    let arrived = report.robots.iter().filter(|r| r.0 == SlotState::Arrived).count();
    if arrived > 1 || (arrived == 1) != (ending.outcome == Outcome::Arrived) {
        return Err(format!("{arrived} robots arrived, outcome {:?}", ending.outcome));
    }
    // Re-sends are bounded: at most every awaited robot once a second.
    let bound = (report.end_us / 1_000_000 + 2) * u64::from(schedule.robots) * 2;
    if report.resends > bound {
        return Err(format!(
            "{} re-sends in {} s (bound {bound})",
            report.resends,
            report.end_us / 1_000_000
        ));
    }
    Ok(())
}

/// Figures of a launch that starts with robots missing (see
/// [`missing_robots`]).
#[derive(Clone, Debug)]
pub struct MissingFigures {
    /// From robot 1's registration to its deployment, µs.
    pub first_deploy_after_register_us: u64,
    /// The longest wait from one turn (a verdict, or the start) to the next
    /// deployment, per absent robot skipped in it, µs.
    pub longest_wait_per_absent_us: u64,
    /// Robots skipped as absent.
    pub absent: Vec<u32>,
    /// Robots deployed.
    pub deployed: usize,
    /// The launch itself.
    pub report: Report,
}

/// A launch of 50 robots of which 5 never come (robots 2, 4, 6, 8, 10)
/// and 5 die before they register (robots 3, 5, 7, 9, 11; processes
/// started here die twice, as the one restart they get dies too), with
/// remote agents or agents spawned here, and its figures.
pub fn missing_robots(remote: bool) -> MissingFigures {
    let mut case = Case::small(0);
    case.robots = 50;
    case.time_limit = 1000.0;
    let mut schedule = Schedule::clean(0, case.robots);
    schedule.remote = remote;
    for id in [2usize, 4, 6, 8, 10] {
        schedule.register_delay_us[id - 1] = None;
    }
    for id in [3usize, 5, 7, 9, 11] {
        schedule.early_deaths[id - 1] = if remote { 1 } else { 2 };
    }
    let report = run(&case, &schedule);
    let absent: Vec<u32> =
        (1..=case.robots).filter(|&id| report.robots[id as usize - 1].0 == SlotState::Absent).collect();
    let deployed_at = |id: u32| {
        report
            .gates
            .iter()
            .zip(&report.gate_times_us)
            .find(|(g, _)| g.robot.0 == id && g.kind == GateKind::Deployed)
            .map(|(_, &t)| t)
    };
    let registered = report.registered_us.first().copied().flatten().unwrap_or(0);
    let first_deploy_after_register_us = deployed_at(1).map_or(u64::MAX, |t| t.saturating_sub(registered));
    // Each deployment after the first: the wait since the last verdict,
    // shared among the absent robots skipped in between.
    let mut longest = 0;
    let mut turn_at = 0;
    let mut last_deployed = 0;
    for (g, &t) in report.gates.iter().zip(&report.gate_times_us) {
        if g.kind == GateKind::Deployed {
            let skipped = absent.iter().filter(|&&a| a > last_deployed && a < g.robot.0).count() as u64;
            longest = longest.max(t.saturating_sub(turn_at) / skipped.max(1));
            last_deployed = g.robot.0;
        } else {
            turn_at = t;
        }
    }
    let deployed = report.gates.iter().filter(|g| g.kind == GateKind::Deployed).count();
    MissingFigures {
        first_deploy_after_register_us,
        longest_wait_per_absent_us: longest,
        absent,
        deployed,
        report,
    }
}
