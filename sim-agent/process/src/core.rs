//! One simulated robot as a state machine, without any IO: [`RobotCore`].
//!
//! Why sans-IO: the bus loop (`run`) only moves messages; everything that
//! decides *what* the robot does lives here (and the agent's message rules
//! around it in [`super::rules`]), where a test can drive it
//! message by message against the in-process runner. The step itself is
//! [`SimRobot::step`] — the very code `runner::run` calls — so a lockstep run
//! over processes reproduces the runner bit for bit as long as this module
//! hands it the same inputs:
//!
//! * the body starts at the deploy pose with the heading table built on the
//!   deploy heading (the runner uses start → goal bearing for both);
//! * the noise stream is `robot_seed(run seed, robot id)`, fresh at deploy;
//! * the beacons are the positions the orchestrator sent
//!   ([`bycoms_protocol::msg::Beacon`]: each earlier robot's last pose, bit
//!   for bit), summed **in robot-id order** (the runner's deployment order);
//! * the goal bearing is the one the orchestrator computed from this robot's
//!   latest pose with `Vec2::bearing_to` (the runner's own function).
//!
//! Physics of stopping: when the body enters an impassable cell (or leaves
//! the arena) it freezes there. The controller never sees the terrain; only
//! this shell does, exactly as in the runner.

use bycoms_agent::Mode;
use bycoms_protocol::msg::{Beacon, Deploy, FromAgent, GoalBearing, Parked, Pose, TickDone};
use bycoms_protocol::RobotId;
use bycoms_sim::body::HeadingTable;
use bycoms_sim::field::Beacons;
use bycoms_sim::robot::SimRobot;
use bycoms_sim::sensing::{robot_seed, SensingNoise};
use bycoms_sim::terrain::Terrain;
use bycoms_sim::{RunConfig, Vec2};
use std::collections::BTreeMap;

/// Where the robot is in its life.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RobotPhase {
    /// Running, registered, not deployed: not in the arena yet.
    Idle,
    /// Deployed and moving under its controller.
    Moving,
    /// Entered an impassable cell (or left the arena): physically stuck.
    Frozen,
    /// Told to stop (it arrived, or the run ended): stays where it is.
    Stopped,
}

/// Why a message was refused (counted and logged by the shell, never fatal).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reject {
    /// The message names another robot than this agent's.
    WrongRobot {
        /// The robot named in the message.
        got: RobotId,
    },
    /// A second `Deploy`.
    AlreadyDeployed,
    /// A value is NaN or infinite.
    NotFinite,
    /// The heading table cannot be built (turn step does not divide 2π).
    BadKinematics,
    /// A beacon's number is not the next one: one was lost (the field
    /// misses a robot until it is sent again) or repeated.
    BeaconOutOfOrder {
        /// The number expected.
        expected: u32,
        /// The number received.
        got: u32,
    },
    /// A `Tick` to an agent on the real-time clock (it steps on its own).
    TickInRealTime,
}

impl core::fmt::Display for Reject {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::WrongRobot { got } => write!(f, "message for {got}"),
            Self::AlreadyDeployed => write!(f, "second Deploy ignored"),
            Self::NotFinite => write!(f, "non-finite value"),
            Self::BadKinematics => write!(f, "the turn step does not divide the full circle"),
            Self::BeaconOutOfOrder { expected, got } => write!(f, "beacon {got} where {expected} was next"),
            Self::TickInRealTime => write!(f, "Tick on a real-time agent"),
        }
    }
}

struct Deployed {
    robot: SimRobot,
    table: HeadingTable,
}

/// One simulated robot: body, controller, noise, the field of its peers.
pub struct RobotCore {
    id: RobotId,
    terrain: Terrain,
    cfg: RunConfig,
    phase: RobotPhase,
    body: Option<Deployed>,
    bearing: Option<GoalBearing>,
    peers: BTreeMap<u32, Vec2>,
    /// Beacon messages taken so far (the next one's `seq` is this + 1).
    beacon_seq: u32,
    beacons: Beacons,
    beacons_stale: bool,
    steps: u64,
}

impl RobotCore {
    /// An idle robot `id` in `terrain`, with the run's parameters (ε, noise,
    /// seed, kinematics, field constant) taken from `cfg` as the runner does.
    pub fn new(id: RobotId, terrain: Terrain, cfg: RunConfig) -> Self {
        let beacons = Beacons::new(cfg.field_constant);
        Self {
            id,
            terrain,
            cfg,
            phase: RobotPhase::Idle,
            body: None,
            bearing: None,
            peers: BTreeMap::new(),
            beacon_seq: 0,
            beacons,
            beacons_stale: false,
            steps: 0,
        }
    }

    /// This agent's robot.
    pub fn id(&self) -> RobotId {
        self.id
    }

    /// Where the robot is in its life.
    pub fn phase(&self) -> RobotPhase {
        self.phase
    }

    /// Whether the robot will never move again: it froze in an impassable
    /// cell or was told to stop (a [`bycoms_protocol::msg::Parked`] robot).
    pub fn parked(&self) -> bool {
        matches!(self.phase, RobotPhase::Frozen | RobotPhase::Stopped)
    }

    /// The reports that answer lockstep tick `step` (after its pose):
    /// `Parked` while the robot will never move again, so the orchestrator
    /// stops ticking it, then `TickDone` ([`super::rules::SimAgentCore`]
    /// answers a tick with these).
    pub fn tick_answer(&self, step: u64) -> impl Iterator<Item = FromAgent> {
        let robot = self.id;
        let parked = self.parked().then_some(FromAgent::Parked(Parked { robot, step }));
        parked.into_iter().chain([FromAgent::TickDone(TickDone { robot, step })])
    }

    /// Control periods stepped since deployment.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The controller's mode (1 before deployment).
    pub fn mode(&self) -> Mode {
        self.body.as_ref().map_or(Mode::Goal, |d| d.robot.mode())
    }

    /// The latest goal bearing received.
    pub fn bearing(&self) -> Option<GoalBearing> {
        self.bearing
    }

    /// Places the robot at the deploy pose and starts it.
    pub fn deploy(&mut self, d: &Deploy) -> Result<(), Reject> {
        self.check_robot(d.robot)?;
        if self.body.is_some() {
            return Err(Reject::AlreadyDeployed);
        }
        if !(d.x.is_finite() && d.y.is_finite() && d.heading.is_finite()) {
            return Err(Reject::NotFinite);
        }
        let table = HeadingTable::new(&self.cfg.kinematics, d.heading).ok_or(Reject::BadKinematics)?;
        let noise = self.cfg.noise.map(|m| SensingNoise::new(m, robot_seed(self.cfg.seed, self.id.0)));
        let robot = SimRobot::new(Vec2::new(d.x, d.y), self.cfg.controller(), noise, self.cfg.kinematics.dt);
        self.body = Some(Deployed { robot, table });
        self.phase = RobotPhase::Moving;
        Ok(())
    }

    /// Takes a new goal bearing.
    pub fn set_bearing(&mut self, b: &GoalBearing) -> Result<(), Reject> {
        self.check_robot(b.robot)?;
        if !b.bearing.is_finite() {
            return Err(Reject::NotFinite);
        }
        self.bearing = Some(*b);
        Ok(())
    }

    /// Stops the robot where it is (it stays in the arena as a beacon).
    pub fn stop(&mut self) {
        if self.phase == RobotPhase::Moving {
            self.phase = RobotPhase::Stopped;
        }
    }

    /// Takes a beacon: robot `b.robot` stands at (`b.x`, `b.y`) (a new one,
    /// or a new position of one it has). A beacon out of sequence is taken
    /// all the same (the latest position is the right one) and reported,
    /// so the shell can say that the field may miss a robot.
    pub fn beacon(&mut self, b: &Beacon) -> Result<(), Reject> {
        if b.robot == self.id {
            return Err(Reject::WrongRobot { got: b.robot });
        }
        if !(b.x.is_finite() && b.y.is_finite()) {
            return Err(Reject::NotFinite);
        }
        let expected = self.beacon_seq.saturating_add(1);
        self.beacon_seq = self.beacon_seq.max(b.seq);
        let p = Vec2::new(b.x, b.y);
        let before = self.peers.insert(b.robot.0, p);
        if before != Some(p) {
            self.beacons_stale = true;
        }
        // A repeat (sent again with its tick, which had been lost) is taken
        // quietly.
        let repeat = b.seq < expected && before == Some(p);
        if b.seq == expected || repeat {
            Ok(())
        } else {
            Err(Reject::BeaconOutOfOrder { expected, got: b.seq })
        }
    }

    /// The beacons it holds, robot by robot.
    pub fn beacons(&self) -> impl Iterator<Item = (u32, Vec2)> + '_ {
        self.peers.iter().map(|(id, p)| (*id, *p))
    }

    /// One control period, if the robot is moving and has a goal bearing:
    /// sense, decide, move, and freeze on entering an impassable cell.
    /// Returns whether it stepped.
    pub fn step(&mut self) -> bool {
        if self.phase != RobotPhase::Moving {
            return false;
        }
        let Some(bearing) = self.bearing else {
            return false;
        };
        if self.beacons_stale {
            // Rebuilt in robot-id order (BTreeMap), the runner's deployment
            // order, so the float sum is the same bits.
            self.beacons = Beacons::new(self.cfg.field_constant);
            for p in self.peers.values() {
                self.beacons.push(*p);
            }
            self.beacons_stale = false;
        }
        let Some(d) = self.body.as_mut() else {
            return false;
        };
        d.robot.step(&d.table, &self.beacons, bearing.bearing);
        self.steps += 1;
        if self.cfg.blocked(&self.terrain, d.robot.body.pos) {
            self.phase = RobotPhase::Frozen;
        }
        true
    }

    /// The robot's pose as motion capture sees it (`None` before deployment).
    pub fn pose(&self, step: u64, time_us: u64) -> Option<Pose> {
        let d = self.body.as_ref()?;
        let p = d.robot.body.pos;
        Some(Pose { robot: self.id, x: p.x, y: p.y, heading: d.robot.body.heading(&d.table), step, time_us })
    }

    fn check_robot(&self, got: RobotId) -> Result<(), Reject> {
        if got == self.id {
            Ok(())
        } else {
            Err(Reject::WrongRobot { got })
        }
    }
}

#[cfg(test)]
mod tests;
