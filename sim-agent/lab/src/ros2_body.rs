//! A ROS 2 ground robot's body (a TurtleBot, an e-puck2): a differential
//! drive that takes `cmd_vel` commands (v, ω), as its driver does.
//!
//! Why its own body: the crawler ([`super::body`]) takes two track
//! voltages from an emulated ESP32; a ROS 2 robot takes velocity commands
//! from its agent over rmw_zenoh, and what the agent must cope with is what
//! its driver does with them. So, sans-IO and on the lab clock:
//!
//! * a command acts [`DiffDriveConfig::latency`] after it arrived (the
//!   network, the driver's loop);
//! * ω is clamped to the robot's angular limit, (v, ω) becomes wheel speeds
//!   v ∓ ω·b/2 (b the wheel base), each clamped to the linear limit, and back
//!   (the wheels' top speed bounds a turn made while driving);
//! * each step, each wheel slips by a small seeded multiplicative noise
//!   (`slip`: uniform in ±slip, from its own seeded generator);
//! * no command for `cmd_vel_timeout` (counted from when the driver got the
//!   last one) stops it, as real drivers do when their agent dies;
//! * it collides as the crawler does ([`Disc::moved`]): touching a frame,
//!   the arena's wall or another body sticks it, for good.

use super::body::{Disc, Obstacle};
use bycoms_agent::wheeled::{Limits, Velocity};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::collections::VecDeque;
use std::time::Duration;

/// The default command latency: a command acts this long after it arrived.
pub const LATENCY: Duration = Duration::from_millis(20);
/// The default wheel slip: each wheel's speed is off by up to ±2 %.
pub const SLIP: f64 = 0.02;
/// Commands waiting out their latency, at most (a flood drops the oldest).
const MAX_PENDING: usize = 1024;

/// What a ROS 2 robot's body is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffDriveConfig {
    /// Its limits and wheel base (the robots file's).
    pub limits: Limits,
    /// Its footprint radius, m (the scenario's body radius: the start and
    /// the frames are laid out for it).
    pub radius: f64,
    /// How long after arriving a command acts.
    pub latency: Duration,
    /// Its driver stops it after this long without a command.
    pub cmd_vel_timeout: Duration,
    /// Multiplicative wheel-speed noise, ± this fraction (0: none).
    pub slip: f64,
}

impl DiffDriveConfig {
    /// A body of `limits` and `radius` whose driver times out after
    /// `cmd_vel_timeout`, with the default [`LATENCY`] and [`SLIP`].
    pub fn new(limits: Limits, radius: f64, cmd_vel_timeout: Duration) -> Self {
        Self { limits, radius, latency: LATENCY, cmd_vel_timeout, slip: SLIP }
    }
}

/// The wheel speeds (left, right), m/s, a driver of `limits` makes of
/// `command`: ω clamped to the angular limit, then each wheel to the linear one.
pub fn wheel_speeds(command: Velocity, limits: &Limits) -> (f64, f64) {
    let w = command.angular.clamp(-limits.angular, limits.angular);
    let half = w * limits.wheel_base / 2.0;
    let wheel = |s: f64| s.clamp(-limits.linear, limits.linear);
    (wheel(command.linear - half), wheel(command.linear + half))
}

/// The body's velocity of wheel speeds (left, right) on `wheel_base`.
pub fn body_velocity((left, right): (f64, f64), wheel_base: f64) -> Velocity {
    Velocity { linear: (left + right) / 2.0, angular: (right - left) / wheel_base }
}

/// One ROS 2 robot's body.
#[derive(Clone, Debug)]
pub struct DiffDrive {
    /// Position, m.
    pub x: f64,
    /// Position, m.
    pub y: f64,
    /// Heading, rad (counter-clockwise from +x).
    pub heading: f64,
    /// Touched something: it never moves again.
    pub stuck: bool,
    config: DiffDriveConfig,
    /// Commands not acting yet: (when they act, the command).
    pending: VecDeque<(Duration, Velocity)>,
    /// The command the driver follows.
    acting: Velocity,
    /// When the driver got its last command.
    heard: Option<Duration>,
    rng: Xoshiro256PlusPlus,
}

impl DiffDrive {
    /// A body at rest at (x, y, heading); `seed` seeds its slip.
    pub fn new(config: DiffDriveConfig, x: f64, y: f64, heading: f64, seed: u64) -> Self {
        let rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let (pending, acting) = (VecDeque::new(), Velocity::ZERO);
        Self { x, y, heading, stuck: false, config, pending, acting, heard: None, rng }
    }

    /// Its configuration.
    pub fn config(&self) -> &DiffDriveConfig {
        &self.config
    }

    /// A command that arrived at lab time `at` (not before the previous
    /// one's); it acts `latency` later. One that is not finite stops the
    /// robot (no driver drives at NaN m/s).
    pub fn command(&mut self, at: Duration, command: Velocity) {
        let finite = command.linear.is_finite() && command.angular.is_finite();
        let command = if finite { command } else { Velocity::ZERO };
        if self.pending.len() == MAX_PENDING {
            self.pending.pop_front();
        }
        self.pending.push_back((at + self.config.latency, command));
    }

    /// The command its driver follows now (zero once timed out or stuck).
    pub fn acting(&self) -> Velocity {
        self.acting
    }

    /// Its footprint where it stands.
    pub fn disc(&self) -> Disc {
        Disc { x: self.x, y: self.y, heading: self.heading, radius: self.config.radius }
    }

    /// Advances from lab time `now` by `dt`; `others` are the other
    /// bodies' centres. Sticks on contact.
    pub fn step(&mut self, now: Duration, dt: Duration, obstacles: &[Obstacle], others: &[(f64, f64)]) {
        while let Some(&(acts, command)) = self.pending.front().filter(|(acts, _)| *acts <= now) {
            self.acting = command;
            self.heard = Some(acts);
            self.pending.pop_front();
        }
        if self.heard.is_some_and(|h| now >= h + self.config.cmd_vel_timeout) {
            self.acting = Velocity::ZERO;
        }
        if self.stuck {
            self.acting = Velocity::ZERO;
            return;
        }
        let (left, right) = wheel_speeds(self.acting, &self.config.limits);
        let slip = self.config.slip;
        let (left, right) = (
            left * (1.0 + slip * self.rng.gen_range(-1.0..=1.0)),
            right * (1.0 + slip * self.rng.gen_range(-1.0..=1.0)),
        );
        let v = body_velocity((left, right), self.config.limits.wheel_base);
        let dt = dt.as_secs_f64();
        let Some((x, y)) = self.disc().moved(v.linear, dt, obstacles, others) else {
            self.stuck = true;
            self.acting = Velocity::ZERO;
            return;
        };
        self.x = x;
        self.y = y;
        self.heading = bycoms_agent::angle::wrap(self.heading + v.angular * dt);
    }
}

#[cfg(test)]
mod tests;
