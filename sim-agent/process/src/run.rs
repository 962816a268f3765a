//! The agent's bus loop: move messages between the bus and [`SimAgentCore`]
//! (the message rules, `rules`), which decides everything; the loop only
//! waits, reads its clock and publishes what the core says.
//!
//! Why one thread and bounded waits: an iceoryx2 bus is confined to the
//! thread that opened it, and an agent must notice a dead parent or a
//! signal within a bounded time, so the loop never waits longer than
//! [`SLICE`] before checking its [`Lifeline`] and its heartbeat timer —
//! except a parked robot's agent (it gets no more ticks), which waits until
//! its next heartbeat, slower than a moving robot's (`--parked-heartbeat-ms`,
//! at most 1 s from a launch), and a real-time agent whose robot is not
//! deployed yet, until its next heartbeat: a command (`Deploy`, `Shutdown`)
//! still wakes either at once.
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
//! Lockstep: a period is a `Tick` from the orchestrator (or one of a `Ticks`
//! run, all published at once before its one `TickDone`); the goal bearing for
//! step `t` precedes `Tick(t)` on the same topic. Real time: a period is due
//! every `0.1 s / speed` of wall time from the robot's deployment; a period
//! whose deadline has passed before the agent got to it is skipped and
//! counted as missed (the frame number in the pose jumps), as it would be on
//! a real robot. Until its robot is deployed a real-time agent only beats:
//! it sleeps on its commands until its next heartbeat, without the
//! busy-wait, like a parked one.

use super::core::{Reject, RobotCore};
use super::options::Clock;
use super::rules::{Leave, Rules, Said, SimAgentCore};
use bycoms_protocol::bus::zenoh::clock::{self, ClockProbe};
use bycoms_protocol::bus::zenoh::{AliveWatch, Presence};
use bycoms_protocol::bus::{Bus, BusError, BusExt, TypedPublisher, TypedSubscriber};
use bycoms_protocol::msg::{FromAgent, Pose, ToAgent};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{Micros, RobotId, SansIo, Swarm};
use bycoms_runtime::epoch::{micros_of, Epoch};
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
    /// The core's rules for an agent of this timing, process `instance`,
    /// run settings of fingerprint `settings` (0: none), no failsafe.
    pub fn rules(&self, instance: u64, settings: u64) -> Rules {
        let micros = micros_of;
        Rules {
            clock: self.clock,
            dt_us: self.dt_us,
            period_us: micros(self.period).max(1),
            heartbeat_us: micros(self.heartbeat),
            parked_heartbeat_us: micros(self.parked_heartbeat),
            instance,
            settings,
            failsafe_grace_ms: 0,
        }
    }

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
    core: SimAgentCore,
    ports: AgentPorts<B>,
    timing: Timing,
    who: String,
    traffic: Traffic,
    /// The loop's clock: the core's time is µs since this.
    epoch: Epoch,
    /// zenoh: the failsafe and the liveliness watch that feeds it.
    failsafe: Option<(Failsafe, AliveWatch)>,
    /// zenoh: the measurement of this host's clock offset to the
    /// orchestrator's, reported as it comes (`FromAgent::Clock`).
    clock: Option<ClockProbe>,
}

impl<B: Bus> Agent<B> {
    /// An agent around `robot` on `ports`.
    pub fn new(robot: RobotCore, ports: AgentPorts<B>, timing: Timing) -> Self {
        let who = format!("sim-agent[robot {}]", robot.id().0);
        Self {
            core: SimAgentCore::new(robot, timing.rules(bycoms_runtime::instance(), 0)),
            ports,
            timing,
            who,
            traffic: Traffic::default(),
            epoch: Epoch::now(),
            failsafe: None,
            clock: None,
        }
    }

    /// Registers with `fingerprint`, the fingerprint of the run settings
    /// this agent runs ([`super::settings::RunSettings::fingerprint`]; 0,
    /// the default, says "none": the launch takes it whatever its own).
    pub fn set_settings(&mut self, fingerprint: u64) {
        self.core.set_settings(fingerprint);
    }

    /// Watches the orchestrator's liveliness on `watch`: once it has been
    /// gone for longer than the failsafe's grace, the robot stops, and the
    /// loop ends with [`ExitCause::OrchestratorLost`] or goes on, by policy.
    pub fn watch_orchestrator(&mut self, failsafe: Failsafe, watch: AliveWatch) {
        self.core.set_failsafe_grace_ms(failsafe.grace_ms());
        self.failsafe = Some((failsafe, watch));
    }

    /// The core's time now.
    fn now(&self) -> Micros {
        self.epoch.elapsed()
    }

    /// The wall instant of core time `at`.
    fn instant(&self, at: Micros) -> Instant {
        self.epoch.instant(at)
    }

    /// Feeds the failsafe what zenoh saw and acts on its verdict.
    fn check_failsafe(&mut self) -> Option<ExitCause> {
        let epoch = self.epoch;
        let (failsafe, watch) = self.failsafe.as_mut()?;
        while let Some(event) = watch.try_recv() {
            if event.member == Member::Orchestrator {
                match event.presence {
                    Presence::Alive => failsafe.orchestrator_alive(epoch.micros(event.at)),
                    Presence::Lost => failsafe.orchestrator_lost(epoch.micros(event.at)),
                }
            }
        }
        let verdict = failsafe.check(epoch.elapsed());
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
        let c = self.core.counts();
        AgentStats {
            traffic: self.traffic,
            periods: c.periods,
            missed: c.missed,
            stale_bearings: c.stale_bearings,
        }
    }

    /// Reports this host's clock offset to the orchestrator's as `probe`
    /// measures it: the first before the `Register` (waited for up to
    /// [`clock::FIRST_WAIT`]), so the launch judges the registration by it.
    pub fn report_clock(&mut self, probe: ClockProbe) {
        self.clock = Some(probe);
    }

    /// Publishes the clock offsets measured since the last call.
    fn clock_reports(&mut self, wait: Option<Duration>) -> Result<(), BusError> {
        let Some(probe) = &self.clock else { return Ok(()) };
        let robot = self.core.id();
        let samples = match wait {
            Some(wait) => probe.wait(wait).into_iter().collect(),
            None => probe.take(),
        };
        for sample in samples {
            self.report(clock::report(robot, sample))?;
        }
        Ok(())
    }

    /// Registers, then runs until `Shutdown`, a signal or the parent's death.
    pub fn run(&mut self, lifeline: &mut Lifeline) -> Result<ExitCause, BusError> {
        self.clock_reports(Some(clock::FIRST_WAIT))?;
        let now = self.now();
        self.core.start(now);
        self.send()?;
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
            let wait = match (idle, self.core.next_heartbeat()) {
                (true, Some(at)) => self.instant(at).saturating_duration_since(Instant::now()).max(SLICE),
                _ => SLICE,
            };
            if let Received::Exit(cause) = self.receive(wait, idle)? {
                return Ok(cause);
            }
        }
    }

    /// Real time: a period is due every `period` from the start (the
    /// core's [`SimAgentCore::next_period`]). Waiting on the bus's event
    /// listener is woken at once by a message but times out only to the
    /// kernel's jiffy (it oversleeps by up to ~8 ms), so the listener is
    /// used only while the deadline is more than [`PRECISE`] away, and the
    /// last stretch is a precise sleep with the commands that came
    /// meanwhile handled right after it.
    fn run_realtime(&mut self, lifeline: &mut Lifeline) -> Result<ExitCause, BusError> {
        loop {
            if let Some(cause) = lifeline.check().or_else(|| self.check_failsafe()) {
                return Ok(cause);
            }
            self.heartbeat_if_due()?;
            let now = self.now();
            if self.core.period_if_due(now) {
                self.send()?;
                // An agent that is always late would otherwise never read
                // its commands (no bearing, no `Shutdown`): take what came.
                if let Some(cause) = self.drain_commands()? {
                    return Ok(cause);
                }
                continue;
            }
            let Some(next) = self.core.next_period() else {
                // Not deployed yet: nothing to step until the `Deploy`,
                // which wakes it; until then it only beats.
                if let Received::Exit(cause) = self.receive(self.until_heartbeat(), true)? {
                    return Ok(cause);
                }
                continue;
            };
            let due = self.instant(next);
            let left = due.saturating_duration_since(Instant::now());
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

    /// The wait until the next heartbeat (at least [`PRECISE`]: the
    /// listener's timeout is coarse anyway).
    fn until_heartbeat(&self) -> Duration {
        let at = self.core.next_heartbeat().map_or(Instant::now() + SLICE, |at| self.instant(at));
        at.saturating_duration_since(Instant::now()).max(PRECISE)
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

    /// Takes the next command within `timeout`; `idle`: nothing is
    /// expected soon ([`TypedSubscriber::recv_idle`]).
    fn receive(&mut self, timeout: Duration, idle: bool) -> Result<Received, BusError> {
        let next = if idle {
            self.ports.commands.recv_idle(timeout)
        } else {
            self.ports.commands.recv_timeout(timeout)
        };
        match next {
            Ok(Some(cmd)) => {
                let leave = self.core.handle(self.now(), &cmd);
                self.send()?;
                Ok(match leave {
                    Some(Leave::Shutdown) => Received::Exit(ExitCause::Shutdown),
                    Some(Leave::Refused) => {
                        if let ToAgent::Refused(r) = cmd {
                            tracing::error!(
                                robot = r.robot.0,
                                "refused by the orchestrator for robot {}: {}",
                                r.robot.0,
                                r.why
                            );
                        }
                        Received::Exit(ExitCause::Refused)
                    }
                    None => Received::Handled,
                })
            }
            Ok(None) => Ok(Received::Nothing),
            Err(e) => match self.traffic.absorb(&self.who, "to_agent", e) {
                None => Ok(Received::Handled),
                Some(fatal) => Err(fatal),
            },
        }
    }

    fn heartbeat_if_due(&mut self) -> Result<(), BusError> {
        self.clock_reports(None)?;
        let now = self.now();
        self.core.beat_if_due(now);
        self.send()
    }

    /// Carries out what the core said (all it has to poll): publishes,
    /// counts refusals. Only the last message to each topic
    /// wakes its readers, who find the ones before it too: a run of ticks
    /// says 32 poses at once, and each wake-up is a system call.
    fn send(&mut self) -> Result<(), BusError> {
        let said: Vec<Said> = std::iter::from_fn(|| self.core.poll()).collect();
        let last_pose = said.iter().rposition(|s| matches!(s, Said::Pose(_)));
        let last_report = said.iter().rposition(|s| matches!(s, Said::Report(_)));
        for (i, said) in said.into_iter().enumerate() {
            match said {
                Said::Report(r) if Some(i) == last_report => self.report(r)?,
                Said::Report(r) => self.ports.report.publish_quietly(&r)?,
                Said::Pose(p) if Some(i) == last_pose => self.ports.pose.publish(&p)?,
                Said::Pose(p) => self.ports.pose.publish_quietly(&p)?,
                Said::Refused(r) => {
                    if matches!(r, Reject::BeaconOutOfOrder { .. }) {
                        tracing::error!(who = %self.who, "{r}: the field may miss a robot until it is sent again");
                    }
                    count_reject(&mut self.traffic, &self.who, r);
                }
            }
        }
        Ok(())
    }

    fn report(&self, msg: FromAgent) -> Result<(), BusError> {
        self.ports.report.publish(&msg)
    }
}

fn count_reject(traffic: &mut Traffic, who: &str, r: Reject) {
    let kind = match r {
        Reject::WrongRobot { .. } => BadKind::UnknownRobot,
        Reject::AlreadyDeployed => BadKind::Duplicate,
        Reject::NotFinite
        | Reject::BadKinematics
        | Reject::BeaconOutOfOrder { .. }
        | Reject::TickInRealTime => BadKind::Refused,
    };
    traffic.count(who, kind, &r);
}

#[cfg(test)]
mod tests;
