//! The gateway's bus-side rules as a sans-IO state machine, around
//! [`GatewayCore`] (the robot-side rules) or any other [`RobotSide`]: a
//! ROS 2 robot's agent (`bycoms-ros2-robot`) registers, beats and fails
//! safe by the very same rules.
//!
//! Why apart from the loop: these rules used to live in the IO loop
//! (`run.rs`) on wall clocks, so the simulation harness could not run them.
//! Here one bus command, datagram, orchestrator liveliness change or `now`
//! goes in, and what to send comes out with the next time something is
//! due: the session is a [`SansIo`] core like every other (one [`Input`]
//! at a time with [`SansIo::handle`], timers with [`SansIo::advance`],
//! what to send with [`SansIo::poll`], [`SansIo::deadline`]), its time
//! [`Micros`] since the shell's epoch; [`super::run`] only moves bytes,
//! and the orchestrator's harness drives the same code in virtual time.
//! Why the session ended, if it did, is [`Session::exit`] (a `Shutdown`,
//! this instance refused, the failsafe): a state the shell reads after
//! each call, not an output, so that it sends everything queued first.
//!
//! The robot side ([`RobotSide`]) has the same shape and time type
//! without being a [`SansIo`] itself: what comes in to it is split by
//! kind (a command, the pose, its own link's input) because the session
//! decides which of its inputs it sees, and its `Register`, heartbeats and
//! stops are queued by the session through it.
//!
//! Rules:
//! * [`Input::Start`] publishes the gateway's `Register`; until the
//!   orchestrator sends a command, every heartbeat repeats it (a lost one
//!   would leave the robot never enabled);
//! * a heartbeat every `heartbeat_every`, from the start;
//! * the orchestrator's liveliness (zenoh) feeds the [`Failsafe`]: gone past
//!   its grace, the robot is told `Stop`, the orchestrator is told
//!   (`FromAgent::Failsafe`, again when it returns) and the session ends
//!   with [`ExitCause::OrchestratorLost`] or goes on, by policy;
//! * `Shutdown` stops the robot and ends the session; a refusal of this
//!   gateway's own instance (another gateway holds the robot) stops it and
//!   ends it; [`Input::End`] (a signal, the parent gone) stops it.

use super::core::{Datagram, GatewayCore, Output, Refused};
use bycoms_protocol::link::DropReason;
use bycoms_protocol::msg::{FromAgent, Heartbeat, Pose, Register, RobotKind, ToAgent};
use bycoms_protocol::{Micros, RobotId, SansIo, PROTOCOL_VERSION};
use bycoms_runtime::epoch::micros_ceil;
use bycoms_runtime::failsafe::{Failsafe, Verdict};
use bycoms_runtime::ExitCause;
use std::time::Duration;

/// The robot-side rules a [`Session`] wraps: what a real robot's agent does
/// with the orchestrator's commands, its own pose and its own link's
/// input, and the reports and robot commands it queues. Time is
/// [`Micros`] since the shell's epoch, as in [`SansIo`].
pub trait RobotSide {
    /// What it wants done (datagrams, velocity commands, reports).
    type Output;
    /// What its own link hands in (a gateway's [`Datagram`]s; a robot side
    /// without one: [`std::convert::Infallible`]).
    type Link<'a>;
    /// The robot served.
    fn robot(&self) -> RobotId;
    /// Queues a report for the robot's `from_agent`, in order with its own.
    fn report(&mut self, msg: FromAgent);
    /// One command from the orchestrator at `now`; `Ok(true)`: shut down
    /// now (after sending what is queued).
    fn on_command(&mut self, now: Micros, cmd: &ToAgent) -> Result<bool, Refused>;
    /// The robot's own pose from motion capture.
    fn on_pose(&mut self, pose: &Pose);
    /// One input from its own link at `now`; a refused one is counted and
    /// its reason returned.
    fn on_link(&mut self, now: Micros, input: Self::Link<'_>) -> Result<(), DropReason>;
    /// Runs the timers due by `now`.
    fn advance(&mut self, now: Micros);
    /// The next thing to do, if any.
    fn poll(&mut self) -> Option<Self::Output>;
    /// When [`RobotSide::advance`] next has something to do.
    fn deadline(&self) -> Option<Micros>;
    /// Stops the robot for good on the agent's own account (its failsafe,
    /// a refusal, its end): nobody to answer.
    fn stop_robot(&mut self, now: Micros);
    /// Whether it waits for the robot's next pose to act (the loop then
    /// waits on the pose topic, not the commands). Default: no.
    fn awaits_pose(&self) -> bool {
        false
    }
}

impl RobotSide for GatewayCore {
    type Output = Output;
    type Link<'a> = Datagram<'a>;
    fn robot(&self) -> RobotId {
        GatewayCore::robot(self)
    }
    fn report(&mut self, msg: FromAgent) {
        GatewayCore::report(self, msg);
    }
    fn on_command(&mut self, now: Micros, cmd: &ToAgent) -> Result<bool, Refused> {
        GatewayCore::on_command(self, now, cmd)
    }
    fn on_pose(&mut self, pose: &Pose) {
        GatewayCore::on_pose(self, pose);
    }
    fn on_link(&mut self, now: Micros, d: Datagram<'_>) -> Result<(), DropReason> {
        GatewayCore::on_datagram(self, now, d.bytes, d.from)
    }
    fn advance(&mut self, now: Micros) {
        GatewayCore::advance(self, now);
    }
    fn poll(&mut self) -> Option<Output> {
        GatewayCore::poll(self)
    }
    fn deadline(&self) -> Option<Micros> {
        GatewayCore::deadline(self)
    }
    fn stop_robot(&mut self, now: Micros) {
        GatewayCore::stop_robot(self, now);
    }
}

/// What comes in to a real robot's agent ([`Session`]'s [`SansIo::Input`]);
/// `L` is its robot side's link input ([`RobotSide::Link`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Input<'a, L = Datagram<'a>> {
    /// The agent starts: it registers with the orchestrator (heartbeats
    /// start now).
    Start,
    /// One command from the orchestrator.
    Command(&'a ToAgent),
    /// The robot's own pose from motion capture.
    Pose(&'a Pose),
    /// One input from the robot's own link (a gateway's datagram).
    Link(L),
    /// The orchestrator's liveliness token came (`alive`) or went (zenoh),
    /// at the time handed in; [`SansIo::advance`] acts on it.
    Orchestrator {
        /// Whether it came.
        alive: bool,
    },
    /// The process ends (a signal, the parent gone): the robot is stopped.
    End,
}

/// An input the session refused at once (bad traffic; nothing else
/// changed): the shell counts or logs it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Rejected {
    /// A command the robot side refused.
    #[error(transparent)]
    Command(#[from] Refused),
    /// A link frame the robot side refused.
    #[error("link frame refused: {0}")]
    Frame(DropReason),
}

/// One real robot's session with the orchestrator, around its robot side
/// (a gateway's [`GatewayCore`] unless said otherwise).
pub struct Session<C: RobotSide = GatewayCore> {
    core: C,
    register: Register,
    heartbeat_every: Micros,
    seq: u64,
    /// None until [`Input::Start`].
    next_heartbeat: Option<Micros>,
    heard_orchestrator: bool,
    failsafe: Option<Failsafe>,
    exit: Option<ExitCause>,
}

/// The gateway's session: what its loop ([`super::run`]) and the launch
/// harness drive.
pub type GatewaySession = Session<GatewayCore>;

impl<C: RobotSide> Session<C> {
    /// A session of process `instance` around `core`, beating every
    /// `heartbeat_every` (counted in whole µs, rounded up), with the
    /// orchestrator-liveliness `failsafe` (zenoh; none over iceoryx2,
    /// where the lifeline ties the processes).
    pub fn new(core: C, heartbeat_every: Duration, instance: u64, failsafe: Option<Failsafe>) -> Self {
        let register = Register {
            robot: core.robot(),
            kind: RobotKind::Real,
            protocol_version: PROTOCOL_VERSION,
            instance,
            settings: 0,
            failsafe_grace_ms: failsafe.as_ref().map_or(0, Failsafe::grace_ms),
        };
        Self {
            core,
            register,
            heartbeat_every: micros_ceil(heartbeat_every),
            seq: 0,
            next_heartbeat: None,
            heard_orchestrator: false,
            failsafe,
            exit: None,
        }
    }

    /// The robot-side core (drop counters, link state).
    pub fn core(&self) -> &C {
        &self.core
    }

    /// Whether the failsafe stopped the robot.
    pub fn failsafe_tripped(&self) -> bool {
        self.failsafe.as_ref().is_some_and(Failsafe::tripped)
    }

    /// Why the session ended, if it did: `Shutdown`, this instance
    /// refused, the orchestrator lost past the failsafe's grace. The shell
    /// sends what is queued, then ends.
    pub fn exit(&self) -> Option<ExitCause> {
        self.exit
    }

    /// Registers with the orchestrator (heartbeats start now).
    fn start(&mut self, now: Micros) {
        self.core.report(FromAgent::Register(self.register));
        self.next_heartbeat = Some(now);
    }

    /// One command from the orchestrator: the session ends on `Shutdown`
    /// and on this instance's refusal; a command the core refused is
    /// returned as such (bad traffic).
    fn command(&mut self, now: Micros, cmd: &ToAgent) -> Result<(), Rejected> {
        if let ToAgent::Refused(r) = cmd {
            // A refusal of another instance is not for us.
            if r.instance != self.register.instance {
                return Ok(());
            }
            tracing::error!(
                robot = r.robot.0,
                "refused by the orchestrator for robot {}: {}",
                r.robot.0,
                r.why
            );
            self.stop(now);
            self.exit = Some(ExitCause::Refused);
            return Ok(());
        }
        self.heard_orchestrator = true;
        if self.core.on_command(now, cmd)? {
            self.exit = Some(ExitCause::Shutdown);
        }
        Ok(())
    }

    /// The orchestrator's liveliness token came (`alive`) or went at `at`.
    fn orchestrator(&mut self, alive: bool, at: Micros) {
        match (self.failsafe.as_mut(), alive) {
            (Some(f), true) => f.orchestrator_alive(at),
            (Some(f), false) => f.orchestrator_lost(at),
            (None, _) => {}
        }
    }

    /// Acts on the failsafe's verdict at `now`.
    fn check_failsafe(&mut self, now: Micros) -> Option<ExitCause> {
        let verdict = self.failsafe.as_mut()?.check(now);
        if let Some(report) = verdict.report(self.core.robot()) {
            self.core.report(report);
        }
        let (lost_for, exit) = match verdict {
            Verdict::Run => return None,
            Verdict::Remind { lost_for } => {
                tracing::info!(?lost_for, "orchestrator back: told it that the failsafe stopped the robot");
                return None;
            }
            Verdict::Stop { lost_for } => (lost_for, false),
            Verdict::StopAndExit { lost_for } => (lost_for, true),
        };
        tracing::error!(
            ?lost_for,
            "orchestrator lost past the grace period: robot stopped, {}",
            if exit { "exiting" } else { "waiting" }
        );
        self.stop(now);
        exit.then_some(ExitCause::OrchestratorLost)
    }

    fn stop(&mut self, now: Micros) {
        self.core.stop_robot(now);
    }
}

impl<C: RobotSide> SansIo for Session<C> {
    type Input<'a> = Input<'a, C::Link<'a>>;
    type Handled = Result<(), Rejected>;
    type Output<'a>
        = C::Output
    where
        Self: 'a;

    /// Takes one input at `now`; a command or a link frame the robot side
    /// refused is returned (nothing else changed).
    fn handle(&mut self, now: Micros, input: Self::Input<'_>) -> Result<(), Rejected> {
        match input {
            Input::Start => self.start(now),
            Input::Command(cmd) => return self.command(now, cmd),
            Input::Pose(pose) => self.core.on_pose(pose),
            Input::Link(link) => return self.core.on_link(now, link).map_err(Rejected::Frame),
            Input::Orchestrator { alive } => self.orchestrator(alive, now),
            Input::End => self.stop(now),
        }
        Ok(())
    }

    /// Runs what is due at `now`: the failsafe (which may end the session:
    /// [`Session::exit`]), heartbeats, the core's timers.
    fn advance(&mut self, now: Micros) {
        if let Some(cause) = self.check_failsafe(now) {
            self.exit = Some(cause);
            return;
        }
        if self.next_heartbeat.is_some_and(|t| now >= t) {
            self.seq += 1;
            self.next_heartbeat = Some(now.saturating_add(self.heartbeat_every));
            if !self.heard_orchestrator && self.seq > 1 {
                self.core.report(FromAgent::Register(self.register));
            }
            let beat = Heartbeat { robot: self.register.robot, seq: self.seq };
            self.core.report(FromAgent::Heartbeat(beat));
        }
        self.core.advance(now);
    }

    /// The next thing to send or publish, if any.
    fn poll(&mut self) -> Option<C::Output> {
        self.core.poll()
    }

    /// When [`SansIo::advance`] next has something to do (none: only when
    /// something comes in).
    fn deadline(&self) -> Option<Micros> {
        let failsafe = self.failsafe.as_ref().and_then(Failsafe::deadline);
        [self.next_heartbeat, failsafe, self.core.deadline()].into_iter().flatten().min()
    }
}

#[cfg(test)]
mod tests;
