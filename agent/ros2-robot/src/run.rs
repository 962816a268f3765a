//! The ROS 2 robot's loop: the bus side (the gateway's [`BusSide`]), the
//! [`Session`] around [`Ros2RobotCore`], and the robot's `cmd_vel`
//! ([`CmdVel`]); the loop only moves messages.
//!
//! Why one thread with short waits: an iceoryx2 bus is confined to the
//! thread that opened it; the loop waits on the robot's commands for at
//! most [`SLICE`] (or until the session's next deadline, if sooner), then
//! takes every pose that came, runs the session's timers and publishes
//! what they say, in order: a `StopDone` goes out after the zero velocity
//! it answers for. The session's time is µs since the loop's start (its
//! [`Epoch`], kept by the [`BusSide`]).

use crate::core::{Output, Ros2RobotCore};
use bycoms_agent::gateway::run::{BusSide, GatewayPorts};
use bycoms_agent::gateway::{Input, RobotSide, Session};
use bycoms_agent::wheeled::Velocity;
use bycoms_protocol::bus::zenoh::clock::{self, ClockProbe};
use bycoms_protocol::bus::zenoh::AliveWatch;
use bycoms_protocol::bus::{Bus, BusError};
use bycoms_protocol::SansIo;
use bycoms_runtime::failsafe::Failsafe;
use bycoms_runtime::{instance, Epoch, ExitCause, Lifeline, Traffic};
use std::time::Duration;

/// Longest wait on the bus before the lifeline and the timers are served.
pub const SLICE: Duration = Duration::from_millis(2);

/// Where the robot's velocity commands go: a ROS 2 publisher on its
/// `cmd_vel`, or a test's list. The one seam between the agent and the
/// robot's driver.
pub trait CmdVel {
    /// Sends one command; an error ends the agent (after a last zero is tried).
    fn send(&mut self, velocity: Velocity) -> Result<(), String>;
}

/// Why the loop stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The bus failed.
    #[error("bus: {0}")]
    Bus(#[from] BusError),
    /// The robot's `cmd_vel` failed.
    #[error("cmd_vel: {0}")]
    CmdVel(String),
}

/// What the agent counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sent {
    /// Velocity commands sent.
    pub commands: u64,
    /// Of them, zero velocity.
    pub zeros: u64,
}

/// One ROS 2 robot agent's loop.
pub struct Ros2Robot<B: Bus, S: CmdVel> {
    session: Session<Ros2RobotCore>,
    bus: BusSide<B>,
    cmd_vel: S,
    sent: Sent,
}

impl<B: Bus, S: CmdVel> Ros2Robot<B, S> {
    /// An agent around `core`, beating every `heartbeat_every`; over zenoh
    /// it watches the orchestrator's liveliness with `failsafe` (gone past
    /// the grace: zero velocity, then exit or wait, by policy).
    pub fn new(
        core: Ros2RobotCore,
        ports: GatewayPorts<B>,
        cmd_vel: S,
        heartbeat_every: Duration,
        failsafe: Option<(Failsafe, AliveWatch)>,
    ) -> Self {
        let (failsafe, watch) = failsafe.unzip();
        let bus = BusSide::new(ports, RobotSide::robot(&core), watch, Epoch::now());
        let session = Session::new(core, heartbeat_every, instance(), failsafe);
        Self { session, bus, cmd_vel, sent: Sent::default() }
    }

    /// Reports this host's clock offset to the orchestrator's as `probe`
    /// measures it (the first before the first `Register`).
    pub fn report_clock(&mut self, probe: ClockProbe) {
        self.bus.report_clock(probe);
    }

    /// The commands sent so far.
    pub fn sent(&self) -> Sent {
        self.sent
    }

    /// Bad bus messages counted so far.
    pub fn traffic(&self) -> &Traffic {
        self.bus.traffic()
    }

    /// Registers, then runs until `Shutdown`, a refusal, the failsafe, a
    /// signal or the parent's death; the robot is sent zero on every way out.
    pub fn run(&mut self, lifeline: &mut Lifeline) -> Result<ExitCause, RunError> {
        let robot = RobotSide::robot(self.session.core());
        self.bus.clock_reports(robot, Some(clock::FIRST_WAIT))?;
        let _ = self.session.handle(self.bus.now(), Input::Start);
        let result = self.serve(lifeline);
        if result.is_err() {
            // Whatever failed, the robot is told to stand still.
            let _ = self.session.handle(self.bus.now(), Input::End);
            let _ = self.flush();
        }
        result
    }

    fn serve(&mut self, lifeline: &mut Lifeline) -> Result<ExitCause, RunError> {
        let robot = RobotSide::robot(self.session.core());
        loop {
            self.bus.clock_reports(robot, None)?;
            if let Some(cause) = lifeline.check() {
                let _ = self.session.handle(self.bus.now(), Input::End);
                self.flush()?;
                return Ok(cause);
            }
            self.bus.watch_orchestrator(&mut self.session);
            self.session.advance(self.bus.now());
            self.flush()?;
            if let Some(cause) = self.session.exit() {
                return Ok(cause);
            }
            let wait = match self.session.deadline() {
                Some(due) => self.bus.epoch().until(due).min(SLICE),
                None => SLICE,
            };
            let exit = self.bus.drain(&mut self.session, Some(wait))?;
            self.flush()?;
            if let Some(cause) = exit {
                return Ok(cause);
            }
        }
    }

    /// Sends and publishes everything the session queued, in order.
    fn flush(&mut self) -> Result<(), RunError> {
        while let Some(out) = self.session.poll() {
            match out {
                Output::Velocity(v) => {
                    self.cmd_vel.send(v).map_err(RunError::CmdVel)?;
                    self.sent.commands += 1;
                    self.sent.zeros += u64::from(v == Velocity::ZERO);
                }
                Output::Report(msg) => self.bus.publish(&msg)?,
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
