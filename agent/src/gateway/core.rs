//! The gateway as a sans-IO state machine.
//!
//! Why sans-IO: every rule of the gateway (when the link counts as lost,
//! when to repeat a goal, what a reboot means) is decided here from
//! datagrams, bus commands, poses and `now`, so it is unit-tested without
//! sockets or clocks, and the loop in [`super::run`] only moves bytes.
//! Time is [`Micros`] since the shell's epoch, as for every core
//! ([`bycoms_protocol::SansIo`]); the core is the robot side
//! ([`super::session::RobotSide`]) of the session that implements that
//! shape, [`super::session::GatewaySession`].
//!
//! Rules:
//! * a hello is answered with a welcome in a fresh random session; the
//!   robot's address is the source of its last authentic frame (a robot
//!   that changed address keeps working, a forger gains nothing: its frames
//!   fail the tag);
//! * `Deploy` enables the robot, `Stop` stops it for good, `Shutdown` stops
//!   it and ends the gateway; while enabled the last goal bearing is
//!   (re)sent at least every `goal_every`, turned into the robot's frame
//!   with its latest heading from motion capture (a robot without a pose
//!   gets no goal: its failsafe stops it);
//! * the robot's telemetry says what it is doing: an enabled robot that
//!   reports `Idle` (a lost Enable, or a reboot) is enabled again, a stopped
//!   one that still drives is stopped again;
//! * no authentic robot frame for `link_timeout` → `Link { up: false }`; the
//!   next authentic frame → `Link { up: true }`; refused frames are counted
//!   and reported at most once a second.

use crate::angle::wrap;
use bycoms_protocol::link::{DropCounters, MAX_FRAME_LEN};
use bycoms_protocol::link::{DropReason, GatewayEvent, GatewayLink, LinkKey, Payload, RobotState, SessionId};
use bycoms_protocol::msg::{FromAgent, LinkStatus, Pose, Status, StopDone, Telemetry, ToAgent};
use bycoms_protocol::{Micros, RobotId};
use bycoms_runtime::epoch::micros_ceil;
use rand::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::collections::VecDeque;
use std::net::SocketAddr;
use std::time::Duration;

/// How often refused-frame counts are reported at most, µs.
const REFUSED_REPORT_EVERY: Micros = 1_000_000;

/// The gateway's timers (wall time; divide by the lab's speed-up to run
/// with an emulated lab faster than real time). Durations, as a command
/// line gives them; the core counts them in whole µs, rounded up (at
/// least this long since, as on `Instant`s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timers {
    /// Resend the goal at least this often while enabled.
    pub goal_every: Duration,
    /// Send a link heartbeat when nothing was sent for this long.
    pub heartbeat_every: Duration,
    /// Report the link lost after this long without an authentic frame.
    pub link_timeout: Duration,
}

impl Timers {
    /// LINK.md's defaults: goal every 100 ms, heartbeat after 100 ms
    /// of silence, link lost after 300 ms; all divided by `speed`.
    pub fn paper(speed: f64) -> Self {
        let ms = |m: f64| Duration::from_secs_f64(m / 1000.0 / speed);
        Self { goal_every: ms(100.0), heartbeat_every: ms(100.0), link_timeout: ms(300.0) }
    }
}

impl Timers {
    /// The timers in the core's µs (rounded up).
    fn micros(&self) -> TimersUs {
        TimersUs {
            goal_every: micros_ceil(self.goal_every),
            heartbeat_every: micros_ceil(self.heartbeat_every),
            link_timeout: micros_ceil(self.link_timeout),
        }
    }
}

/// [`Timers`] in µs.
#[derive(Clone, Copy, Debug)]
struct TimersUs {
    goal_every: Micros,
    heartbeat_every: Micros,
    link_timeout: Micros,
}

/// A datagram from the robot's side of the link, with its source: the
/// gateway's link input ([`super::session::RobotSide::Link`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Datagram<'a> {
    /// Its bytes.
    pub bytes: &'a [u8],
    /// Where it came from.
    pub from: SocketAddr,
}

/// What the core wants done.
#[derive(Clone, Debug, PartialEq)]
pub enum Output {
    /// Send this datagram to the robot.
    Datagram(Vec<u8>, SocketAddr),
    /// Publish this on the robot's `from_agent`.
    Report(FromAgent),
}

/// A command the core refused (bad traffic on the bus).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum Refused {
    /// A command for another robot.
    #[error("command for robot {got}, this gateway serves robot {mine}")]
    WrongRobot {
        /// The robot named.
        got: u32,
        /// This gateway's robot.
        mine: u32,
    },
    /// A non-finite goal bearing.
    #[error("goal bearing is not finite")]
    NotFinite,
    /// A lockstep tick: a real robot runs on its own clock.
    #[error("Tick sent to a real robot (real robots run in real time only)")]
    Tick,
}

/// One robot's gateway.
pub struct GatewayCore {
    link: GatewayLink,
    robot: RobotId,
    timers: TimersUs,
    rng: Xoshiro256PlusPlus,
    started: Micros,
    peer: Option<SocketAddr>,
    last_valid: Option<Micros>,
    up: bool,
    enabled: bool,
    stopped: bool,
    goal_world: Option<f64>,
    heading: Option<f64>,
    robot_state: Option<RobotState>,
    last_sent: Option<Micros>,
    last_goal: Option<Micros>,
    last_repair: Option<Micros>,
    refused_reported: u32,
    last_refused_report: Option<Micros>,
    out: VecDeque<Output>,
}

impl GatewayCore {
    /// A gateway for `robot` with `key`; `seed` seeds the session ids
    /// (from the OS in the binary, fixed in tests); it starts at `now`
    /// (its link heartbeats say the time since).
    pub fn new(robot: RobotId, key: LinkKey, timers: Timers, seed: u64, now: Micros) -> Self {
        Self {
            link: GatewayLink::new(robot, key),
            robot,
            timers: timers.micros(),
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            started: now,
            peer: None,
            last_valid: None,
            up: false,
            enabled: false,
            stopped: false,
            goal_world: None,
            heading: None,
            robot_state: None,
            last_sent: None,
            last_goal: None,
            last_repair: None,
            refused_reported: 0,
            last_refused_report: None,
            out: VecDeque::new(),
        }
    }

    /// The robot served.
    pub fn robot(&self) -> RobotId {
        self.robot
    }

    /// Refused link frames, by reason.
    pub fn drops(&self) -> &DropCounters {
        self.link.drops()
    }

    /// Whether authentic frames arrive (the last `Link` report's `up`).
    pub fn link_up(&self) -> bool {
        self.up
    }

    /// The robot's address, once it has spoken.
    pub fn peer(&self) -> Option<SocketAddr> {
        self.peer
    }

    /// The next thing to do, if any.
    pub fn poll(&mut self) -> Option<Output> {
        self.out.pop_front()
    }

    /// One datagram from `from` at `now`. A refused one is counted (and
    /// its reason returned); it changes nothing else.
    pub fn on_datagram(&mut self, now: Micros, bytes: &[u8], from: SocketAddr) -> Result<(), DropReason> {
        let accepted = self.link.receive(bytes)?;
        self.peer = Some(from);
        let silent = self.silent_ms(now);
        self.last_valid = Some(now);
        if !self.up {
            self.up = true;
            let status = self.link_status(true, silent);
            self.report(FromAgent::Link(status));
        }
        if accepted.session_started.is_some() {
            tracing::info!(robot = self.robot.0, %from, "robot session started");
            // A (re)connected robot may have rebooted: tell it again.
            self.robot_state = None;
            if self.enabled {
                self.send(Payload::Enable, now);
                self.send_goal(now);
            } else if self.stopped {
                self.send(Payload::Stop, now);
            }
        }
        match accepted.event {
            GatewayEvent::Hello(nonce) => {
                let fresh = SessionId(self.rng.next_u64().max(1));
                let mut buf = [0u8; MAX_FRAME_LEN];
                match self.link.welcome(nonce, fresh, &mut buf) {
                    Ok(w) => self.out.push_back(Output::Datagram(w.to_vec(), from)),
                    Err(e) => tracing::error!(robot = self.robot.0, "cannot encode a welcome: {e}"),
                }
            }
            GatewayEvent::Telemetry(t) => {
                self.robot_state = Some(t.state);
                let status = Status { robot: self.robot, mode: t.mode, step: u64::from(t.step) };
                self.report(FromAgent::Status(status));
                self.report(FromAgent::Telemetry(Telemetry::from_link(self.robot, &t)));
                self.repair(t.state, now);
            }
            GatewayEvent::Heartbeat { .. } => {}
        }
        Ok(())
    }

    /// One command from the orchestrator at `now`. `Ok(true)` means: shut
    /// down now (after sending what is queued).
    pub fn on_command(&mut self, now: Micros, cmd: &ToAgent) -> Result<bool, Refused> {
        let mine = self.robot.0;
        match cmd {
            ToAgent::Deploy(d) if d.robot != self.robot => {
                return Err(Refused::WrongRobot { got: d.robot.0, mine });
            }
            ToAgent::Deploy(_) => {
                self.enabled = true;
                self.stopped = false;
                self.send(Payload::Enable, now);
            }
            ToAgent::GoalBearing(b) if b.robot != self.robot => {
                return Err(Refused::WrongRobot { got: b.robot.0, mine });
            }
            ToAgent::GoalBearing(b) if !b.bearing.is_finite() => return Err(Refused::NotFinite),
            ToAgent::GoalBearing(b) => {
                self.goal_world = Some(b.bearing);
                self.send_goal(now);
            }
            ToAgent::Tick(_) | ToAgent::Ticks(_) => return Err(Refused::Tick),
            // Answered every time (the orchestrator re-sends `Stop` until
            // it hears this), saying whether the stop frame went out.
            ToAgent::Stop => {
                let on_link = self.stop(now);
                self.report(FromAgent::StopDone(StopDone { robot: self.robot, on_link }));
            }
            ToAgent::Shutdown => {
                self.stop(now);
                return Ok(true);
            }
            // Handled by the run loop, which knows its own instance.
            ToAgent::Refused(_) => {}
            // A real robot hears the others; the launch sends gateways none.
            ToAgent::Beacon(_) => {}
        }
        Ok(false)
    }

    /// The robot's own pose from motion capture (its heading turns goal
    /// bearings into its frame).
    pub fn on_pose(&mut self, pose: &Pose) {
        if pose.robot == self.robot && pose.heading.is_finite() {
            self.heading = Some(pose.heading);
        }
    }

    /// Runs the timers due by `now`.
    pub fn advance(&mut self, now: Micros) {
        if self.up && self.last_valid.is_some_and(|t| now.saturating_sub(t) >= self.timers.link_timeout) {
            self.up = false;
            let silent = self.silent_ms(now);
            tracing::warn!(robot = self.robot.0, silent_ms = silent, "robot link lost");
            let status = self.link_status(false, silent);
            self.report(FromAgent::Link(status));
        }
        if self.enabled && self.last_goal.is_none_or(|t| now.saturating_sub(t) >= self.timers.goal_every) {
            self.send_goal(now);
        }
        if self.link.session().is_some()
            && self.last_sent.is_none_or(|t| now.saturating_sub(t) >= self.timers.heartbeat_every)
        {
            let uptime_ms = (now.saturating_sub(self.started) / 1000) as u32;
            self.send(Payload::GatewayHeartbeat { uptime_ms }, now);
        }
        let refused = self.link.drops().total();
        if refused != self.refused_reported
            && self.last_refused_report.is_none_or(|t| now.saturating_sub(t) >= REFUSED_REPORT_EVERY)
        {
            let silent = self.silent_ms(now);
            self.last_refused_report = Some(now);
            let status = self.link_status(self.up, silent);
            self.report(FromAgent::Link(status));
        }
    }

    /// When [`GatewayCore::advance`] next has something to do (none: only
    /// when something comes in). A past time means: now.
    pub fn deadline(&self) -> Option<Micros> {
        let after = |last: Option<Micros>, every: Micros| {
            Some(last.map_or(self.started, |t| t.saturating_add(every)))
        };
        let link = match self.last_valid {
            Some(t) if self.up => Some(t.saturating_add(self.timers.link_timeout)),
            _ => None,
        };
        let goal = if self.enabled && self.goal_world.is_some() && self.heading.is_some() {
            after(self.last_goal, self.timers.goal_every)
        } else {
            None
        };
        let beat = match self.link.session() {
            Some(_) => after(self.last_sent, self.timers.heartbeat_every),
            None => None,
        };
        let refused = if self.link.drops().total() != self.refused_reported {
            after(self.last_refused_report, REFUSED_REPORT_EVERY)
        } else {
            None
        };
        [link, goal, beat, refused].into_iter().flatten().min()
    }

    /// Whether the robot is enabled (deployed, not stopped since).
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Whether the robot has been told to stop (and not enabled since).
    pub fn stopped(&self) -> bool {
        self.stopped
    }

    /// Stops the robot for good, on the gateway's own account (its
    /// failsafe, a refusal, its end): nobody to answer.
    pub fn stop_robot(&mut self, now: Micros) {
        self.stop(now);
    }

    /// Stops the robot for good; whether the stop frame went out.
    fn stop(&mut self, now: Micros) -> bool {
        self.enabled = false;
        self.stopped = true;
        self.send(Payload::Stop, now)
    }

    /// Re-sends Enable or Stop when the robot's state contradicts them
    /// (a lost datagram), at most once per goal period.
    fn repair(&mut self, state: RobotState, now: Micros) {
        if self.last_repair.is_some_and(|t| now.saturating_sub(t) < self.timers.goal_every) {
            return;
        }
        let fix = match state {
            RobotState::Idle if self.enabled => Payload::Enable,
            RobotState::Driving | RobotState::Failsafe if self.stopped => Payload::Stop,
            _ => return,
        };
        self.last_repair = Some(now);
        self.send(fix, now);
    }

    fn send_goal(&mut self, now: Micros) {
        let (Some(goal), Some(heading)) = (self.goal_world, self.heading) else { return };
        if !self.enabled {
            return;
        }
        let bearing = wrap(goal - heading) as f32;
        self.last_goal = Some(now);
        self.send(Payload::Goal { bearing }, now);
    }

    /// Sends `payload` to the robot; whether it went out.
    fn send(&mut self, payload: Payload, now: Micros) -> bool {
        let Some(peer) = self.peer else { return false };
        let mut buf = [0u8; MAX_FRAME_LEN];
        match self.link.send(payload, &mut buf) {
            Ok(frame) => {
                self.out.push_back(Output::Datagram(frame.to_vec(), peer));
                self.last_sent = Some(now);
                true
            }
            // No session yet: the robot hears it all once it connects.
            Err(e) => {
                tracing::debug!(robot = self.robot.0, ?payload, "not sent: {e}");
                false
            }
        }
    }

    fn silent_ms(&self, now: Micros) -> u32 {
        let since = self.last_valid.unwrap_or(self.started);
        u32::try_from(now.saturating_sub(since) / 1000).unwrap_or(u32::MAX)
    }

    fn link_status(&mut self, up: bool, silent_ms: u32) -> LinkStatus {
        let refused = self.link.drops().total();
        self.refused_reported = refused;
        LinkStatus { robot: self.robot, up, silent_ms, refused }
    }

    /// Queues `msg` for the robot's `from_agent` (the session's own
    /// reports go out in order with the core's).
    pub fn report(&mut self, msg: FromAgent) {
        self.out.push_back(Output::Report(msg));
    }
}

#[cfg(test)]
mod tests;
