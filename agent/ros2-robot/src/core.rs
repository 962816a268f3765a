//! One ROS 2 robot's agent as a sans-IO state machine: the orchestrator's
//! commands, the beacons, the robot's own pose and `now` in; velocity
//! commands and reports out.
//!
//! Why sans-IO: every safety rule (when to send zero, for how long, when a
//! stop counts as done) is decided here and unit-tested on a hand-driven
//! clock; the loop in `run.rs` only moves bytes. It is a
//! [`RobotSide`], so the gateway's [`Session`](bycoms_agent::gateway::Session)
//! wraps it: registration, heartbeats and the orchestrator-liveliness
//! failsafe are the gateway's very rules, and the session is the
//! [`SansIo`](bycoms_protocol::SansIo) core the loop drives. Time is
//! [`Micros`] since the loop's epoch; the periods in [`Settings`] stay
//! `Duration`s (counted in whole µs, rounded up).
//!
//! Rules:
//! * `Deploy` enables the robot; every control period while enabled it
//!   senses the field virtually (the paper's §IV g = Σ c/d² of the beacons
//!   it was sent, at its own pose from motion capture) and runs the §VI-C
//!   drive law ([`Wheeled`]) towards its last goal bearing: one velocity
//!   command and one `Status` (mode, step) per period, from a pose not used
//!   before — when the period is due and no new pose has come, the command
//!   waits for the next pose and goes out as it arrives (so a command is
//!   never older than the loop's pass after its pose);
//! * no goal yet, or no pose for [`Settings::pose_timeout`]: zero velocity
//!   each period (a robot blind to motion capture does not drive);
//! * `Stop`, `Shutdown`, the failsafe and the agent's own end send zero at
//!   once and again every period for [`Settings::stop_repeat`] (a lost
//!   sample must not leave a robot driving); `Stop` is answered with
//!   `StopDone` queued after that first zero, so it is published after it;
//! * a beacon of the robot itself, or not finite, is refused (bad traffic),
//!   a later one of the same robot moves it (a creeping beacon);
//! * every velocity command, zeros included, is followed by a
//!   [`Commanded`] report of exactly what went out, its step and the field
//!   it came from, so the launch's recording holds every command sent
//!   (issue 50). One per command rather than one per period: a period
//!   without a command (waiting for a pose) has nothing to report, and a
//!   stop's zeros are the commands a recording must not miss.

use bycoms_agent::gateway::{Refused, RobotSide};
use bycoms_agent::wheeled::{FieldReading, Limits, Velocity, Wheeled};
use bycoms_protocol::link::DropReason;
use bycoms_protocol::msg::{Beacon, Commanded, FromAgent, Pose, Sensed, Status, StopDone, ToAgent};
use bycoms_protocol::{Micros, RobotId};
use bycoms_runtime::epoch::micros_ceil;
use bycoms_sim::field::Beacons;
use bycoms_sim::Vec2;
use std::collections::{BTreeMap, VecDeque};
use std::convert::Infallible;
use std::time::Duration;

/// Field constant c of the paper's simulation (g = c/d²).
const FIELD_CONSTANT: f64 = bycoms_agent::point::FIELD_CONSTANT;

/// How one ROS 2 robot is driven.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// The robot.
    pub robot: RobotId,
    /// ε, metres: the contour mode 2 holds around a lone beacon.
    pub eps: f64,
    /// The robot's velocity limits and wheel base.
    pub limits: Limits,
    /// One velocity command per this period.
    pub period: Duration,
    /// No pose from motion capture for this long: zero velocity.
    pub pose_timeout: Duration,
    /// After a stop, zero is sent again every period for this long.
    pub stop_repeat: Duration,
}

impl Settings {
    /// The paper's control period (0.1 s), a pose timeout of 300 ms (the
    /// gateways' link timeout) and a second of zeros after a stop.
    pub fn new(robot: RobotId, eps: f64, limits: Limits) -> Self {
        Self {
            robot,
            eps,
            limits,
            period: Duration::from_millis(100),
            pose_timeout: Duration::from_millis(300),
            stop_repeat: Duration::from_secs(1),
        }
    }
}

/// What the core wants done.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Output {
    /// Publish this velocity command on the robot's `cmd_vel`.
    Velocity(Velocity),
    /// Publish this on the robot's `from_agent`.
    Report(FromAgent),
}

/// [`Settings`]' periods in µs (rounded up).
#[derive(Clone, Copy, Debug)]
struct PeriodsUs {
    period: Micros,
    pose_timeout: Micros,
    stop_repeat: Micros,
}

/// One ROS 2 robot's agent.
pub struct Ros2RobotCore {
    settings: Settings,
    us: PeriodsUs,
    controller: Wheeled,
    /// The beacons by robot, and their field in robot-id order (the
    /// simulation's summation order), rebuilt when one changed.
    peers: BTreeMap<u32, Vec2>,
    field: Beacons,
    enabled: bool,
    goal: Option<f64>,
    pose: Option<Pose>,
    /// When the latest pose was handed in (the first `advance` after it).
    pose_seen: Option<Micros>,
    fresh_pose: bool,
    /// A pose came since the last command.
    unused_pose: bool,
    /// A period is due and waits for a pose not used yet.
    awaiting_pose: bool,
    next_period: Option<Micros>,
    zero_until: Option<Micros>,
    steps: u64,
    out: VecDeque<Output>,
}

impl Ros2RobotCore {
    /// An agent for `settings.robot`, not yet deployed.
    pub fn new(settings: Settings) -> Self {
        Self {
            controller: Wheeled::new(settings.eps, settings.limits),
            us: PeriodsUs {
                period: micros_ceil(settings.period),
                pose_timeout: micros_ceil(settings.pose_timeout),
                stop_repeat: micros_ceil(settings.stop_repeat),
            },
            settings,
            peers: BTreeMap::new(),
            field: Beacons::new(FIELD_CONSTANT),
            enabled: false,
            goal: None,
            pose: None,
            pose_seen: None,
            fresh_pose: false,
            unused_pose: false,
            awaiting_pose: false,
            next_period: None,
            zero_until: None,
            steps: 0,
            out: VecDeque::new(),
        }
    }

    /// Whether the robot is enabled (deployed, not stopped since).
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// The field the robot senses at `p` (the beacons it was sent).
    pub fn field_at(&self, p: Vec2) -> FieldReading {
        let sample = self.field.sample(p);
        let gradient = (!self.field.is_empty()).then(|| sample.direction());
        FieldReading { intensity: sample.intensity, gradient }
    }

    fn beacon(&mut self, b: &Beacon) -> Result<(), Refused> {
        if b.robot == self.settings.robot {
            return Err(Refused::WrongRobot { got: b.robot.0, mine: self.settings.robot.0 });
        }
        if !(b.x.is_finite() && b.y.is_finite()) {
            return Err(Refused::NotFinite);
        }
        let p = Vec2::new(b.x, b.y);
        if self.peers.insert(b.robot.0, p) != Some(p) {
            self.field = Beacons::new(FIELD_CONSTANT);
            for p in self.peers.values() {
                self.field.push(*p);
            }
        }
        Ok(())
    }

    /// Zero now and every period for the stop's repeat time.
    fn stop(&mut self, now: Micros) {
        self.enabled = false;
        self.zero_until = Some(now.saturating_add(self.us.stop_repeat));
        self.next_period = Some(now.saturating_add(self.us.period));
        self.command(Velocity::ZERO, None);
    }

    /// Publish `velocity`, then report it ([`Commanded`]) with the field it
    /// was computed from (`None`: a zero no field decided).
    fn command(&mut self, velocity: Velocity, field: Option<FieldReading>) {
        self.out.push_back(Output::Velocity(velocity));
        let commanded = Commanded {
            robot: self.settings.robot,
            step: self.steps,
            linear: velocity.linear,
            angular: velocity.angular,
            sensed: field.map(|f| Sensed { intensity: f.intensity, gradient: f.gradient }),
        };
        self.out.push_back(Output::Report(FromAgent::Commanded(commanded)));
    }

    /// A control period that is due while enabled: a command from a pose
    /// not used yet, at once; without one, wait for it (until the pose
    /// timeout, when the period's deadline moves there); no goal, or no
    /// pose for the pose timeout: zero, and the next period.
    fn period_due(&mut self, now: Micros) {
        let period = self.us.period;
        let stale = self.pose_seen.is_none_or(|t| now.saturating_sub(t) >= self.us.pose_timeout);
        self.awaiting_pose = false;
        match (self.goal, self.unused_pose) {
            (Some(goal), true) => {
                self.unused_pose = false;
                self.drive(goal);
                self.next_period = Some(now.saturating_add(period));
            }
            (Some(_), false) if !stale => {
                self.awaiting_pose = true;
                self.next_period = self.pose_seen.map(|t| t.saturating_add(self.us.pose_timeout));
            }
            _ => {
                self.command(Velocity::ZERO, None);
                self.next_period = Some(now.saturating_add(period));
            }
        }
    }

    /// One command from the latest pose towards `goal`.
    fn drive(&mut self, goal: f64) {
        let Some(pose) = self.pose else { return };
        let field = self.field_at(Vec2::new(pose.x, pose.y));
        let (out, velocity) = self.controller.step(goal, pose.heading, field);
        self.steps += 1;
        self.command(velocity, Some(field));
        let status = Status { robot: self.settings.robot, mode: out.mode as u8, step: self.steps };
        self.out.push_back(Output::Report(FromAgent::Status(status)));
    }
}

impl RobotSide for Ros2RobotCore {
    type Output = Output;
    /// A ROS 2 robot has no link of its own: its commands go out on
    /// `cmd_vel`, its pose comes from motion capture.
    type Link<'a> = Infallible;

    fn robot(&self) -> RobotId {
        self.settings.robot
    }

    fn report(&mut self, msg: FromAgent) {
        self.out.push_back(Output::Report(msg));
    }

    fn on_command(&mut self, now: Micros, cmd: &ToAgent) -> Result<bool, Refused> {
        let mine = self.settings.robot;
        let wrong = |got: RobotId| Refused::WrongRobot { got: got.0, mine: mine.0 };
        match cmd {
            ToAgent::Deploy(d) if d.robot != mine => return Err(wrong(d.robot)),
            ToAgent::Deploy(_) => {
                self.enabled = true;
                self.zero_until = None;
                self.next_period = Some(now);
            }
            ToAgent::GoalBearing(b) if b.robot != mine => return Err(wrong(b.robot)),
            ToAgent::GoalBearing(b) if !b.bearing.is_finite() => return Err(Refused::NotFinite),
            ToAgent::GoalBearing(b) => self.goal = Some(b.bearing),
            ToAgent::Beacon(b) => self.beacon(b)?,
            ToAgent::Tick(_) | ToAgent::Ticks(_) => return Err(Refused::Tick),
            // Answered every time (the orchestrator re-sends `Stop` until it
            // hears this), after the zero it answers for.
            ToAgent::Stop => {
                self.stop(now);
                self.report(FromAgent::StopDone(StopDone { robot: mine, on_link: true }));
            }
            ToAgent::Shutdown => {
                self.stop(now);
                return Ok(true);
            }
            // The session handles refusals: it knows its instance.
            ToAgent::Refused(_) => {}
        }
        Ok(false)
    }

    fn on_pose(&mut self, pose: &Pose) {
        let finite = pose.x.is_finite() && pose.y.is_finite() && pose.heading.is_finite();
        if pose.robot == self.settings.robot && finite {
            self.pose = Some(*pose);
            self.fresh_pose = true;
        }
    }

    fn on_link(&mut self, _: Micros, input: Infallible) -> Result<(), DropReason> {
        match input {}
    }

    fn advance(&mut self, now: Micros) {
        if std::mem::take(&mut self.fresh_pose) {
            self.pose_seen = Some(now);
            self.unused_pose = true;
        }
        if self.enabled && self.awaiting_pose && self.unused_pose {
            return self.period_due(now);
        }
        let Some(due) = self.next_period.filter(|t| now >= *t) else { return };
        if self.enabled {
            return self.period_due(now);
        }
        // A late loop skips the periods it missed rather than bursting.
        let next = due.saturating_add(self.us.period);
        self.next_period = Some(if next > now { next } else { now.saturating_add(self.us.period) });
        if self.zero_until.is_some_and(|t| now < t) {
            self.command(Velocity::ZERO, None);
        } else {
            self.zero_until = None;
            self.next_period = None;
        }
    }

    fn poll(&mut self) -> Option<Output> {
        self.out.pop_front()
    }

    fn deadline(&self) -> Option<Micros> {
        self.next_period
    }

    fn stop_robot(&mut self, now: Micros) {
        self.stop(now);
    }

    fn awaits_pose(&self) -> bool {
        self.enabled && self.awaiting_pose
    }
}

#[cfg(test)]
mod tests;
