//! What a viewer needs to draw the run at any moment, kept as the run goes.
//!
//! Why a kept state and not only the stream: the Foxglove protocol has no
//! history, and a person opens the page whenever they like — mid-run, or
//! after reloading. So the live view folds the run's one stream, the
//! scene's messages (`bycoms_record::scene`: every pose that moved or
//! turned a robot, every gate decision), into this state (robots with
//! their trails, beacons, the robot under the gate's watch, the verdict)
//! and hands it to each viewer that subscribes, then again after every gate
//! decision. It is a projection of that stream, as the Foxglove channels
//! are: the page and Foxglove see the same messages, at the same moment.
//! Its beacons are the scene's `beacon/json` messages, each where the
//! launch core's beacon table has it (the run's one view, `RunView`),
//! creeping with it, and its robots' states the scene's `robot/<k>/state`
//! messages, each as the core said it (so a robot revoked or lost before
//! its deployment is shown lost): neither is derived from the gate's
//! decisions (issue 53).
//! Pure data, no I/O: the unit tests drive it.

use bycoms_launch::core::SlotState;
use bycoms_launch::{LaunchConfig, World};
use bycoms_record::scene::json::{BeaconAt, Decision, GateDecision, RobotPose, RobotSlot};
use bycoms_record::scene::{Message, Out};
use schemars::JsonSchema;
use serde::Serialize;
use std::collections::BTreeMap;

/// A trail keeps a point only after the robot moved this far (cells): a
/// trail stays small however long the run.
pub const TRAIL_STEP: f64 = 0.25;
/// Most points of one robot's trail; later points are not kept.
pub const TRAIL_MAX: usize = 20_000;

/// The world as the page draws it.
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
pub struct WorldView {
    /// Where the terrain came from.
    pub name: String,
    /// Grid width, cells.
    pub width: usize,
    /// Grid height, cells.
    pub height: usize,
    /// The terrain rows, FIRST row = HIGHEST y (`#` blocked; the text format).
    pub rows: Vec<String>,
    /// Start position.
    pub start: [f64; 2],
    /// Goal position.
    pub goal: [f64; 2],
    /// The arrival radius around the goal.
    pub goal_radius: f64,
    /// The circumferential radius ε around every beacon.
    pub eps: f64,
    /// Robots available.
    pub robots: u32,
    /// `lockstep` or `realtime`.
    pub clock: String,
    /// The robots with a real body (a lab's; in a mixed swarm its real
    /// members): the page draws them as squares and says so in its list.
    pub real: Vec<u32>,
}

impl WorldView {
    /// The page's view of a launch's world.
    pub fn new(world: &World, cfg: &LaunchConfig) -> Self {
        let rows: Vec<String> = world.terrain_text.lines().map(str::to_owned).collect();
        Self {
            name: world.name.clone(),
            width: rows.first().map_or(0, |r| r.chars().count()),
            height: rows.len(),
            rows,
            start: [world.start.x, world.start.y],
            goal: [world.goal.x, world.goal.y],
            goal_radius: cfg.goal_radius,
            eps: cfg.eps,
            robots: cfg.robots,
            clock: serde_json::to_value(cfg.clock)
                .ok()
                .and_then(|v| v.as_str().map(str::to_owned))
                .unwrap_or_default(),
            real: bycoms_launch::lab::real_robots(cfg, world),
        }
    }
}

/// Where a robot is in the run, as the launch core said it ([`RobotState::of`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RobotState {
    /// Seen, not yet under the gate's watch.
    Deploying,
    /// Moving under the gate's watch.
    Moving,
    /// Stopped away from the goal: a beacon.
    Stuck,
    /// At the goal.
    Arrived,
    /// Its agent died while it moved: a beacon where last seen.
    Lost,
    /// The time limit ran out while it moved.
    Timeout,
}

impl RobotState {
    /// The page's word for the core's state: any state before it moves is
    /// `deploying` (the page lists a robot once it is seen), a robot lost
    /// before its deployment or while moving is `lost`.
    pub fn of(state: SlotState) -> Self {
        match state {
            SlotState::Waiting
            | SlotState::Spawned
            | SlotState::Registered
            | SlotState::Deploying
            | SlotState::Absent => Self::Deploying,
            SlotState::Moving => Self::Moving,
            SlotState::Stuck => Self::Stuck,
            SlotState::Arrived => Self::Arrived,
            SlotState::Died | SlotState::Lost => Self::Lost,
            SlotState::Unfinished => Self::Timeout,
        }
    }
}

/// One robot.
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
pub struct RobotView {
    /// Its id.
    pub id: u32,
    /// Its state.
    pub state: RobotState,
    /// Last position x.
    pub x: f64,
    /// Last position y.
    pub y: f64,
    /// Last heading, rad.
    pub heading: f64,
    /// Where it went, thinned to [`TRAIL_STEP`].
    pub trail: Vec<[f64; 2]>,
}

/// A stopped robot: a source of the field with its ε circle.
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
pub struct Beacon {
    /// Which robot.
    pub robot: u32,
    /// Where.
    pub x: f64,
    /// Where.
    pub y: f64,
}

/// How the run ended.
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
pub struct Ended {
    /// A robot arrived.
    pub success: bool,
    /// The verdict sentence (as the terminal prints it).
    pub verdict: String,
}

/// The whole scene at one moment.
#[derive(Clone, Debug, Default, PartialEq, Serialize, JsonSchema)]
pub struct LiveState {
    /// Every robot seen, in id order.
    pub robots: Vec<RobotView>,
    /// Beacons in the order they appeared.
    pub beacons: Vec<Beacon>,
    /// The robot under the gate's watch.
    pub moving: Option<u32>,
    /// Gate events so far.
    pub gate_events: u64,
    /// The verdict, once the run ended.
    pub ended: Option<Ended>,
    #[serde(skip)]
    #[schemars(skip)]
    index: BTreeMap<u32, usize>,
    /// Each robot's state as the core said it, seen or not yet.
    #[serde(skip)]
    #[schemars(skip)]
    states: BTreeMap<u32, RobotState>,
}

impl LiveState {
    fn robot(&mut self, id: u32, x: f64, y: f64) -> &mut RobotView {
        let at = match self.index.get(&id) {
            Some(&i) => i,
            None => {
                let state = self.states.get(&id).copied().unwrap_or(RobotState::Deploying);
                let fresh = RobotView { id, state, x, y, heading: 0.0, trail: Vec::new() };
                let at = self.robots.partition_point(|r| r.id < id);
                self.robots.insert(at, fresh);
                self.index = self.robots.iter().enumerate().map(|(i, r)| (r.id, i)).collect();
                at
            }
        };
        &mut self.robots[at]
    }

    /// Takes in what the run's scene produced; whether a gate decision, a
    /// seen robot's new state or a new beacon was among it (viewers get the
    /// state at once then; a beacon that crept on is sent with the next
    /// state).
    pub fn take(&mut self, outs: &[Out]) -> bool {
        let mut decided = false;
        for out in outs {
            match &out.message {
                Message::Pose(pose) => self.pose(pose),
                Message::Gate(decision) => {
                    self.gate(decision);
                    decided = true;
                }
                Message::Beacon(beacon) => decided |= self.beacon(beacon),
                Message::State(slot) => decided |= self.state(slot),
                _ => {}
            }
        }
        decided
    }

    /// Takes in one pose.
    pub fn pose(&mut self, pose: &RobotPose) {
        let robot = self.robot(pose.robot, pose.x, pose.y);
        robot.x = pose.x;
        robot.y = pose.y;
        robot.heading = pose.heading;
        let far = robot.trail.last().is_none_or(|&[x, y]| (pose.x - x).hypot(pose.y - y) >= TRAIL_STEP);
        if far && robot.trail.len() < TRAIL_MAX {
            robot.trail.push([pose.x, pose.y]);
        }
    }

    /// Takes in one gate decision (the robot's state comes as the core
    /// said it: [`LiveState::state`]).
    pub fn gate(&mut self, event: &GateDecision) {
        self.gate_events += 1;
        let robot = self.robot(event.robot, event.x, event.y);
        if event.decision != Decision::Deployed {
            // The gate's position is where it stopped (or was last seen).
            robot.x = event.x;
            robot.y = event.y;
        }
    }

    /// Takes in a robot's new state, as the core said it; whether a robot
    /// the page lists changed. The robot under the gate's watch is the one
    /// moving.
    pub fn state(&mut self, slot: &RobotSlot) -> bool {
        let (id, state) = (slot.robot, RobotState::of(slot.state));
        self.states.insert(id, state);
        self.moving = match state {
            RobotState::Moving => Some(id),
            _ if self.moving == Some(id) => None,
            _ => self.moving,
        };
        let Some(&i) = self.index.get(&id) else { return false };
        let robot = &mut self.robots[i];
        std::mem::replace(&mut robot.state, state) != state
    }

    /// Takes in where a beacon stands (new: after the others; crept on: in
    /// its place); whether it is new.
    pub fn beacon(&mut self, at: &BeaconAt) -> bool {
        match self.beacons.iter_mut().find(|b| b.robot == at.robot) {
            Some(b) => {
                (b.x, b.y) = (at.x, at.y);
                false
            }
            None => {
                self.beacons.push(Beacon { robot: at.robot, x: at.x, y: at.y });
                true
            }
        }
    }

    /// The run ended.
    pub fn ended(&mut self, success: bool, verdict: &str) {
        self.moving = None;
        self.ended = Some(Ended { success, verdict: verdict.to_owned() });
    }
}
