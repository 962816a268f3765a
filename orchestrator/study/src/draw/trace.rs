//! A launch's run as the snapshot picture draws it, rebuilt from what crossed
//! the bus: poses and gate decisions.
//!
//! Why from bus messages and not from the launch's state: `orchestrator draw
//! FILE.mcap` has only the recording, and `launch --svg` must draw what a
//! lab's mocap saw. Both feed the same [`Trace`], so the two pictures of a
//! run are the same picture. A robot's trajectory runs from its first pose
//! (its start pose) to the pose at the gate decision that ended its run;
//! the frozen poses a beacon keeps publishing afterwards add nothing. That
//! decision (its end: arrived, a beacon, lost, timed out, and where) is the
//! run view's ([`RunView`]), the fold every renderer reads, as the
//! robot's success, the robots used and the beacons are.
//!
//! The run's time in the title is the summary's: each robot's active
//! periods from its start pose to its last change of pose, counted in pose
//! time by the gate's own rule (`gate::active_periods`), summed over
//! the robots. Counting poses instead would add the gate's dwell and count
//! every motion-capture frame as a control period. The start pose is the one
//! the `Deployed` decision names by its step (in lockstep that step is the
//! tick the robot started at, its time the tick's).
//!
//! Why the start pose is looked up by its step among the robot's recent
//! poses, not taken as its latest: motion capture by NatNet hands the launch
//! a batch of frames at a time, and every frame is recorded as it is drained,
//! before the launch judges them; the `Deployed` decision about the batch's
//! first pose thus follows several later poses of the same robot on the
//! record. Taking the latest as the start gave the start the wrong step, its
//! time became step × period (frame 1583 → 158 s, where the pose said 1.6 s),
//! no period was counted and the trajectories were lost (issue 31). Bus
//! mocap hands one pose at a time, so there the two are the same pose.

use super::snapshot::{Options, Unit};
use crate::gate::{active_periods, same_pose};
use crate::runs::summary_line;
use bycoms_gate::view::{BeaconAt, RunView, Shown};
use bycoms_protocol::msg::{GateEvent, GateKind, Pose};
use bycoms_sim::body::Kinematics;
use bycoms_sim::runner::{RobotRun, RobotRunEnd, RunOutcome, RunResult};
use bycoms_sim::terrain::Terrain;
use bycoms_sim::Vec2;
use std::collections::{BTreeMap, VecDeque};

/// How many of a robot's poses before its `Deployed` decision are kept to find
/// the start pose in: more than the frames of one motion-capture batch (120 Hz
/// NatNet drained every few milliseconds hands a few).
const BEFORE_DEPLOYED: usize = 256;

/// One robot's track so far (where it ended is the view's).
#[derive(Debug, Clone, Default)]
struct Track {
    /// Its latest poses before its `Deployed` decision (at most
    /// [`BEFORE_DEPLOYED`]): the start pose is among them.
    before: VecDeque<Pose>,
    /// Whether the gate's `Deployed` decision was seen.
    deployed: bool,
    /// From its start pose on: the active-time count.
    active: Option<Active>,
}

/// A deployed robot's start and last change of pose, as the gate counts them.
#[derive(Debug, Clone)]
struct Active {
    /// The step the gate deployed it at.
    start_step: u64,
    /// Pose time of the start pose; `None`: the start tick's time (step ×
    /// period), known once the period is.
    start_us: Option<u64>,
    /// The latest pose taken (poses of older steps are ignored).
    last: Pose,
    /// Pose time of the last change of pose; `None`: none since the start.
    last_change_us: Option<u64>,
    /// Where it was at the start pose.
    start_at: Vec2,
    /// Every later pose taken: pose time and position.
    moves: Vec<(u64, Vec2)>,
    /// The step of each of `moves`, and whether it changed the pose.
    steps: Vec<(u64, bool)>,
}

impl Active {
    /// From the robot's latest pose when the gate deployed it: the start
    /// pose, at the step the decision names (in lockstep the tick it starts
    /// at; an agent's first pose may still carry an older step).
    fn start(latest: Pose, deployed: &GateEvent) -> Self {
        let start_us = (latest.step == deployed.step).then_some(latest.time_us);
        let last = Pose { step: deployed.step, ..latest };
        let start_at = Vec2::new(latest.x, latest.y);
        let (moves, steps) = (Vec::new(), Vec::new());
        Self { start_step: deployed.step, start_us, last, last_change_us: None, start_at, moves, steps }
    }

    /// From a robot's first pose.
    fn first(pose: Pose) -> Self {
        Self {
            start_step: pose.step,
            start_us: Some(pose.time_us),
            last: pose,
            last_change_us: None,
            start_at: Vec2::new(pose.x, pose.y),
            moves: Vec::new(),
            steps: Vec::new(),
        }
    }

    fn observe(&mut self, pose: &Pose) {
        if pose.step <= self.last.step {
            return;
        }
        let changed = !same_pose(pose, &self.last);
        if changed {
            self.last_change_us = Some(pose.time_us);
        }
        self.last = *pose;
        self.moves.push((pose.time_us, Vec2::new(pose.x, pose.y)));
        self.steps.push((pose.step, changed));
    }

    /// The gate judged it on its pose of `step`: poses of later steps
    /// (motion capture's frames of a batch are recorded before the gate's
    /// decision on the first of them) are not its run, as they are not the
    /// summary's. Without a pose of that step (a decision on the start
    /// pose), nothing is cut.
    fn end_at(&mut self, step: u64) {
        let Some(judged) = self.steps.iter().position(|(s, _)| *s == step) else { return };
        let kept = judged + 1;
        self.moves.truncate(kept);
        self.steps.truncate(kept);
        let last_change = self.steps.iter().rposition(|(_, changed)| *changed);
        self.last_change_us = last_change.map(|i| self.moves[i].0);
    }

    fn start_us(&self, period_us: u64) -> u64 {
        self.start_us.unwrap_or(self.start_step.saturating_mul(period_us))
    }

    /// Active control periods of `period_us`.
    fn periods(&self, period_us: u64) -> u64 {
        let start_us = self.start_us(period_us);
        active_periods(start_us, self.last_change_us.unwrap_or(start_us), period_us)
    }

    /// Its trajectory as a simulated run's: the start, then where it was
    /// after each active period (the latest pose by then), the last point
    /// where it last moved to. Motion capture's frames and the still poses
    /// of the dwell thus fall out, and the timeline of the pictures holds.
    fn trajectory(&self, period_us: u64) -> Vec<Vec2> {
        let (start_us, steps) = (self.start_us(period_us), self.periods(period_us));
        let mut out = Vec::with_capacity(steps as usize + 1);
        let (mut at, mut next) = (self.start_at, self.moves.iter().peekable());
        for k in 0..steps {
            let by = start_us + k * period_us;
            while let Some(&(_, p)) = next.next_if(|(t, _)| *t <= by) {
                at = p;
            }
            out.push(at);
        }
        let end = self.last_change_us.unwrap_or(start_us);
        let last = self.moves.iter().take_while(|(t, _)| *t <= end).last().map_or(self.start_at, |m| m.1);
        out.push(last);
        out
    }
}

/// Poses and gate decisions of one run, in the order they crossed the bus.
#[derive(Debug, Clone)]
pub struct Trace {
    robots: BTreeMap<u32, Track>,
    /// The run as the views show it: which robot arrived, the robots used,
    /// where the beacons stand (the summary reads the same fold).
    view: RunView,
}

impl Default for Trace {
    fn default() -> Self {
        Self::new()
    }
}

impl Trace {
    /// An empty trace of a run whose beacons are not told (a recording
    /// older than `core/beacon`): the gate's decisions place them
    /// ([`RunView::without_beacons`]).
    pub fn new() -> Self {
        Self { robots: BTreeMap::new(), view: RunView::without_beacons() }
    }

    /// An empty trace of a run whose beacons the launch core tells
    /// ([`Trace::beacon`]: a live launch's `--svg`, a recording with
    /// `core/beacon`), creeping as its table's.
    pub fn with_beacons_told() -> Self {
        Self { robots: BTreeMap::new(), view: RunView::new() }
    }

    /// Robot `robot`'s beacon stands at `at` (the core's beacon table
    /// changed).
    pub fn beacon(&mut self, robot: u32, at: Vec2) {
        self.view.take(&Shown::Beacon(BeaconAt { robot, at }));
    }

    /// The gate's decision that ended robot `id`'s run, as the view holds it.
    fn end(&self, id: u32) -> Option<GateEvent> {
        self.view.robot_view(id).and_then(|r| r.end)
    }

    /// A pose: extends its robot's trajectory until the gate has decided on it.
    pub fn pose(&mut self, pose: &Pose) {
        self.view.take(&Shown::Moved(*pose));
        let ended = self.end(pose.robot.0).is_some();
        let track = self.robots.entry(pose.robot.0).or_default();
        if ended {
            return;
        }
        if !track.deployed {
            if track.before.len() == BEFORE_DEPLOYED {
                track.before.pop_front();
            }
            track.before.push_back(*pose);
        }
        // Until a `Deployed` decision (none in a recording cut before it),
        // the first pose is the start.
        match &mut track.active {
            Some(active) => active.observe(pose),
            None => track.active = Some(Active::first(*pose)),
        }
    }

    /// A gate decision: ends its robot's trajectory (a deployment starts
    /// its active time).
    pub fn gate(&mut self, event: &GateEvent) {
        let ended = self.end(event.robot.0).is_some();
        self.view.take(&Shown::Gate(*event));
        let track = self.robots.entry(event.robot.0).or_default();
        if ended {
            return;
        }
        if event.kind == GateKind::Deployed {
            let before = std::mem::take(&mut track.before);
            // The pose the decision names by its step, and the later poses
            // recorded before the decision; without one of that step (in
            // lockstep the agent's start pose may carry an older step), the
            // latest pose.
            let at = before.iter().rposition(|p| p.step == event.step).or(before.len().checked_sub(1));
            if let Some(at) = at {
                let mut active = Active::start(before[at], event);
                before.iter().skip(at + 1).for_each(|p| active.observe(p));
                track.active = Some(active);
            }
            track.deployed = true;
            return;
        }
        if let Some(active) = &mut track.active {
            active.end_at(event.step);
        }
    }

    /// Whether any robot was seen.
    pub fn is_empty(&self) -> bool {
        self.robots.is_empty()
    }

    /// The run as [`RunResult`], for `draw::snapshot`: robots in id
    /// (deployment) order; a robot that died counts as stuck (a beacon
    /// where last seen); `dt` converts steps to time. Each robot's end,
    /// success (a robot arrived), the robots used and the beacons are the
    /// view's ([`RunView`]), as the summary's are.
    pub fn result(&self, dt: f64) -> RunResult {
        let period_us = (dt * 1e6).round() as u64;
        let mut robots = Vec::new();
        let mut beacons: Vec<(u32, Vec2)> = self.view.beacons().collect();
        beacons.sort_by_key(|(id, _)| *id);
        for (&id, track) in &self.robots {
            let decided = self.end(id);
            let at = decided.map(|e| Vec2::new(e.x, e.y));
            if track.active.is_none() && at.is_none() {
                continue;
            }
            let end = match decided.map(|e| e.kind) {
                Some(GateKind::Stopped { arrived: true }) => RobotRunEnd::Arrived,
                Some(GateKind::Stopped { arrived: false } | GateKind::Died) => RobotRunEnd::Stuck,
                _ => RobotRunEnd::Moving,
            };
            let trajectory = match (&track.active, at) {
                (Some(active), _) => active.trajectory(period_us),
                (None, at) => at.into_iter().collect(),
            };
            let position = at.or(trajectory.last().copied()).unwrap_or(Vec2::new(0.0, 0.0));
            let steps = track.active.as_ref().map_or(0, |a| a.periods(period_us));
            robots.push(RobotRun { id, end, position, steps, trajectory });
        }
        let success = self.view.arrived().is_some();
        let timed_out = self.view.robots().any(|(_, r)| r.end.is_some_and(|e| e.kind == GateKind::Timeout));
        let outcome = match (success, timed_out) {
            (true, _) => RunOutcome::Arrived,
            (false, true) => RunOutcome::TimeLimit,
            (false, false) => RunOutcome::RobotsExhausted,
        };
        let steps = robots.iter().map(|r| r.steps).sum::<u64>();
        RunResult {
            success,
            outcome,
            steps,
            time: Kinematics { dt, ..Kinematics::paper() }.time_of(steps),
            robots_used: self.view.robots_used(),
            beacons: beacons.into_iter().map(|(_, at)| at).collect(),
            robots,
        }
    }
}

/// The snapshot picture of a traced run on `terrain` (start and goal set):
/// `heading` on the first title line, the verdict on the second.
pub fn picture(terrain: &Terrain, trace: &Trace, eps: f64, dt: f64, heading: &str) -> String {
    picture_in(terrain, trace, eps, dt, heading, &Options::in_unit(Unit::Cell))
}

/// [`picture`] drawn with `opts` (a lab's run: metres, in its room).
pub fn picture_in(
    terrain: &Terrain,
    trace: &Trace,
    eps: f64,
    dt: f64,
    heading: &str,
    opts: &Options,
) -> String {
    let result = trace.result(dt);
    let verdict = summary_line(&result);
    super::snapshot::render_with(terrain, &result, eps, [heading, &verdict], opts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::RobotId;

    fn pose(k: u32, x: f64) -> Pose {
        Pose { robot: RobotId(k), x, y: 1.0, heading: 0.0, step: 0, time_us: 0 }
    }

    fn event(k: u32, kind: GateKind, x: f64) -> GateEvent {
        GateEvent { robot: RobotId(k), kind, x, y: 1.0, step: 0 }
    }

    #[test]
    fn trajectories_end_at_the_decision_and_beacons_are_the_stuck_and_the_dead() {
        let mut trace = Trace::new();
        let t = |s: u64| s * 100_000;
        trace.pose(&at(1, 0, 0.0, 0));
        trace.gate(&event(1, GateKind::Deployed, 0.0));
        for (s, x) in [(1, 1.0), (2, 2.0), (3, 2.0)] {
            trace.pose(&at(1, s, x, t(s)));
        }
        trace.gate(&event(1, GateKind::Stopped { arrived: false }, 2.0));
        trace.pose(&at(1, 4, 2.0, t(4))); // republished frozen pose: ignored
                                          // Without a `Deployed` decision the first pose is the start.
        trace.pose(&at(2, 3, 0.0, t(3)));
        trace.pose(&at(2, 4, 0.5, t(4)));
        trace.gate(&event(2, GateKind::Died, 0.5));
        trace.pose(&at(3, 4, 0.0, t(4)));
        trace.pose(&at(3, 5, 3.0, t(5)));
        trace.gate(&event(3, GateKind::Stopped { arrived: true }, 3.0));
        let r = trace.result(0.1);
        assert_eq!(r.outcome, RunOutcome::Arrived);
        assert_eq!(
            r.robots.iter().map(|r| r.steps).collect::<Vec<_>>(),
            [2, 1, 1],
            "the still pose is no step"
        );
        let points = [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(2.0, 1.0)];
        assert_eq!(r.robots[0].trajectory, points, "one point per period, the still pose none");
        assert_eq!(r.steps, 4);
        assert_eq!(r.time, 0.4);
        assert_eq!(r.beacons, [Vec2::new(2.0, 1.0), Vec2::new(0.5, 1.0)]);
        assert_eq!(r.robots[2].end, RobotRunEnd::Arrived);
    }

    /// Each robot's end is the view's: the first decision that ended its
    /// run, where it was made. A later decision about the same robot (a
    /// stray one in a recording) changes neither its end, nor where it
    /// stands, nor its trajectory, nor the outcome.
    #[test]
    fn a_robots_end_is_the_views_first_decision_about_it() {
        let mut trace = Trace::with_beacons_told();
        trace.pose(&at(1, 0, 0.0, 0));
        trace.gate(&event(1, GateKind::Deployed, 0.0));
        trace.pose(&at(1, 1, 1.0, 100_000));
        trace.gate(&GateEvent { step: 1, ..event(1, GateKind::Stopped { arrived: false }, 1.0) });
        trace.gate(&GateEvent { step: 2, ..event(1, GateKind::Timeout, 4.0) });
        trace.pose(&at(1, 2, 4.0, 200_000));
        let ended = trace.view.robot_view(1).and_then(|r| r.end).map(|e| (e.kind, e.x));
        assert_eq!(ended, Some((GateKind::Stopped { arrived: false }, 1.0)));
        let r = trace.result(0.1);
        assert_eq!((r.robots[0].end, r.robots[0].position), (RobotRunEnd::Stuck, Vec2::new(1.0, 1.0)));
        assert_eq!(r.robots[0].trajectory, [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0)]);
        assert_eq!(r.outcome, RunOutcome::RobotsExhausted, "not a time limit");
    }

    /// A launch's own trace (or a recording with `core/beacon`): its
    /// beacons stand where the core's table has them, creeping on, and its
    /// robots used are those the gate deployed.
    #[test]
    fn told_beacons_creep_and_the_robots_used_are_the_deployed() {
        let mut trace = Trace::with_beacons_told();
        trace.pose(&at(1, 0, 0.0, 0));
        trace.gate(&event(1, GateKind::Deployed, 0.0));
        trace.pose(&at(1, 1, 1.0, 100_000));
        trace.gate(&event(1, GateKind::Stopped { arrived: false }, 1.0));
        assert!(trace.result(0.1).beacons.is_empty(), "the gate alone makes no beacon here");
        trace.beacon(1, Vec2::new(1.0, 1.0));
        trace.beacon(1, Vec2::new(1.25, 1.0));
        trace.pose(&at(2, 3, 0.0, 300_000)); // seen, never deployed
        let r = trace.result(0.1);
        assert_eq!(r.beacons, [Vec2::new(1.25, 1.0)], "where it crept to");
        assert_eq!((r.robots_used, r.success), (1, false));
    }

    /// Motion capture's frames of a batch are recorded before the gate's
    /// decision on the first of them: frames after the pose it was judged on
    /// are no part of its run (the title once said 40.4 s where the summary
    /// said 40.3 s, issue 31).
    #[test]
    fn frames_recorded_after_the_judged_pose_are_not_the_run() {
        let t = |s: u64| s * 100_000;
        let mut trace = Trace::new();
        trace.pose(&at(1, 0, 0.0, 0));
        trace.gate(&GateEvent { robot: RobotId(1), kind: GateKind::Deployed, x: 0.0, y: 1.0, step: 0 });
        for (s, x) in [(1, 1.0), (2, 2.0), (3, 2.5)] {
            trace.pose(&at(1, s, x, t(s)));
        }
        let judged = GateEvent {
            robot: RobotId(1),
            kind: GateKind::Stopped { arrived: true },
            x: 2.0,
            y: 1.0,
            step: 2,
        };
        trace.gate(&judged);
        let r = trace.result(0.1);
        assert_eq!(r.robots[0].steps, 2, "the frame of step 3 came after the verdict on step 2");
        assert_eq!(r.robots[0].trajectory.last(), Some(&Vec2::new(2.0, 1.0)));
    }

    #[test]
    fn a_run_cut_short_keeps_its_moving_robot_and_a_timeout_is_a_time_limit() {
        let mut trace = Trace::new();
        trace.pose(&pose(1, 0.0));
        trace.pose(&pose(1, 1.0));
        let r = trace.result(0.1);
        assert_eq!((r.outcome, r.robots[0].end), (RunOutcome::RobotsExhausted, RobotRunEnd::Moving));
        trace.gate(&event(1, GateKind::Timeout, 1.0));
        assert_eq!(trace.result(0.1).outcome, RunOutcome::TimeLimit);
    }

    fn at(k: u32, step: u64, x: f64, time_us: u64) -> Pose {
        Pose { robot: RobotId(k), x, y: 1.0, heading: 0.0, step, time_us }
    }

    /// The lockstep launch as the gate sees it: robot 1 moves 10 periods,
    /// stands still for the 2 s dwell and is judged stuck; robot 2's agent
    /// died before it was deployed; robot 3 starts at tick 30 (its start
    /// pose still carries its agent's stale step 0) and arrives after 12.
    fn lockstep_trace() -> Trace {
        let mut trace = Trace::new();
        trace.pose(&at(1, 0, 0.0, 0));
        trace.gate(&event(1, GateKind::Deployed, 0.0));
        for s in 1..=30u64 {
            trace.pose(&at(1, s, 0.1 * s.min(10) as f64, s * 100_000));
        }
        trace.gate(&event(1, GateKind::Stopped { arrived: false }, 1.0));
        trace.pose(&at(3, 0, 0.0, 0));
        trace.gate(&GateEvent { step: 30, ..event(3, GateKind::Deployed, 0.0) });
        for s in 31..=42u64 {
            trace.pose(&at(3, s, 0.1 * (s - 30) as f64, s * 100_000));
        }
        trace.gate(&event(3, GateKind::Stopped { arrived: true }, 1.2));
        trace
    }

    #[test]
    fn the_run_time_is_the_gates_active_periods_not_every_pose() {
        let r = lockstep_trace().result(0.1);
        assert_eq!(
            r.robots.iter().map(|r| r.steps).collect::<Vec<_>>(),
            [10, 12],
            "the dwell is not counted"
        );
        assert_eq!(r.time, 2.2);
    }

    #[test]
    fn mocap_frames_are_not_periods() {
        // 120 Hz motion capture (frame numbers from 5000): 3 s of driving,
        // then 2 s still: 3.0 s of run time, not 600 frames × 0.1 s.
        let mut trace = Trace::new();
        let frame = |n: u64, x: f64| at(1, 5000 + n, x, 1_000_000 + n * 8_333);
        trace.pose(&frame(0, 0.0));
        trace.gate(&GateEvent { step: 5000, ..event(1, GateKind::Deployed, 0.0) });
        for n in 1..=600u64 {
            trace.pose(&frame(n, 0.001 * n.min(360) as f64));
        }
        trace.gate(&event(1, GateKind::Stopped { arrived: false }, 0.36));
        let r = trace.result(0.1);
        assert_eq!((r.robots[0].steps, r.time), (30, 3.0));
        // The picture shows it where it stopped, its whole way there: one
        // point per period, as a simulated run's trajectory.
        let now = crate::draw::timeline::robots_at(&r, r.steps);
        assert!(now[0].position.distance(Vec2::new(0.36, 1.0)) < 1e-9, "{:?}", now[0].position);
        assert_eq!(r.robots[0].trajectory.len(), 31);
        assert!(r.robots[0].trajectory[15].distance(Vec2::new(0.18, 1.0)) < 1e-9, "1.5 s = 180 frames in");
    }

    #[test]
    fn the_title_names_the_robot_that_arrived_not_the_count() {
        let terrain = bycoms_sim::terrain::parse(&"..........\n".repeat(10)).expect("terrain");
        let svg = picture(&terrain, &lockstep_trace(), 3.0, 0.1, "heading");
        assert!(svg.contains("robot 3 arrived after 2.2 s (1 beacon)"), "{svg}");
        // Robot 3 (the second robot that ran) is drawn with its own way.
        assert!(svg.contains(r##"fill="none" stroke="#2ca02c" stroke-width="1.2"/>"##), "{svg}");
    }

    /// NatNet as the launch records it: frames arrive in batches, each frame
    /// is recorded as it is drained, and the gate's `Deployed` decision about
    /// a batch's first frame follows the later frames on the record. The
    /// start is the pose the decision names (frame 1583, 1.6 s of mocap
    /// time), not the latest one; the run's time is the gate's, and the
    /// trajectory is the robot's whole way.
    #[test]
    fn natnet_frames_recorded_before_the_deployment_do_not_move_the_start() {
        let mut trace = Trace::new();
        let frame = |n: u64, x: f64| at(1, 1583 + n, x, 1_566_667 + n * 8_333);
        for n in 0..=5 {
            trace.pose(&frame(n, 0.0));
        }
        trace.gate(&GateEvent { step: 1583, ..event(1, GateKind::Deployed, 0.0) });
        // 3 s of driving (360 frames at 120 Hz), then 2 s still.
        for n in 6..=600u64 {
            trace.pose(&frame(n, 0.001 * n.saturating_sub(5).min(360) as f64));
        }
        trace.gate(&event(1, GateKind::Stopped { arrived: false }, 0.36));
        let r = trace.result(0.1);
        // Moving from frame 6 to 365: (365 × 8333 µs) / 0.1 s = 30 periods.
        let gate = active_periods(1_566_667, 1_566_667 + 365 * 8_333, 100_000);
        assert_eq!((r.robots[0].steps, gate), (30, 30));
        assert_eq!(r.time, 3.0);
        assert_eq!(r.robots[0].trajectory.len(), 31, "a point per period: the whole way");
        assert!(r.robots[0].trajectory[30].distance(Vec2::new(0.36, 1.0)) < 1e-9);
    }
}
