//! The gateway's bus-side rules as a sans-IO state machine, around
//! [`GatewayCore`] (the robot-side rules) or any other [`RobotSide`]: a
//! ROS 2 robot's agent (`bycoms-ros2-robot`) registers, beats and fails
//! safe by the very same rules.
//!
//! Why apart from the loop: these rules used to live in the IO loop
//! (`run.rs`) on wall clocks, so the simulation harness could not run them.
//! Here one bus command, datagram, orchestrator liveliness change or `now`
//! goes in, and what to send comes out ([`Session::poll_output`]) with the
//! next time something is due ([`Session::deadline`]); [`super::run`] only
//! moves bytes, and the orchestrator's harness drives the same code in
//! virtual time.
//!
//! Rules:
//! * [`Session::start`] publishes the gateway's `Register`; until the
//!   orchestrator sends a command, every heartbeat repeats it (a lost one
//!   would leave the robot never enabled);
//! * a heartbeat every `heartbeat_every`, from the start;
//! * the orchestrator's liveliness (zenoh) feeds the [`Failsafe`]: gone past
//!   its grace, the robot is told `Stop`, the orchestrator is told
//!   (`FromAgent::Failsafe`, again when it returns) and the session ends
//!   with [`ExitCause::OrchestratorLost`] or goes on, by policy;
//! * `Shutdown` stops the robot and ends the session; a refusal of this
//!   gateway's own instance (another gateway holds the robot) stops it and
//!   ends it; [`Session::end`] (a signal, the parent gone) stops it.

use super::core::{GatewayCore, Output, Refused};
use bycoms_protocol::link::DropReason;
use bycoms_protocol::msg::{FromAgent, Heartbeat, Pose, Register, RobotKind, ToAgent};
use bycoms_protocol::{RobotId, PROTOCOL_VERSION};
use bycoms_runtime::failsafe::{Failsafe, Verdict};
use bycoms_runtime::ExitCause;
use std::net::SocketAddr;
use std::time::{Duration, Instant};

/// The robot-side rules a [`Session`] wraps: what a real robot's agent does
/// with the orchestrator's commands and its own pose, and the reports and
/// robot commands it queues.
pub trait RobotSide {
    /// What it wants done (datagrams, velocity commands, reports).
    type Output;
    /// The robot served.
    fn robot(&self) -> RobotId;
    /// Queues a report for the robot's `from_agent`, in order with its own.
    fn report(&mut self, msg: FromAgent);
    /// One command from the orchestrator; `Ok(true)`: shut down now (after
    /// sending what is queued).
    fn on_command(&mut self, cmd: &ToAgent, now: Instant) -> Result<bool, Refused>;
    /// The robot's own pose from motion capture.
    fn on_pose(&mut self, pose: &Pose);
    /// Runs the timers.
    fn poll(&mut self, now: Instant);
    /// The next thing to do, if any.
    fn poll_output(&mut self) -> Option<Self::Output>;
    /// When [`RobotSide::poll`] next has something to do.
    fn deadline(&self) -> Option<Instant>;
    /// Stops the robot for good on the agent's own account (its failsafe,
    /// a refusal, its end): nobody to answer.
    fn stop_robot(&mut self, now: Instant);
    /// Whether it waits for the robot's next pose to act (the loop then
    /// waits on the pose topic, not the commands). Default: no.
    fn awaits_pose(&self) -> bool {
        false
    }
}

impl RobotSide for GatewayCore {
    type Output = Output;
    fn robot(&self) -> RobotId {
        GatewayCore::robot(self)
    }
    fn report(&mut self, msg: FromAgent) {
        GatewayCore::report(self, msg);
    }
    fn on_command(&mut self, cmd: &ToAgent, now: Instant) -> Result<bool, Refused> {
        GatewayCore::on_command(self, cmd, now)
    }
    fn on_pose(&mut self, pose: &Pose) {
        GatewayCore::on_pose(self, pose);
    }
    fn poll(&mut self, now: Instant) {
        GatewayCore::poll(self, now);
    }
    fn poll_output(&mut self) -> Option<Output> {
        GatewayCore::poll_output(self)
    }
    fn deadline(&self) -> Option<Instant> {
        GatewayCore::deadline(self)
    }
    fn stop_robot(&mut self, now: Instant) {
        GatewayCore::stop_robot(self, now);
    }
}

/// One real robot's session with the orchestrator, around its robot side
/// (a gateway's [`GatewayCore`] unless said otherwise).
pub struct Session<C: RobotSide = GatewayCore> {
    core: C,
    register: Register,
    heartbeat_every: Duration,
    seq: u64,
    /// None until [`Session::start`].
    next_heartbeat: Option<Instant>,
    heard_orchestrator: bool,
    failsafe: Option<Failsafe>,
}

impl Session<GatewayCore> {
    /// One datagram from the robot's side; a refused one is counted.
    pub fn on_datagram(&mut self, bytes: &[u8], from: SocketAddr, now: Instant) -> Result<(), DropReason> {
        self.core.on_datagram(bytes, from, now)
    }
}

impl<C: RobotSide> Session<C> {
    /// A session of process `instance` around `core`, beating every
    /// `heartbeat_every`, with the orchestrator-liveliness `failsafe`
    /// (zenoh; none over iceoryx2, where the lifeline ties the processes).
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
            heartbeat_every,
            seq: 0,
            next_heartbeat: None,
            heard_orchestrator: false,
            failsafe,
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

    /// Registers with the orchestrator (heartbeats start now).
    pub fn start(&mut self, now: Instant) {
        self.core.report(FromAgent::Register(self.register));
        self.next_heartbeat = Some(now);
    }

    /// The robot's own pose from motion capture.
    pub fn on_pose(&mut self, pose: &Pose) {
        self.core.on_pose(pose);
    }

    /// One command from the orchestrator: why the session ends, if it does
    /// (`Shutdown`, this instance refused); a command the core refused is
    /// returned as such (bad traffic).
    pub fn on_command(&mut self, cmd: &ToAgent, now: Instant) -> Result<Option<ExitCause>, Refused> {
        if let ToAgent::Refused(r) = cmd {
            // A refusal of another instance is not for us.
            if r.instance != self.register.instance {
                return Ok(None);
            }
            tracing::error!(
                robot = r.robot.0,
                "refused by the orchestrator for robot {}: {}",
                r.robot.0,
                r.why
            );
            self.stop(now);
            return Ok(Some(ExitCause::Refused));
        }
        self.heard_orchestrator = true;
        Ok(self.core.on_command(cmd, now)?.then_some(ExitCause::Shutdown))
    }

    /// The orchestrator's liveliness token came (`alive`) or went at `at`
    /// (zenoh); [`Session::poll`] acts on it.
    pub fn orchestrator(&mut self, alive: bool, at: Instant) {
        match (self.failsafe.as_mut(), alive) {
            (Some(f), true) => f.orchestrator_alive(at),
            (Some(f), false) => f.orchestrator_lost(at),
            (None, _) => {}
        }
    }

    /// The process ends (a signal, the parent gone): the robot is stopped.
    pub fn end(&mut self, now: Instant) {
        self.stop(now);
    }

    /// Runs what is due at `now`: the failsafe, heartbeats, the core's
    /// timers. Why the session ends, if the failsafe ends it.
    pub fn poll(&mut self, now: Instant) -> Option<ExitCause> {
        if let Some(cause) = self.check_failsafe(now) {
            return Some(cause);
        }
        if self.next_heartbeat.is_some_and(|t| now >= t) {
            self.seq += 1;
            self.next_heartbeat = Some(now + self.heartbeat_every);
            if !self.heard_orchestrator && self.seq > 1 {
                self.core.report(FromAgent::Register(self.register));
            }
            let beat = Heartbeat { robot: self.register.robot, seq: self.seq };
            self.core.report(FromAgent::Heartbeat(beat));
        }
        self.core.poll(now);
        None
    }

    /// The next thing to send or publish, if any.
    pub fn poll_output(&mut self) -> Option<C::Output> {
        self.core.poll_output()
    }

    /// When [`Session::poll`] next has something to do (none: only when
    /// something comes in).
    pub fn deadline(&self) -> Option<Instant> {
        let failsafe = self.failsafe.as_ref().and_then(Failsafe::deadline);
        [self.next_heartbeat, failsafe, self.core.deadline()].into_iter().flatten().min()
    }

    /// Acts on the failsafe's verdict at `now`.
    fn check_failsafe(&mut self, now: Instant) -> Option<ExitCause> {
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

    fn stop(&mut self, now: Instant) {
        self.core.stop_robot(now);
    }
}

#[cfg(test)]
mod tests;
