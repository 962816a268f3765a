//! The agent's bus loop: move messages between the bus and [`AgentCore`].
//!
//! Why one thread and bounded waits: an iceoryx2 bus is confined to the
//! thread that opened it, and an agent must notice a dead parent or a
//! signal within a bounded time, so the loop never waits longer than
//! [`SLICE`] before checking its [`Lifeline`] and its heartbeat timer —
//! except a parked robot's agent (it gets no more ticks), which waits until
//! its next heartbeat, slower than a moving robot's (`--parked-heartbeat-ms`,
//! at most 1 s from a launch): a `Shutdown` still wakes it at once.
//!
//! The beacons of its field come on its command topic
//! ([`ToAgent::Beacon`]), before the `Deploy` and in order with the ticks.
//! Per control period the agent steps the core, then publishes, in this
//! order, its pose
//! (simulated motion capture), a `Status` with its mode (when it stepped)
//! and, in lockstep, `Parked` (once its robot froze or was stopped: the
//! orchestrator then ticks it no more) and `TickDone`. Publishing is synchronous into shared
//! memory, so once the orchestrator holds `TickDone(t)` the pose of step `t`
//! is already in its queue.
//!
//! Lockstep: a period is a `Tick` from the orchestrator; the goal bearing for
//! step `t` precedes `Tick(t)` on the same topic. Real time: a period is due
//! every `0.1 s / speed` of wall time; a period whose deadline has passed
//! before the agent got to it is skipped and counted as missed (the frame
//! number in the pose jumps), as it would be on a real robot.

use super::core::{AgentCore, Phase, Reject};
use super::options::Clock;
use bycoms_protocol::bus::zenoh::{AliveWatch, Presence};
use bycoms_protocol::bus::{Bus, BusError, BusExt, TypedPublisher, TypedSubscriber};
use bycoms_protocol::msg::{FromAgent, Heartbeat, Pose, Register, RobotKind, Status, ToAgent};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{RobotId, Swarm, PROTOCOL_VERSION};
use bycoms_runtime::failsafe::{Failsafe, Verdict};
use bycoms_runtime::lifeline::{ExitCause, Lifeline};
use bycoms_runtime::traffic::{BadKind, Traffic};
use std::time::{Duration, Instant};

/// Longest single wait before the loop checks its lifeline and timers.
pub const SLICE: Duration = Duration::from_millis(50);

/// Below this much time to a real-time deadline the agent sleeps precisely
/// instead of waiting on the event listener (see `run_realtime`).
pub const PRECISE: Duration = Duration::from_millis(12);

/// What one receive did.
enum Received {
    Nothing,
    Handled,
    Exit(ExitCause),
}

/// The agent's ports on the bus.
pub struct AgentPorts<B: Bus> {
    commands: TypedSubscriber<B::Subscriber, ToAgent>,
    pose: TypedPublisher<B::Publisher, Pose>,
    report: TypedPublisher<B::Publisher, FromAgent>,
}

impl<B: Bus> AgentPorts<B> {
    /// Opens every port, subscribers first, so nothing sent after the
    /// agent's `Register` can be missed.
    pub fn open(bus: &B, swarm: &Swarm, id: RobotId) -> Result<Self, BusError> {
        let commands = bus.typed_subscriber(&swarm.to_agent(id))?;
        let pose = bus.typed_publisher(&swarm.pose(id))?;
        let report = bus.typed_publisher(&swarm.from_agent(id))?;
        Ok(Self { commands, pose, report })
    }
}

/// Timing of the loop.
#[derive(Clone, Copy, Debug)]
pub struct Timing {
    /// Lockstep or real time.
    pub clock: Clock,
    /// Wall time of one period in real time (0.1 s / speed).
    pub period: Duration,
    /// Simulated duration of one period, µs (the poses' `time_us` step).
    pub dt_us: u64,
    /// Heartbeat period.
    pub heartbeat: Duration,
    /// Heartbeat period once the robot is parked (it gets no more ticks).
    pub parked_heartbeat: Duration,
}

impl Timing {
    /// The heartbeat period of a robot that is `parked` or not.
    pub fn heartbeat_of(&self, parked: bool) -> Duration {
        if parked {
            self.parked_heartbeat
        } else {
            self.heartbeat
        }
    }
}

/// Counters an agent reports when it exits.
#[derive(Clone, Copy, Debug, Default)]
pub struct AgentStats {
    /// Bad messages received.
    pub traffic: Traffic,
    /// Real-time periods run.
    pub periods: u64,
    /// Real-time periods skipped because the agent was late.
    pub missed: u64,
    /// Lockstep periods whose goal bearing was not for that period.
    pub stale_bearings: u64,
}

/// One agent process's loop.
pub struct Agent<B: Bus> {
    core: AgentCore,
    ports: AgentPorts<B>,
    timing: Timing,
    who: String,
    stats: AgentStats,
    heartbeat_seq: u64,
    next_heartbeat: Instant,
    tick: u64,
    /// Whether the orchestrator has sent this agent anything yet; until it
    /// has, every heartbeat repeats the `Register` (it may have been lost).
    heard_orchestrator: bool,
    /// The `Deploy` taken (a repeat of it is answered, another refused).
    deployed: Option<bycoms_protocol::msg::Deploy>,
    /// This process's instance ([`bycoms_runtime::instance`]), sent in `Register`.
    instance: u64,
    /// zenoh: the failsafe and the liveliness watch that feeds it.
    failsafe: Option<(Failsafe, AliveWatch)>,
    /// The fingerprint of the run settings this agent was started with,
    /// sent in `Register` (0: none).
    settings: u64,
}

impl<B: Bus> Agent<B> {
    /// An agent around `core` on `ports`.
    pub fn new(core: AgentCore, ports: AgentPorts<B>, timing: Timing) -> Self {
        let who = format!("sim-agent[robot {}]", core.id().0);
        Self {
            core,
            ports,
            timing,
            who,
            stats: AgentStats::default(),
            heartbeat_seq: 0,
            next_heartbeat: Instant::now(),
            tick: 0,
            heard_orchestrator: false,
            deployed: None,
            instance: bycoms_runtime::instance(),
            failsafe: None,
            settings: 0,
        }
    }

    /// Registers with `fingerprint`, the fingerprint of the run settings
    /// this agent runs ([`super::settings::RunSettings::fingerprint`]; 0,
    /// the default, says "none": the launch takes it whatever its own).
    pub fn set_settings(&mut self, fingerprint: u64) {
        self.settings = fingerprint;
    }

    /// Watches the orchestrator's liveliness on `watch`: once it has been
    /// gone for longer than the failsafe's grace, the robot stops, and the
    /// loop ends with [`ExitCause::OrchestratorLost`] or goes on, by policy.
    pub fn watch_orchestrator(&mut self, failsafe: Failsafe, watch: AliveWatch) {
        self.failsafe = Some((failsafe, watch));
    }

    /// Feeds the failsafe what zenoh saw and acts on its verdict.
    fn check_failsafe(&mut self) -> Option<ExitCause> {
        let (failsafe, watch) = self.failsafe.as_mut()?;
        while let Some(event) = watch.try_recv() {
            if event.member == Member::Orchestrator {
                match event.presence {
                    Presence::Alive => failsafe.orchestrator_alive(event.at),
                    Presence::Lost => failsafe.orchestrator_lost(event.at),
                }
            }
        }
        let verdict = failsafe.check(Instant::now());
        if let Some(report) = verdict.report(self.core.id()) {
            // Best effort: the link may be cut (a reminder follows its return).
            let _ = self.report(report);
        }
        match verdict {
            Verdict::Run => None,
            Verdict::Remind { lost_for } => {
                tracing::info!(?lost_for, "orchestrator back: told it that the failsafe stopped the robot");
                None
            }
            Verdict::Stop { lost_for } => {
                self.core.stop();
                tracing::error!(?lost_for, "orchestrator lost past the grace period: robot stopped, waiting");
                None
            }
            Verdict::StopAndExit { lost_for } => {
                self.core.stop();
                tracing::error!(?lost_for, "orchestrator lost past the grace period: robot stopped, exiting");
                Some(ExitCause::OrchestratorLost)
            }
        }
    }

    /// What the agent counted so far.
    pub fn stats(&self) -> AgentStats {
        self.stats
    }

    /// Registers, then runs until `Shutdown`, a signal or the parent's death.
    pub fn run(&mut self, lifeline: &mut Lifeline) -> Result<ExitCause, BusError> {
        self.register()?;
        match self.timing.clock {
            Clock::Lockstep => self.run_lockstep(lifeline),
            Clock::Realtime => self.run_realtime(lifeline),
        }
    }

    fn run_lockstep(&mut self, lifeline: &mut Lifeline) -> Result<ExitCause, BusError> {
        loop {
            if let Some(cause) = lifeline.check().or_else(|| self.check_failsafe()) {
                return Ok(cause);
            }
            self.heartbeat_if_due()?;
            // A parked robot's agent expects no tick (only `Shutdown`, which
            // wakes it): it waits without the busy-wait and the short sleeps
            // that keep a moving robot's ticks fast, until its next
            // (slower) heartbeat. A thousand of them cost 1.5 of this
            // machine's two cores otherwise, and still 0.7 of one when they
            // woke every slice and beat ten times a second.
            let idle = self.core.parked();
            let wait = match idle {
                true => self.next_heartbeat.saturating_duration_since(Instant::now()).max(SLICE),
                false => SLICE,
            };
            if let Received::Exit(cause) = self.receive(wait, idle)? {
                return Ok(cause);
            }
        }
    }

    /// Real time: a period is due every `period` from the start. Waiting on
    /// the bus's event listener is woken at once by a message but times out
    /// only to the kernel's jiffy (it oversleeps by up to ~8 ms), so the
    /// listener is used only while the deadline is more than [`PRECISE`]
    /// away, and the last stretch is a precise sleep with the commands that
    /// came meanwhile handled right after it.
    fn run_realtime(&mut self, lifeline: &mut Lifeline) -> Result<ExitCause, BusError> {
        let period_ns = self.timing.period.as_nanos().max(1);
        let t0 = Instant::now();
        let mut next: u64 = 1;
        loop {
            if let Some(cause) = lifeline.check().or_else(|| self.check_failsafe()) {
                return Ok(cause);
            }
            self.heartbeat_if_due()?;
            let due =
                t0 + Duration::from_nanos(u64::try_from(period_ns * u128::from(next)).unwrap_or(u64::MAX));
            let now = Instant::now();
            if now >= due {
                let index = u64::try_from(now.duration_since(t0).as_nanos() / period_ns).unwrap_or(u64::MAX);
                self.stats.missed += index.saturating_sub(next);
                self.stats.periods += 1;
                self.period(index)?;
                next = index.saturating_add(1);
                // An agent that is always late would otherwise never read
                // its commands (no bearing, no `Shutdown`): take what came.
                if let Some(cause) = self.drain_commands()? {
                    return Ok(cause);
                }
                continue;
            }
            let left = due.duration_since(now);
            if left > PRECISE {
                if let Received::Exit(cause) = self.receive((left - PRECISE).min(SLICE), false)? {
                    return Ok(cause);
                }
            } else {
                if let Some(cause) = self.drain_commands()? {
                    return Ok(cause);
                }
                std::thread::sleep(due.saturating_duration_since(Instant::now()));
            }
        }
    }

    /// Handles every command already waiting; the exit cause if one says so.
    fn drain_commands(&mut self) -> Result<Option<ExitCause>, BusError> {
        loop {
            match self.receive(Duration::ZERO, false)? {
                Received::Nothing => return Ok(None),
                Received::Handled => {}
                Received::Exit(cause) => return Ok(Some(cause)),
            }
        }
    }

    /// Waits up to `timeout` for one command and handles it.
    /// Takes the next command within `timeout`; `idle`: nothing is
    /// expected soon ([`TypedSubscriber::recv_idle`]).
    fn receive(&mut self, timeout: Duration, idle: bool) -> Result<Received, BusError> {
        let next = if idle {
            self.ports.commands.recv_idle(timeout)
        } else {
            self.ports.commands.recv_timeout(timeout)
        };
        match next {
            Ok(Some(cmd)) => Ok(match self.handle(cmd)? {
                Some(cause) => Received::Exit(cause),
                None => Received::Handled,
            }),
            Ok(None) => Ok(Received::Nothing),
            Err(e) => match self.stats.traffic.absorb(&self.who, "to_agent", e) {
                None => Ok(Received::Handled),
                Some(fatal) => Err(fatal),
            },
        }
    }

    fn handle(&mut self, cmd: ToAgent) -> Result<Option<ExitCause>, BusError> {
        if let ToAgent::Refused(r) = cmd {
            // Every agent on this robot's topic hears a refusal; only the
            // refused instance leaves, the one the orchestrator kept stays.
            if r.instance == self.instance {
                tracing::error!(
                    robot = r.robot.0,
                    "refused by the orchestrator for robot {}: {}",
                    r.robot.0,
                    r.why
                );
                return Ok(Some(ExitCause::Refused));
            }
            return Ok(None);
        }
        self.heard_orchestrator = true;
        match cmd {
            ToAgent::Deploy(d) => match self.core.deploy(&d) {
                // Motion capture sees the robot at its start at once: this
                // pose is the gate's "deployed" acknowledgement, and the
                // status after it wakes an orchestrator waiting on reports.
                Ok(()) => {
                    self.deployed = Some(d);
                    self.publish_pose(self.tick)?;
                    let status =
                        Status { robot: self.core.id(), mode: self.core.mode() as u8, step: self.tick };
                    self.report(FromAgent::Status(status))?;
                }
                // The same `Deploy` again (re-sent when its answer was
                // lost): answered again with where the robot is. Another
                // one is refused and counted.
                Err(Reject::AlreadyDeployed) if self.deployed == Some(d) => {
                    self.publish_pose(self.tick)?;
                    let status =
                        Status { robot: self.core.id(), mode: self.core.mode() as u8, step: self.tick };
                    self.report(FromAgent::Status(status))?;
                }
                Err(r) => self.refuse(r),
            },
            ToAgent::GoalBearing(b) => {
                if let Err(r) = self.core.set_bearing(&b) {
                    self.refuse(r);
                }
            }
            ToAgent::Tick(t) => match self.timing.clock {
                // A tick already stepped is a repeat (the orchestrator
                // re-sends what went unanswered, e.g. across a cut link):
                // answered again, never stepped twice.
                Clock::Lockstep if t.step <= self.tick => {
                    if t.step == self.tick {
                        self.publish_pose(self.tick)?;
                        self.tick_done(t.step)?;
                    } else {
                        tracing::debug!(who = %self.who, step = t.step, at = self.tick, "an old tick, ignored");
                    }
                }
                Clock::Lockstep => {
                    if self.core.phase() == Phase::Moving
                        && self.core.bearing().is_some_and(|b| b.step != t.step)
                    {
                        self.stats.stale_bearings += 1;
                    }
                    self.period(t.step)?;
                    self.tick_done(t.step)?;
                }
                Clock::Realtime => {
                    self.stats.traffic.count(&self.who, BadKind::Refused, &"Tick on a real-time agent");
                }
            },
            ToAgent::Stop => self.core.stop(),
            ToAgent::Shutdown => return Ok(Some(ExitCause::Shutdown)),
            ToAgent::Refused(_) => {}
            ToAgent::Beacon(b) => {
                if let Err(r) = self.core.beacon(&b) {
                    if matches!(r, Reject::BeaconOutOfOrder { .. }) {
                        tracing::error!(who = %self.who, "{r}: the field may miss a robot until it is sent again");
                    }
                    self.refuse(r);
                }
            }
        }
        Ok(None)
    }

    /// One control period numbered `step`.
    fn period(&mut self, step: u64) -> Result<(), BusError> {
        self.tick = step;
        let stepped = self.core.step();
        self.publish_pose(step)?;
        if stepped {
            let status = Status { robot: self.core.id(), mode: self.core.mode() as u8, step };
            self.report(FromAgent::Status(status))?;
        }
        Ok(())
    }

    /// Answers lockstep tick `step` ([`AgentCore::tick_answer`]).
    fn tick_done(&mut self, step: u64) -> Result<(), BusError> {
        for report in self.core.tick_answer(step) {
            self.report(report)?;
        }
        Ok(())
    }

    fn publish_pose(&mut self, step: u64) -> Result<(), BusError> {
        match self.core.pose(step, step.saturating_mul(self.timing.dt_us)) {
            Some(pose) => self.ports.pose.publish(&pose),
            None => Ok(()),
        }
    }

    fn heartbeat_if_due(&mut self) -> Result<(), BusError> {
        let now = Instant::now();
        if now < self.next_heartbeat {
            return Ok(());
        }
        self.next_heartbeat = now + self.timing.heartbeat_of(self.core.parked());
        self.heartbeat_seq += 1;
        // A lost `Register` would leave the agent heard (heartbeats) but
        // never registered: repeat it until the orchestrator answers.
        if !self.heard_orchestrator && self.heartbeat_seq > 1 {
            self.register()?;
        }
        self.report(FromAgent::Heartbeat(Heartbeat { robot: self.core.id(), seq: self.heartbeat_seq }))
    }

    fn register(&self) -> Result<(), BusError> {
        self.report(FromAgent::Register(Register {
            robot: self.core.id(),
            kind: RobotKind::Simulated,
            protocol_version: PROTOCOL_VERSION,
            instance: self.instance,
            settings: self.settings,
            failsafe_grace_ms: self.failsafe.as_ref().map_or(0, |(f, _)| f.grace_ms()),
        }))
    }

    fn report(&self, msg: FromAgent) -> Result<(), BusError> {
        self.ports.report.publish(&msg)
    }

    fn refuse(&mut self, r: Reject) {
        count_reject(&mut self.stats.traffic, &self.who, r);
    }
}

fn count_reject(traffic: &mut Traffic, who: &str, r: Reject) {
    let kind = match r {
        Reject::WrongRobot { .. } => BadKind::UnknownRobot,
        Reject::AlreadyDeployed => BadKind::Duplicate,
        Reject::NotFinite | Reject::BadKinematics | Reject::BeaconOutOfOrder { .. } => BadKind::Refused,
    };
    traffic.count(who, kind, &r);
}

#[cfg(test)]
mod tests;
