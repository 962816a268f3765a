//! A real robot behind its gateway, in virtual time: the `gateway` binary's
//! own rules ([`GatewaySession`], the [`SansIo`] core around
//! `GatewayCore`, on the virtual clock's µs) on the bus side, the
//! robot's own firmware core ([`Firmware`]) on the far side of the UDP
//! link, and a body the world moves from the firmware's motor commands
//! (what motion capture then sees).
//!
//! Why the real code on both sides: a gateway schedule must test what runs
//! in the lab — register until heard, heartbeats, the robot-link timeout,
//! goals turned into the robot's frame, the orchestrator-liveliness
//! failsafe, and the firmware's own 500 ms failsafe. What this file adds is
//! only what is physical: the link's delay and cuts, the microphones (a
//! quiet room: every control period hears nothing), the tracks (a
//! differential drive that stops at walls), and the process around the
//! gateway (it starts, crashes or is killed).
//!
//! It also watches the robot's safety promises as it goes and notes each
//! broken one in [`RealRobot::violations`] (checked by `check.rs`):
//! a robot whose gateway said `Stop` no longer drives within
//! [`STOP_BOUND_US`] (its telemetry says so); a gateway whose orchestrator
//! is gone past the failsafe grace has stopped its robot; a robot whose
//! gateway is gone stops on its own; no goal reaches a robot whose gateway
//! never had its pose.

use bycoms_agent::acoustic::{Frame, FRAME_LEN};
use bycoms_agent::firmware::{Firmware, FirmwareConfig, FirmwareInput};
use bycoms_agent::gateway::{Datagram, GatewayCore, GatewaySession, Input, Output, Session, Timers};
use bycoms_protocol::link::{LinkKey, RobotEvent, RobotState};
use bycoms_protocol::msg::{FromAgent, Pose, ToAgent};
use bycoms_protocol::{RobotId, SansIo};
use bycoms_runtime::failsafe::Failsafe;
use bycoms_sim::terrain::Terrain;
use bycoms_sim::Vec2;
use std::collections::VecDeque;
use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::time::Duration;

/// The firmware's control period (one microphone frame), µs.
const CONTROL_US: u64 = 125_000;
/// One-way delay of the robot's WiFi link, µs.
const LINK_DELAY_US: u64 = 1_500;
/// A robot whose gateway said `Stop` drives no more after this long (the
/// datagram's trip, and the next telemetry one control period later).
pub const STOP_BOUND_US: u64 = 2 * CONTROL_US + 2 * LINK_DELAY_US;
/// A robot whose gateway is gone stops within its firmware's failsafe
/// (500 ms after the last command) and one control period.
pub const ORPHAN_BOUND_US: u64 = 500_000 + CONTROL_US + 2 * LINK_DELAY_US;
/// Track speed at full command, arena units per second.
const TOP_SPEED: f64 = 0.4;
/// Track separation, arena units.
const TRACK: f64 = 0.2;

/// Where a real robot is and which way it faces (motion capture's truth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// Position.
    pub at: Vec2,
    /// Heading, rad.
    pub heading: f64,
}

/// One real robot and its gateway; see the module docs.
pub struct RealRobot {
    id: u32,
    session: GatewaySession,
    /// The latest virtual time it was given (a pose comes without one).
    at: u64,
    firmware: Firmware<1>,
    /// The gateway process runs (not crashed, killed or ended).
    pub alive: bool,
    started: bool,
    register_at: Option<u64>,
    gone_at: Option<u64>,
    next_period: u64,
    /// Datagrams in flight: (arrival, to the robot, bytes).
    in_flight: VecDeque<(u64, bool, Vec<u8>)>,
    cuts: Vec<(u64, u64)>,
    /// Where it is.
    pub body: Body,
    posed: bool,
    stop_since: Option<u64>,
    lost_since: Option<u64>,
    grace_us: u64,
    /// Safety promises broken, in words.
    pub violations: Vec<String>,
    /// Its telemetry said `Driving` at least once.
    pub drove: bool,
}

fn addr(id: u32) -> SocketAddr {
    SocketAddr::V4(SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, id as u8), 4000))
}

impl RealRobot {
    /// Robot `id`, parked at `body`, its gateway (process `instance`)
    /// registering first at `register_at` (never if none), with the
    /// orchestrator-liveliness `failsafe` when it is remote (zenoh); its
    /// robot link cut over `cuts` (µs intervals).
    pub fn new(
        id: u32,
        instance: u64,
        register_at: Option<u64>,
        failsafe: Option<Failsafe>,
        body: Body,
        cuts: Vec<(u64, u64)>,
    ) -> Self {
        let key = LinkKey::new(&[id as u8; 32]);
        let timers = Timers::paper(1.0);
        let core = GatewayCore::new(RobotId(id), key.clone(), timers, instance, 0);
        let grace_us = failsafe.as_ref().map_or(u64::MAX, |f| u64::from(f.grace_ms()) * 1000);
        let session = Session::new(core, Duration::from_millis(100), instance, failsafe);
        let config = FirmwareConfig::paper(RobotId(id), 320.0, [512.0]);
        let firmware = match Firmware::new(config, key, [id as u8; 32]) {
            Ok(f) => f,
            Err(e) => unreachable!("the paper's tones are apart: {e}"),
        };
        Self {
            id,
            session,
            at: 0,
            firmware,
            alive: true,
            started: false,
            register_at,
            gone_at: None,
            next_period: CONTROL_US,
            in_flight: VecDeque::new(),
            cuts,
            body,
            posed: false,
            stop_since: None,
            lost_since: None,
            grace_us,
            violations: Vec::new(),
            drove: false,
        }
    }

    /// The robot.
    pub fn id(&self) -> u32 {
        self.id
    }

    /// Whether its gateway hears the robot (the link is up).
    pub fn link_up(&self) -> bool {
        self.alive && self.session.core().link_up()
    }

    /// Whether its gateway's failsafe stopped the robot.
    pub fn failsafe_tripped(&self) -> bool {
        self.session.failsafe_tripped()
    }

    /// What the firmware is doing.
    pub fn state(&self) -> RobotState {
        self.firmware.state()
    }

    fn cut(&self, at: u64) -> bool {
        self.cuts.iter().any(|&(from, until)| (from..until).contains(&at))
    }

    /// When it next does something on its own.
    pub fn deadline(&self) -> u64 {
        let gateway = match (self.alive, self.started) {
            (true, false) => self.register_at,
            (true, true) => self.session.deadline(),
            (false, _) => None,
        };
        let firmware = self.firmware.deadline();
        let datagram = self.in_flight.front().map(|d| d.0);
        [gateway, firmware, datagram, Some(self.next_period)].into_iter().flatten().min().unwrap_or(u64::MAX)
    }

    /// Everything due at `now`; the gateway's reports go into `out`.
    pub fn advance(&mut self, now: u64, terrain: &Terrain, out: &mut Vec<FromAgent>) {
        self.at = self.at.max(now);
        while self.in_flight.front().is_some_and(|d| d.0 <= now) {
            let Some((_, to_robot, bytes)) = self.in_flight.pop_front() else { break };
            self.datagram(now, to_robot, &bytes);
        }
        if self.alive && !self.started && self.register_at.is_some_and(|t| t <= now) {
            self.started = true;
            let _ = self.session.handle(now, Input::Start);
            // zenoh tells a new session who is alive: the orchestrator.
            let _ = self.session.handle(now, Input::Orchestrator { alive: true });
        }
        if self.alive && self.started && self.advance_session(now) {
            self.end(now);
        }
        if now >= self.next_period {
            self.period(now, terrain);
        }
        self.firmware.advance(now);
        self.flush(now, out);
    }

    fn datagram(&mut self, now: u64, to_robot: bool, bytes: &[u8]) {
        if to_robot {
            let event = self.firmware.handle(now, FirmwareInput::Datagram(bytes));
            if matches!(event, Ok(Some(RobotEvent::Goal(_)))) && !self.posed {
                self.violations
                    .push(format!("robot {}: a goal at {now} µs, its gateway had no pose", self.id));
            }
        } else if self.alive && self.started {
            let _ = self.session.handle(now, Input::Link(Datagram { bytes, from: addr(self.id) }));
        }
    }

    /// One control period: a quiet room, the drive law, the tracks.
    fn period(&mut self, now: u64, terrain: &Terrain) {
        self.next_period = now + CONTROL_US;
        let quiet: Frame = [2048; FRAME_LEN];
        let _ = self.firmware.handle(now, FirmwareInput::Mics(&[quiet; 6]));
        let m = self.firmware.motors();
        let dt = CONTROL_US as f64 / 1e6;
        let (v, w) =
            ((m.left + m.right) / 2.0 / 255.0 * TOP_SPEED, (m.right - m.left) / 255.0 * TOP_SPEED / TRACK);
        let heading = self.body.heading + w * dt;
        let next =
            Vec2::new(self.body.at.x + v * dt * heading.cos(), self.body.at.y + v * dt * heading.sin());
        let free = !terrain.is_blocked_at(next);
        self.body = Body { at: if free { next } else { self.body.at }, heading };
        let told = self.firmware.last_telemetry().map(|t| t.state);
        self.watch(now, told);
    }

    /// The safety promises, at a control period whose telemetry says `told`.
    fn watch(&mut self, now: u64, told: Option<RobotState>) {
        let driving = told == Some(RobotState::Driving);
        self.drove |= driving;
        let id = self.id;
        let cut = |from: u64| self.cuts.iter().any(|&(a, b)| a < now && b > from);
        if let Some(t) = self.stop_since.filter(|&t| now >= t + STOP_BOUND_US && driving && !cut(t)) {
            self.violations
                .push(format!("robot {id}: told Stop at {t} µs, its telemetry says Driving at {now} µs"));
        }
        if let Some(t) = self.gone_at.filter(|&t| now >= t + ORPHAN_BOUND_US && driving) {
            self.violations
                .push(format!("robot {id}: its gateway gone at {t} µs, still driving at {now} µs"));
        }
        let past = self.lost_since.map(|t| t.saturating_add(self.grace_us) + STOP_BOUND_US);
        if past.is_some_and(|p| now >= p) && self.alive && self.stop_since.is_none() {
            self.violations.push(format!(
                "robot {id}: orchestrator lost since {:?} µs, the failsafe did not stop the robot by {now} µs",
                self.lost_since
            ));
            self.lost_since = None;
        }
    }

    /// Sends what the firmware and the gateway queued.
    fn flush(&mut self, now: u64, out: &mut Vec<FromAgent>) {
        let cut = self.cut(now);
        self.firmware.advance(now);
        while let Some(frame) = self.firmware.poll() {
            if !cut {
                self.in_flight.push_back((now + LINK_DELAY_US, false, frame.to_vec()));
            }
        }
        while let Some(o) = self.session.poll() {
            match o {
                Output::Datagram(bytes, _) if !self.cut(now) => {
                    self.in_flight.push_back((now + LINK_DELAY_US, true, bytes));
                }
                Output::Datagram(..) => {}
                Output::Report(r) => out.push(r),
            }
        }
        if self.stop_since.is_none() && self.session.core().stopped() {
            self.stop_since = Some(now);
        }
    }

    /// A command from the orchestrator.
    pub fn command(&mut self, now: u64, cmd: &ToAgent, out: &mut Vec<FromAgent>) {
        self.at = self.at.max(now);
        if !(self.alive && self.started) {
            return;
        }
        if self.session.handle(now, Input::Command(cmd)).is_ok() && self.session.exit().is_some() {
            self.flush(now, out);
            self.end(now);
        }
        self.flush(now, out);
    }

    /// Its own pose from motion capture, forwarded by the launch.
    pub fn pose(&mut self, pose: &Pose) {
        if self.alive && self.started {
            self.posed |= pose.robot.0 == self.id && pose.heading.is_finite();
            let _ = self.session.handle(self.at, Input::Pose(pose));
        }
    }

    /// The orchestrator's liveliness token came or went at `now`.
    pub fn orchestrator(&mut self, now: u64, alive: bool, out: &mut Vec<FromAgent>) {
        self.at = self.at.max(now);
        if !(self.alive && self.started) {
            return;
        }
        self.lost_since = if alive { None } else { self.lost_since.or(Some(now)) };
        let _ = self.session.handle(now, Input::Orchestrator { alive });
        if self.advance_session(now) {
            self.end(now);
        }
        self.flush(now, out);
    }

    /// Runs the session's timers at `now`: whether the session ended.
    fn advance_session(&mut self, now: u64) -> bool {
        self.session.advance(now);
        self.session.exit().is_some()
    }

    /// The gateway process ends (crashed, killed, or its session over).
    pub fn end(&mut self, now: u64) {
        if self.alive {
            self.alive = false;
            self.gone_at = Some(now);
        }
    }
}
