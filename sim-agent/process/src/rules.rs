//! The agent's message rules as a sans-IO state machine: [`SimAgentCore`].
//!
//! Why sans-IO: the rules of a `sim-agent` (register until heard from,
//! heartbeats every `heartbeat` and every `parked_heartbeat` once the robot
//! will never move again, `Deploy` answered with the start pose and a
//! repeat of it answered again, a `Tick` stepped once and a repeated one
//! answered without stepping, a `Ticks` run of several periods answered once,
//! real-time periods on the agent's own clock,
//! beacons, `Stop`, `Shutdown`, a refusal of this instance) used to live
//! inside the bus loop, and the launch harness restated them by hand —
//! and drifted. Here they take one command (or the time) at a time, with
//! `now` given, and queue what to send; the bus loop (`run`) only
//! carries that out, and the harness drives this same core in virtual time.
//! It has the shape of every sans-IO core ([`SansIo`]): a command with
//! [`SansIo::handle`] (which says at once whether the agent leaves), its
//! timers with [`SansIo::advance`], what it says with [`SansIo::poll`],
//! [`SansIo::deadline`].
//!
//! Time is [`Micros`] of the caller's clock (the bus loop's since it
//! started, the harness's virtual time); the core never reads a clock. A
//! command's rules do not depend on the time: [`SansIo::handle`] takes it
//! for the shape's sake and leaves every timer as it was.
//! The robot itself (body, controller, field) is the [`RobotCore`].

use super::core::{Reject, RobotCore, RobotPhase};
use super::options::Clock;
use bycoms_protocol::msg::{
    Deploy, FromAgent, Heartbeat, Parked, Pose, Register, RobotKind, Status, StopDone, TickDone, ToAgent,
};
use bycoms_protocol::{Micros, RobotId, SansIo, PROTOCOL_VERSION};
use std::collections::VecDeque;

/// The timing and identity an agent runs with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rules {
    /// Lockstep or real time.
    pub clock: Clock,
    /// Simulated duration of one period, µs (the poses' `time_us` step).
    pub dt_us: u64,
    /// Real time: wall duration of one period (0.1 s / speed), µs.
    pub period_us: u64,
    /// Heartbeat period, µs.
    pub heartbeat_us: u64,
    /// Heartbeat period once the robot is parked (it gets no more ticks), µs.
    pub parked_heartbeat_us: u64,
    /// This process's instance ([`bycoms_runtime::instance`]), sent in `Register`.
    pub instance: u64,
    /// The fingerprint of the run settings it was started with (0: none).
    pub settings: u64,
    /// Its failsafe's grace, ms (0: no failsafe).
    pub failsafe_grace_ms: u32,
}

/// What the agent sends, in order.
#[derive(Clone, Debug, PartialEq)]
pub enum Said {
    /// A report to the orchestrator.
    Report(FromAgent),
    /// Its pose on its own topic (simulated motion capture).
    Pose(Pose),
    /// A command it refused (counted and logged by the shell, never fatal).
    Refused(Reject),
}

/// Why the agent leaves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leave {
    /// The orchestrator said `Shutdown`.
    Shutdown,
    /// The orchestrator refused this instance.
    Refused,
}

/// What the rules counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Real-time periods run.
    pub periods: u64,
    /// Real-time periods skipped because the agent was late.
    pub missed: u64,
    /// Lockstep periods whose goal bearing was not for that period.
    pub stale_bearings: u64,
}

/// Real time: the clock of an agent's control periods, which runs from its
/// robot's deployment. Why not from its start: a robot not in the arena
/// has nothing to step, and a thousand agents waiting for their turn that
/// each woke ten times a second (and busy-waited before each period) took
/// the cores the others needed to start (`bench scale`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Periods {
    /// Lockstep, or not deployed yet: no periods.
    Off,
    /// Just deployed: the clock starts at the next time it is given.
    Starting,
    /// Running since `t0`; `next` is the number of the next period.
    Running { t0: u64, next: u64 },
}

/// One agent's message rules around its robot.
pub struct SimAgentCore {
    robot: RobotCore,
    rules: Rules,
    counts: Counts,
    heartbeat_seq: u64,
    /// When it next beats (none: not started).
    next_heartbeat: Option<u64>,
    /// Real time: its periods' clock.
    periods: Periods,
    /// The latest time it was given (a just-deployed robot's clock starts
    /// no earlier).
    seen: u64,
    tick: u64,
    /// The first step of the last `Ticks` run (a repeat of it is answered).
    ran_from: Option<u64>,
    /// Whether the orchestrator has sent it anything yet; until it has,
    /// every heartbeat repeats the `Register` (it may have been lost).
    heard: bool,
    /// The `Deploy` taken (a repeat of it is answered, another refused).
    deployed: Option<Deploy>,
    /// What it said and the shell has not polled yet, in order.
    out: VecDeque<Said>,
}

impl SimAgentCore {
    /// The rules `rules` around `robot`, not started.
    pub fn new(robot: RobotCore, rules: Rules) -> Self {
        Self {
            robot,
            rules,
            counts: Counts::default(),
            heartbeat_seq: 0,
            next_heartbeat: None,
            periods: Periods::Off,
            seen: 0,
            tick: 0,
            ran_from: None,
            heard: false,
            deployed: None,
            out: VecDeque::new(),
        }
    }

    /// Its robot.
    pub fn robot(&self) -> &RobotCore {
        &self.robot
    }

    /// Its robot's id.
    pub fn id(&self) -> RobotId {
        self.robot.id()
    }

    /// What it counted so far.
    pub fn counts(&self) -> Counts {
        self.counts
    }

    /// Sets the fingerprint of its run settings (sent in the next `Register`).
    pub fn set_settings(&mut self, fingerprint: u64) {
        self.rules.settings = fingerprint;
    }

    /// Sets its failsafe's grace (sent in the next `Register`).
    pub fn set_failsafe_grace_ms(&mut self, ms: u32) {
        self.rules.failsafe_grace_ms = ms;
    }

    /// Starts at `now`: registers and beats. A real-time clock starts at
    /// the robot's deployment ([`Periods`]).
    pub fn start(&mut self, now: Micros) {
        self.out.push_back(Said::Report(FromAgent::Register(self.register())));
        self.next_heartbeat = Some(now);
        self.beat_if_due(now);
    }

    /// When its next heartbeat is due (none: not started).
    pub fn next_heartbeat(&self) -> Option<u64> {
        self.next_heartbeat
    }

    /// Real time: when its next period is due (none: lockstep, or its
    /// robot not deployed yet); just deployed, at once: its clock starts
    /// at the next time it is given ([`Self::period_if_due`]).
    pub fn next_period(&self) -> Option<u64> {
        match self.periods {
            Periods::Off => None,
            Periods::Starting => Some(self.seen),
            Periods::Running { t0, next } => {
                Some(t0.saturating_add(self.rules.period_us.max(1).saturating_mul(next)))
            }
        }
    }

    /// Whether its robot will never move again (it then beats slower).
    pub fn parked(&self) -> bool {
        self.robot.parked()
    }

    /// A heartbeat if one is due at `now` (with a `Register` before it
    /// while the orchestrator has said nothing: it may have been lost).
    pub fn beat_if_due(&mut self, now: Micros) {
        self.seen = self.seen.max(now);
        match self.next_heartbeat {
            Some(due) if now >= due => {}
            _ => return,
        }
        let period = if self.parked() { self.rules.parked_heartbeat_us } else { self.rules.heartbeat_us };
        self.next_heartbeat = Some(now.saturating_add(period.max(1)));
        self.heartbeat_seq += 1;
        if !self.heard && self.heartbeat_seq > 1 {
            self.out.push_back(Said::Report(FromAgent::Register(self.register())));
        }
        let beat = Heartbeat { robot: self.id(), seq: self.heartbeat_seq };
        self.out.push_back(Said::Report(FromAgent::Heartbeat(beat)));
    }

    /// Real time: the period due at `now`, if one is, numbered by the time
    /// since its clock started (at the deployment: the start pose is period
    /// 0); the periods it was late for are skipped and counted as missed
    /// (the frame number in the pose jumps), as on a real robot. Returns
    /// whether a period ran.
    pub fn period_if_due(&mut self, now: Micros) -> bool {
        self.seen = self.seen.max(now);
        let (t0, next) = match self.periods {
            Periods::Off => return false,
            Periods::Starting => {
                self.periods = Periods::Running { t0: now, next: 1 };
                return false;
            }
            Periods::Running { t0, next } => (t0, next),
        };
        if self.next_period().is_some_and(|due| now < due) {
            return false;
        }
        let index = (now - t0) / self.rules.period_us.max(1);
        self.counts.missed += index.saturating_sub(next);
        self.counts.periods += 1;
        self.period(index);
        self.periods = Periods::Running { t0, next: index.saturating_add(1) };
        true
    }

    /// Takes command `cmd`; says why the agent leaves if it does.
    fn command(&mut self, cmd: &ToAgent) -> Option<Leave> {
        if let ToAgent::Refused(r) = cmd {
            // Every agent on this robot's topic hears a refusal; only the
            // refused instance leaves, the one the orchestrator kept stays.
            return (r.instance == self.rules.instance).then_some(Leave::Refused);
        }
        self.heard = true;
        match cmd {
            ToAgent::Deploy(d) => self.deploy(d),
            ToAgent::GoalBearing(b) => {
                if let Err(r) = self.robot.set_bearing(b) {
                    self.out.push_back(Said::Refused(r));
                }
            }
            ToAgent::Tick(t) => self.tick(t.step),
            ToAgent::Ticks(t) => self.ticks(t.step, t.count.max(1)),
            // Answered every time: the orchestrator re-sends `Stop` until
            // it hears this.
            ToAgent::Stop => {
                self.robot.stop();
                let done = StopDone { robot: self.id(), on_link: false };
                self.out.push_back(Said::Report(FromAgent::StopDone(done)));
            }
            ToAgent::Shutdown => return Some(Leave::Shutdown),
            ToAgent::Refused(_) => {}
            ToAgent::Beacon(b) => {
                if let Err(r) = self.robot.beacon(b) {
                    self.out.push_back(Said::Refused(r));
                }
            }
        }
        None
    }

    /// Stops the robot where it is (its failsafe's verdict).
    pub fn stop(&mut self) {
        self.robot.stop();
    }

    fn deploy(&mut self, d: &Deploy) {
        match self.robot.deploy(d) {
            // Motion capture sees the robot at its start at once: this pose
            // is the gate's "deployed" acknowledgement, and the status after
            // it wakes an orchestrator waiting on reports.
            Ok(()) => {
                self.deployed = Some(*d);
                if self.rules.clock == Clock::Realtime {
                    self.periods = Periods::Starting;
                }
                self.answer_deploy();
            }
            // The same `Deploy` again (re-sent when its answer was lost):
            // answered again with where the robot is. Another is refused.
            Err(Reject::AlreadyDeployed) if self.deployed == Some(*d) => self.answer_deploy(),
            Err(r) => self.out.push_back(Said::Refused(r)),
        }
    }

    fn answer_deploy(&mut self) {
        self.pose(self.tick);
        self.out.push_back(Said::Report(FromAgent::Status(self.status(self.tick))));
    }

    fn tick(&mut self, step: u64) {
        match self.rules.clock {
            Clock::Realtime => self.out.push_back(Said::Refused(Reject::TickInRealTime)),
            // A tick already stepped is a repeat (the orchestrator re-sends
            // what went unanswered, e.g. across a cut link): answered again,
            // never stepped twice.
            Clock::Lockstep if step <= self.tick => {
                if step == self.tick {
                    self.pose(step);
                    self.out.extend(self.robot.tick_answer(step).map(Said::Report));
                } else {
                    tracing::debug!(robot = self.id().0, step, at = self.tick, "an old tick, ignored");
                }
            }
            Clock::Lockstep => {
                self.stale_if(step);
                self.period(step);
                self.out.extend(self.robot.tick_answer(step).map(Said::Report));
            }
        }
    }

    /// `count` periods from `step` at once, answered once (`ToAgent::Ticks`):
    /// each period as a `Tick`'s, a robot that parks stops there (its
    /// `Parked` says the step), and a run already done is answered again.
    fn ticks(&mut self, step: u64, count: u32) {
        let robot = self.id();
        let done = FromAgent::TickDone(TickDone { robot, step });
        match self.rules.clock {
            Clock::Realtime => self.out.push_back(Said::Refused(Reject::TickInRealTime)),
            Clock::Lockstep if step <= self.tick => {
                if self.ran_from == Some(step) {
                    self.out.push_back(Said::Report(done));
                } else {
                    tracing::debug!(robot = robot.0, step, at = self.tick, "an old run of ticks, ignored");
                }
            }
            Clock::Lockstep => {
                self.ran_from = Some(step);
                let mut mode = self.robot.mode() as u8;
                for s in step..step.saturating_add(u64::from(count)) {
                    self.stale_if(s);
                    self.period(s);
                    // A status whose mode the last one said already is
                    // left out: the launch's record of the mode is the same
                    // at every tick without it, and a run is 32 periods.
                    if let Some(Said::Report(FromAgent::Status(st))) = self.out.back() {
                        if st.mode == mode {
                            self.out.pop_back();
                        }
                        mode = self.robot.mode() as u8;
                    }
                    if self.robot.parked() {
                        self.out.push_back(Said::Report(FromAgent::Parked(Parked { robot, step: s })));
                        break;
                    }
                }
                self.out.push_back(Said::Report(done));
            }
        }
    }

    /// Counts a period `step` of a moving robot whose goal bearing is not
    /// for it (a robot judged stuck is sent none any more).
    fn stale_if(&mut self, step: u64) {
        if self.robot.phase() == RobotPhase::Moving && self.robot.bearing().is_some_and(|b| b.step != step) {
            self.counts.stale_bearings += 1;
        }
    }

    /// One control period numbered `step`: step, the pose, a status if it stepped.
    fn period(&mut self, step: u64) {
        self.tick = step;
        let stepped = self.robot.step();
        self.pose(step);
        if stepped {
            self.out.push_back(Said::Report(FromAgent::Status(self.status(step))));
        }
    }

    fn pose(&mut self, step: u64) {
        if let Some(p) = self.robot.pose(step, step.saturating_mul(self.rules.dt_us)) {
            self.out.push_back(Said::Pose(p));
        }
    }

    fn status(&self, step: u64) -> Status {
        Status { robot: self.id(), mode: self.robot.mode() as u8, step }
    }

    fn register(&self) -> Register {
        Register {
            robot: self.id(),
            kind: RobotKind::Simulated,
            protocol_version: PROTOCOL_VERSION,
            instance: self.rules.instance,
            settings: self.rules.settings,
            failsafe_grace_ms: self.rules.failsafe_grace_ms,
        }
    }
}

impl SansIo for SimAgentCore {
    type Input<'a> = &'a ToAgent;
    /// Why the agent leaves, if it does (`Shutdown`, its instance refused):
    /// the shell sends what is queued, then ends.
    type Handled = Option<Leave>;
    type Output<'a> = Said;

    /// Takes command `cmd` (its rules do not depend on `now`).
    fn handle(&mut self, _now: Micros, cmd: &ToAgent) -> Option<Leave> {
        self.command(cmd)
    }

    /// Whatever is due at `now`: a heartbeat, a real-time period.
    fn advance(&mut self, now: Micros) {
        self.beat_if_due(now);
        self.period_if_due(now);
    }

    /// The next thing it says, in order.
    fn poll(&mut self) -> Option<Said> {
        self.out.pop_front()
    }

    /// Its next timer: a heartbeat or a real-time period.
    fn deadline(&self) -> Option<Micros> {
        [self.next_heartbeat, self.next_period()].into_iter().flatten().min()
    }
}

#[cfg(test)]
mod tests;
