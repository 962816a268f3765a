//! The run as every view shows it: one fold ([`RunView`]) of what the
//! launch core says the run looks like ([`Shown`]: the poses it applied,
//! the changes of its beacon table, the changes of its robots' states, its
//! gate decisions).
//!
//! Why one fold: what shows the run (the recording's Foxglove scene and
//! through it the live view, the `--svg` trace and `orchestrator draw`, the
//! ROS 2 messages and their bag, the summary) each kept its own map of
//! beacons and decided on its own which robot arrived and how many were
//! used (issue 53). The scene's beacons never crept, ROS 2 restated the
//! core's creep rule, and the trace decided success and robots used beside
//! the summary. Now the core says each fact once, as it happens, and each
//! renderer reads this fold of them: where each robot was last applied,
//! its state, where its beacon stands (creeping with it, as the core's
//! table has it), which robot arrived and which robots were deployed.
//!
//! Why here, in the gate's crate: the renderers sit in crates on either side
//! of the launch core (the scene in `bycoms-record`, the trace in
//! `bycoms-study`, which must not rebuild with the core), and this is the
//! crate below all of them. Like the gate, it does no IO.
//!
//! A recording older than the core's beacon channel (`core/beacon`) has
//! no beacon facts: its reader folds it [`RunView::without_beacons`], where
//! a robot the gate judged stuck or lost is a beacon where it was judged,
//! as those recordings were always drawn (without creep). One older than
//! its state channel (`core/state`) has no state facts: its reader folds it
//! [`RunView::without_states`], where each gate decision sets the state it
//! implies ([`SlotState::of_gate`]), as those recordings were always shown
//! (a robot lost before its deployment was never shown lost).

use bycoms_protocol::msg::{GateEvent, GateKind, Pose};
use bycoms_sim::Vec2;
use std::collections::BTreeMap;

/// Where a robot is in the launch (the launch core's slot state).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SlotState {
    /// Its agent has not been started.
    Waiting,
    /// Started, not registered.
    Spawned,
    /// Registered, idle.
    Registered,
    /// Told to deploy, first pose not seen yet.
    Deploying,
    /// Moving under the gate's watch.
    Moving,
    /// Stopped away from the goal: a beacon.
    Stuck,
    /// At the goal.
    Arrived,
    /// Died while moving: a beacon where last seen.
    Died,
    /// Still moving when the run ended.
    Unfinished,
    /// Its agent was lost before it was deployed.
    Lost,
    /// Skipped at its turn: its agent never registered (see `death`).
    Absent,
}

impl SlotState {
    /// The state in words, for the live lines.
    pub fn words(self) -> &'static str {
        match self {
            Self::Waiting => "waiting",
            Self::Spawned => "starting",
            Self::Registered => "ready",
            Self::Deploying => "deploying",
            Self::Moving => "moving",
            Self::Stuck => "stuck",
            Self::Arrived => "arrived",
            Self::Died => "lost while moving",
            Self::Unfinished => "still moving",
            Self::Lost => "lost",
            Self::Absent => "absent",
        }
    }

    /// The state a gate decision puts its robot in (the core sets it just
    /// before it publishes the decision).
    pub fn of_gate(kind: GateKind) -> Self {
        match kind {
            GateKind::Deployed => Self::Moving,
            GateKind::Stopped { arrived: true } => Self::Arrived,
            GateKind::Stopped { arrived: false } => Self::Stuck,
            GateKind::Died => Self::Died,
            GateKind::Timeout => Self::Unfinished,
        }
    }
}

/// Robot `robot`'s beacon stands at `at`: new, or crept on (the launch
/// core's table never removes a beacon). One type for the fact wherever it
/// goes: the core's output, the fold's input, the recording's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeaconAt {
    /// The robot.
    pub robot: u32,
    /// Where its beacon stands.
    pub at: Vec2,
}

/// Robot `robot`'s state changed to `state`, as the launch core changed
/// its slot. One type for the fact wherever it goes, as [`BeaconAt`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StateChange {
    /// The robot.
    pub robot: u32,
    /// Its new state.
    pub state: SlotState,
}

/// One fact of the run a view shows, as the launch core put it out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shown {
    /// A pose the core applied (made its robot's latest).
    Moved(Pose),
    /// A beacon stands somewhere new.
    Beacon(BeaconAt),
    /// A robot's state changed.
    State(StateChange),
    /// A gate decision the core published.
    Gate(GateEvent),
}

/// One robot as the views show it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RobotView {
    /// Its last applied pose.
    pub pose: Option<Pose>,
    /// Its state (none: never said, as in a recording).
    pub state: Option<SlotState>,
    /// Where its beacon stands, if it is one.
    pub beacon: Option<Vec2>,
    /// The gate deployed it.
    pub deployed: bool,
    /// The gate's decision that ended its run (stopped, died, timeout):
    /// the first; the core decides once.
    pub end: Option<GateEvent>,
}

/// The fold of the run's [`Shown`] facts (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct RunView {
    robots: BTreeMap<u32, RobotView>,
    /// Robots that became beacons, in the order they did.
    beacon_order: Vec<u32>,
    /// The robot that arrived.
    arrived: Option<u32>,
    /// Beacons come as [`Shown::Beacon`] (else from the gate's decisions).
    told_beacons: bool,
    /// States come as [`Shown::State`] (else from the gate's decisions).
    told_states: bool,
}

impl Default for RunView {
    fn default() -> Self {
        Self::new()
    }
}

impl RunView {
    /// An empty view, its beacons told by [`Shown::Beacon`] (a live core's
    /// outputs, or a recording with `core/beacon`).
    pub fn new() -> Self {
        Self {
            robots: BTreeMap::new(),
            beacon_order: Vec::new(),
            arrived: None,
            told_beacons: true,
            told_states: true,
        }
    }

    /// An empty view of a recording older than the core's beacon channel:
    /// a robot judged stuck or lost is a beacon where it was judged.
    pub fn without_beacons() -> Self {
        Self { told_beacons: false, ..Self::new() }
    }

    /// This view of a recording older than the core's state channel
    /// (`core/state`): each gate decision sets the state it implies
    /// ([`SlotState::of_gate`]).
    pub fn without_states(self) -> Self {
        Self { told_states: false, ..self }
    }

    /// Takes in one fact; whether the beacons changed (one appeared or
    /// moved).
    pub fn take(&mut self, shown: &Shown) -> bool {
        match *shown {
            Shown::Moved(pose) => {
                self.robot(pose.robot.0).pose = Some(pose);
                false
            }
            Shown::Beacon(BeaconAt { robot, at }) => self.beacon(robot, at),
            Shown::State(StateChange { robot, state }) => {
                self.robot(robot).state = Some(state);
                false
            }
            Shown::Gate(event) => self.gate(&event),
        }
    }

    fn robot(&mut self, id: u32) -> &mut RobotView {
        self.robots.entry(id).or_default()
    }

    fn beacon(&mut self, robot: u32, at: Vec2) -> bool {
        let view = self.robots.entry(robot).or_default();
        if view.beacon == Some(at) {
            return false;
        }
        if view.beacon.replace(at).is_none() {
            self.beacon_order.push(robot);
        }
        true
    }

    fn gate(&mut self, event: &GateEvent) -> bool {
        let id = event.robot.0;
        let told_states = self.told_states;
        let view = self.robot(id);
        if !told_states {
            view.state = Some(SlotState::of_gate(event.kind));
        }
        match event.kind {
            GateKind::Deployed => {
                view.deployed = true;
                return false;
            }
            GateKind::Stopped { arrived: true } => {
                self.arrived.get_or_insert(id);
            }
            _ => {}
        }
        self.robot(id).end.get_or_insert(*event);
        let beacon = matches!(event.kind, GateKind::Stopped { arrived: false } | GateKind::Died);
        if beacon && !self.told_beacons {
            return self.beacon(id, Vec2::new(event.x, event.y));
        }
        false
    }

    /// Robot `id` as shown (none: nothing shown of it yet).
    pub fn robot_view(&self, id: u32) -> Option<&RobotView> {
        self.robots.get(&id)
    }

    /// Every robot shown, in id order.
    pub fn robots(&self) -> impl Iterator<Item = (u32, &RobotView)> + '_ {
        self.robots.iter().map(|(&id, r)| (id, r))
    }

    /// Every beacon, in the order the robots became beacons, where it stands.
    pub fn beacons(&self) -> impl Iterator<Item = (u32, Vec2)> + '_ {
        self.beacon_order.iter().filter_map(|id| Some((*id, self.robots.get(id)?.beacon?)))
    }

    /// The robot that arrived at the goal: the run's success.
    pub fn arrived(&self) -> Option<u32> {
        self.arrived
    }

    /// Robots used: the robots the gate deployed.
    pub fn robots_used(&self) -> u32 {
        self.robots.values().filter(|r| r.deployed).count() as u32
    }

    /// Robot `id`'s state as shown (none: never said).
    pub fn state(&self, id: u32) -> Option<SlotState> {
        self.robots.get(&id).and_then(|r| r.state)
    }

    /// Whether the gate deployed robot `id`.
    pub fn deployed(&self, id: u32) -> bool {
        self.robots.get(&id).is_some_and(|r| r.deployed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::RobotId;

    fn gate(robot: u32, kind: GateKind, x: f64) -> Shown {
        Shown::Gate(GateEvent { robot: RobotId(robot), kind, x, y: 0.0, step: 1 })
    }

    fn moved(robot: u32, x: f64, step: u64) -> Shown {
        Shown::Moved(Pose { robot: RobotId(robot), x, y: 0.0, heading: 0.0, step, time_us: step })
    }

    #[test]
    fn a_beacon_creeps_as_the_core_says_and_keeps_its_place_in_order() {
        let mut v = RunView::new();
        assert!(!v.take(&moved(2, 1.0, 1)));
        assert!(!v.take(&gate(2, GateKind::Stopped { arrived: false }, 1.0)), "told, not judged");
        assert_eq!(v.beacons().count(), 0);
        assert!(v.take(&Shown::Beacon(BeaconAt { robot: 2, at: Vec2::new(1.0, 0.0) })));
        assert!(v.take(&Shown::Beacon(BeaconAt { robot: 1, at: Vec2::new(5.0, 0.0) })));
        assert!(!v.take(&Shown::Beacon(BeaconAt { robot: 2, at: Vec2::new(1.0, 0.0) })), "the same place");
        assert!(v.take(&Shown::Beacon(BeaconAt { robot: 2, at: Vec2::new(1.5, 0.0) })), "crept on");
        let beacons: Vec<_> = v.beacons().collect();
        assert_eq!(beacons, [(2, Vec2::new(1.5, 0.0)), (1, Vec2::new(5.0, 0.0))]);
    }

    #[test]
    fn arrival_robots_used_states_and_poses_have_one_owner() {
        let mut v = RunView::new();
        for k in 1..=3 {
            v.take(&Shown::State(StateChange { robot: k, state: SlotState::Registered }));
        }
        v.take(&gate(1, GateKind::Deployed, 0.0));
        v.take(&moved(1, 0.5, 2));
        v.take(&gate(1, GateKind::Died, 0.5));
        v.take(&gate(2, GateKind::Deployed, 0.0));
        v.take(&Shown::State(StateChange { robot: 2, state: SlotState::Arrived }));
        v.take(&gate(2, GateKind::Stopped { arrived: true }, 9.0));
        assert_eq!((v.arrived(), v.robots_used()), (Some(2), 2));
        assert!(v.deployed(1) && !v.deployed(3));
        let one = v.robot_view(1).copied().unwrap_or_default();
        assert_eq!((one.pose.map(|p| p.x), one.end.map(|e| e.kind)), (Some(0.5), Some(GateKind::Died)));
        assert_eq!(v.robot_view(2).and_then(|r| r.state), Some(SlotState::Arrived));
        assert_eq!(v.robot_view(3).and_then(|r| r.state), Some(SlotState::Registered));
    }

    #[test]
    fn without_beacon_facts_the_gate_places_beacons_where_it_judged() {
        let mut v = RunView::without_beacons();
        assert!(v.take(&gate(1, GateKind::Stopped { arrived: false }, 2.0)));
        assert!(v.take(&gate(2, GateKind::Died, 3.0)));
        assert!(!v.take(&gate(3, GateKind::Stopped { arrived: true }, 4.0)));
        assert!(!v.take(&moved(1, 2.5, 9)), "no creep without the core's word");
        let beacons: Vec<_> = v.beacons().collect();
        assert_eq!(beacons, [(1, Vec2::new(2.0, 0.0)), (2, Vec2::new(3.0, 0.0))]);
    }

    /// A robot revoked before its deployment: the core says it is lost,
    /// with no gate decision; the told view shows it, a gate decision
    /// changes no told state, and a view of an older recording takes the
    /// states its gate decisions imply.
    #[test]
    fn states_are_the_cores_and_without_them_the_gates() {
        let mut v = RunView::new();
        v.take(&Shown::State(StateChange { robot: 1, state: SlotState::Registered }));
        v.take(&Shown::State(StateChange { robot: 1, state: SlotState::Lost }));
        v.take(&gate(2, GateKind::Deployed, 0.0));
        v.take(&gate(2, GateKind::Timeout, 1.0));
        assert_eq!((v.state(1), v.state(2)), (Some(SlotState::Lost), None), "told: only the core's word");
        let mut old = RunView::without_beacons().without_states();
        old.take(&gate(2, GateKind::Deployed, 0.0));
        assert_eq!(old.state(2), Some(SlotState::Moving));
        old.take(&gate(2, GateKind::Timeout, 1.0));
        old.take(&gate(3, GateKind::Died, 1.0));
        assert_eq!((old.state(2), old.state(3)), (Some(SlotState::Unfinished), Some(SlotState::Died)));
    }
}
