//! The sequential runner: the paper's simulation of one run (§IV–V).
//!
//! Robots are deployed one at a time at the start, facing the goal; each is
//! deployed in the period after the previous one stopped. A robot stops when
//! it enters an impassable cell or leaves the arena (it stays there, a beacon
//! whose field steers the next ones) or when it comes within the success
//! radius of the goal (the run is won). The run also ends at the time limit
//! (10 000 s simulated) or when `max_robots` are spent.
//!
//! Same terrain, configuration and seed → the same result, bit for bit.
//!
//! No shortcuts: every period of every robot is simulated, up to the time
//! limit. Each period is a [`Deployment::step`], which does what
//! `SimRobot::step` does (same bits) while skipping work whose result is
//! unchanged or unused (see there); the terrain and arrival checks follow
//! a move only, since a turn in place leaves the robot where the last
//! period's checks passed. Without noise, the turns in place that surely
//! repeat the last period's turn are done at once
//! ([`Deployment::skip_known_turns`]: the heading advances and the periods
//! are counted as if stepped one by one). (An exact loop detector — Brent's algorithm on the robot's state
//! bits — was tried and removed: orbiting robots drift by rounding and never
//! repeat a state exactly, so it never fired; the full study meets its time
//! budget without it.)

use crate::body::{HeadingTable, Kinematics};
use crate::field::Beacons;
use crate::robot::{Deployment, MotionCones, SimRobot};
use crate::sensing::{robot_seed, NoiseModel, SensingNoise};
use crate::terrain::Terrain;
use crate::Vec2;
use bycoms_agent::{ControllerConfig, Motion};
use serde::{Deserialize, Serialize};

/// The success radius of the paper's runs, world units: a robot's radius.
/// The one default of it: the runner's ([`RunConfig::paper`]), the launch's
/// `goal_radius` and `world`'s `--success-radius`.
pub const DEFAULT_SUCCESS_RADIUS: f64 = 0.5;

/// Whether a robot at `p` has arrived at `goal` for a success radius
/// `radius`: within it, its edge included. The one test of arrival: the
/// runner's, the launch gate's (`bycoms_study::gate`, judging the agents'
/// poses) and the tests' that stand in for them call it, so a run judged
/// by the launch decides as the runner's.
#[inline]
pub fn arrived(p: Vec2, goal: Vec2, radius: f64) -> bool {
    let (dx, dy) = (p.x - goal.x, p.y - goal.y);
    dx * dx + dy * dy <= radius * radius
}

/// Everything that parameterises a run besides the terrain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunConfig {
    /// Circumferential radius ε (g_th = c / ε²).
    pub eps: f64,
    /// Sensing noise, `None` for the noiseless study.
    pub noise: Option<NoiseModel>,
    /// Seed of the robots' noise streams.
    pub seed: u64,
    /// Stop after this many robots (`None`: as many as the time limit allows).
    pub max_robots: Option<u32>,
    /// Simulated time limit of the whole run, s.
    pub time_limit: f64,
    /// A robot within this distance of the goal has arrived ([`arrived`];
    /// default [`DEFAULT_SUCCESS_RADIUS`]).
    pub success_radius: f64,
    pub kinematics: Kinematics,
    /// Field constant c of g = c / d².
    pub field_constant: f64,
    /// Keep every robot's trajectory (for pictures).
    pub record_trajectories: bool,
    /// The world's units per terrain cell: 1 in the paper's world (a unit
    /// is a cell); a lab's arena in metres has cells of a few centimetres
    /// (its frames as blocked cells), and then positions, speeds, ε and the
    /// field are in metres while only the terrain test is in cells
    /// ([`RunConfig::in_cells`]). Dividing by 1 is exact, so the paper's
    /// runs keep their bits.
    pub cell: f64,
}

impl RunConfig {
    /// The paper's settings with circumferential radius `eps`.
    pub fn paper(eps: f64) -> Self {
        Self {
            eps,
            noise: None,
            seed: 0,
            max_robots: None,
            time_limit: 10_000.0,
            success_radius: DEFAULT_SUCCESS_RADIUS,
            kinematics: Kinematics::paper(),
            field_constant: 1.0,
            record_trajectories: false,
            cell: 1.0,
        }
    }

    /// Position `p` of the world in the terrain's cells (what
    /// [`Terrain::is_blocked_at`] takes): `p` when a cell is a unit.
    #[inline]
    pub fn in_cells(&self, p: Vec2) -> Vec2 {
        Vec2::new(p.x / self.cell, p.y / self.cell)
    }

    /// Whether a robot at world position `p` is in an impassable cell of
    /// `terrain` or outside it (stuck there).
    #[inline]
    pub fn blocked(&self, terrain: &Terrain, p: Vec2) -> bool {
        terrain.is_blocked_at(self.in_cells(p))
    }

    /// Point `p` of the terrain's cells (its start, its goal) in the world.
    pub fn in_world(&self, p: Vec2) -> Vec2 {
        Vec2::new(p.x * self.cell, p.y * self.cell)
    }

    /// The controller parameters this run gives each robot.
    pub fn controller(&self) -> ControllerConfig {
        ControllerConfig {
            g_th: self.field_constant / (self.eps * self.eps),
            speed: self.kinematics.speed,
            turn_rate: self.kinematics.turn_rate,
            ..ControllerConfig::paper(self.eps)
        }
    }

    /// Checks the parameters [`run`] relies on.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !positive(self.eps) || !positive(self.field_constant / (self.eps * self.eps)) {
            return Err(ConfigError::Eps(self.eps));
        }
        if !(positive(self.time_limit) && self.time_limit <= bycoms_runtime::seconds::MAX_SECONDS) {
            return Err(ConfigError::TimeLimit(self.time_limit));
        }
        if !positive(self.success_radius) {
            return Err(ConfigError::SuccessRadius(self.success_radius));
        }
        if !positive(self.field_constant) {
            return Err(ConfigError::FieldConstant(self.field_constant));
        }
        if self.max_robots == Some(0) {
            return Err(ConfigError::NoRobots);
        }
        if self.kinematics.headings_per_turn().is_none() || !positive(self.kinematics.speed) {
            return Err(ConfigError::Kinematics);
        }
        if self.step_limit() == 0 {
            return Err(ConfigError::TimeLimit(self.time_limit));
        }
        if !positive(self.cell) {
            return Err(ConfigError::Cell(self.cell));
        }
        Ok(())
    }

    /// Number of control periods in the time limit.
    pub fn step_limit(&self) -> u64 {
        libm::round(self.time_limit / self.kinematics.dt) as u64
    }
}

/// A run configuration [`run`] cannot honour.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    #[error("the circumferential radius ε must be a positive number of cells (with c/ε² > 0), got {0:?}")]
    Eps(f64),
    #[error(
        "the time limit must be at least one control period and at most {max} s, got {0:?} s",
        max = bycoms_runtime::seconds::MAX_SECONDS
    )]
    TimeLimit(f64),
    #[error("the success radius must be positive, got {0}")]
    SuccessRadius(f64),
    #[error("the field constant c must be positive, got {0}")]
    FieldConstant(f64),
    #[error("at least one robot is needed")]
    NoRobots,
    #[error("the cell size must be a positive number of the world's units, got {0:?}")]
    Cell(f64),
    #[error(
        "kinematics need a positive speed and a turn step (turn rate × dt) that divides the full circle"
    )]
    Kinematics,
}

/// Why a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunOutcome {
    /// A robot reached the goal.
    Arrived,
    /// Simulated time ran out.
    TimeLimit,
    /// `max_robots` robots were deployed and all got stuck.
    RobotsExhausted,
}

/// How one robot's deployment ended.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RobotRunEnd {
    Stuck,
    Arrived,
    /// Still moving when the run ended (time limit).
    Moving,
}

/// One robot's deployment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotRun {
    /// 1-based deployment order.
    pub id: u32,
    pub end: RobotRunEnd,
    /// Where it stopped (or was when the run ended).
    pub position: Vec2,
    /// Control periods it was deployed for.
    pub steps: u64,
    /// Positions after every period, starting with the start point (only when recorded).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub trajectory: Vec<Vec2>,
}

/// The result of one run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    pub success: bool,
    pub outcome: RunOutcome,
    /// Control periods simulated in all.
    pub steps: u64,
    /// Simulated time, s.
    pub time: f64,
    /// Robots deployed.
    pub robots_used: u32,
    /// Positions of the stuck robots, in deployment order.
    pub beacons: Vec<Vec2>,
    pub robots: Vec<RobotRun>,
}

/// What one robot's walk is checked against: the terrain, the goal and
/// the step limit.
struct Course<'a> {
    terrain: &'a Terrain,
    cfg: &'a RunConfig,
    goal: Vec2,
    limit: u64,
}

impl Course<'_> {
    /// Steps `deployment` until its robot sticks, arrives or the run's
    /// steps reach the limit: how it ended, and the run's outcome if the
    /// run ends with it.
    #[inline]
    fn walk(
        &self,
        deployment: &mut Deployment<'_>,
        steps: &mut u64,
        trajectory: &mut Vec<Vec2>,
    ) -> (RobotRunEnd, Option<RunOutcome>) {
        let (cfg, limit, first_step) = (self.cfg, self.limit, *steps);
        loop {
            if *steps >= limit {
                return (RobotRunEnd::Moving, Some(RunOutcome::TimeLimit));
            }
            let motion = deployment.step();
            *steps += 1;
            let p = deployment.robot.body.pos;
            if cfg.record_trajectories {
                trajectory.push(p);
            }
            if motion != Motion::Straight && *steps - first_step > 1 {
                // Turned in place where the last period's checks passed; so
                // do the turns known to follow, the same one each period.
                let turns = deployment.skip_known_turns(limit - *steps);
                *steps += u64::from(turns);
                if cfg.record_trajectories {
                    trajectory.extend(std::iter::repeat_n(p, turns as usize));
                }
                continue;
            }
            if cfg.blocked(self.terrain, p) {
                return (RobotRunEnd::Stuck, None);
            }
            if arrived(p, self.goal, cfg.success_radius) {
                return (RobotRunEnd::Arrived, Some(RunOutcome::Arrived));
            }
        }
    }
}

/// Runs the sequential deployment on `terrain`.
///
/// Panics if `cfg` fails [`RunConfig::validate`]; callers taking the
/// configuration from users validate it first.
pub fn run(terrain: &Terrain, cfg: &RunConfig) -> RunResult {
    let goal = cfg.in_world(terrain.goal());
    let start = cfg.in_world(terrain.start());
    let theta0 = start.bearing_to(goal);
    let table = HeadingTable::new(&cfg.kinematics, theta0)
        .expect("RunConfig::validate: the turn step must divide the full circle");
    let controller = cfg.controller();
    let cones = MotionCones::new(&table, controller.straight_tolerance);
    let limit = cfg.step_limit();

    let mut beacons = Beacons::new(cfg.field_constant);
    let mut robots = Vec::new();
    let mut steps: u64 = 0;
    let mut outcome = None;

    while outcome.is_none() {
        let id = robots.len() as u32 + 1;
        if cfg.max_robots.is_some_and(|m| id > m) {
            outcome = Some(RunOutcome::RobotsExhausted);
            break;
        }
        if steps >= limit {
            outcome = Some(RunOutcome::TimeLimit);
            break;
        }
        let noise = cfg.noise.map(|m| SensingNoise::new(m, robot_seed(cfg.seed, id)));
        let robot = SimRobot::new(start, controller, noise, cfg.kinematics.dt);
        let mut trajectory = Vec::new();
        if cfg.record_trajectories {
            trajectory.push(start);
        }
        let first_step = steps;
        let mut deployment = Deployment::new(robot, &table, &cones, &beacons, goal);
        let course = Course { terrain, cfg, goal, limit };
        let (end, ended) = course.walk(&mut deployment, &mut steps, &mut trajectory);
        outcome = ended;
        let robot = deployment.robot;
        if end == RobotRunEnd::Stuck {
            beacons.push(robot.body.pos);
        }
        robots.push(RobotRun { id, end, position: robot.body.pos, steps: steps - first_step, trajectory });
    }
    let outcome = outcome.unwrap_or(RunOutcome::TimeLimit);
    RunResult {
        success: outcome == RunOutcome::Arrived,
        outcome,
        steps,
        time: cfg.kinematics.time_of(steps),
        robots_used: robots.len() as u32,
        beacons: beacons.positions().collect(),
        robots,
    }
}
