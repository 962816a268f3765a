//! A launch's run as the snapshot picture draws it, rebuilt from what crossed
//! the bus: poses and gate decisions.
//!
//! Why from bus messages and not from the launch's state: `orchestrator draw
//! FILE.mcap` has only the recording, and `launch --svg` must draw what a
//! lab's mocap saw. Both feed the same [`Trace`], so the two pictures of a
//! run are the same picture. A robot's trajectory runs from its first pose
//! (its start pose) to the pose at its gate decision; the frozen poses a
//! beacon keeps publishing afterwards add nothing.

use crate::commands::world::verdict;
use bycoms_protocol::msg::{GateEvent, GateKind, Pose};
use bycoms_sim::runner::{Outcome, RobotEnd, RobotRun, RunResult};
use bycoms_sim::terrain::Terrain;
use bycoms_sim::Vec2;
use std::collections::BTreeMap;

/// One robot's track so far.
#[derive(Debug, Clone, Default)]
struct Track {
    path: Vec<Vec2>,
    end: Option<GateKind>,
    /// Where the gate decided (a beacon's position).
    at: Option<Vec2>,
}

/// Poses and gate decisions of one run, in the order they crossed the bus.
#[derive(Debug, Clone, Default)]
pub struct Trace {
    robots: BTreeMap<u32, Track>,
}

impl Trace {
    /// An empty trace.
    pub fn new() -> Self {
        Self::default()
    }

    /// A pose: extends its robot's trajectory until the gate has decided on it.
    pub fn pose(&mut self, pose: &Pose) {
        let track = self.robots.entry(pose.robot.0).or_default();
        if track.end.is_none() {
            track.path.push(Vec2::new(pose.x, pose.y));
        }
    }

    /// A gate decision: ends its robot's trajectory (deployments only mark it).
    pub fn gate(&mut self, event: &GateEvent) {
        let track = self.robots.entry(event.robot.0).or_default();
        if event.kind == GateKind::Deployed || track.end.is_some() {
            return;
        }
        let at = Vec2::new(event.x, event.y);
        if track.path.is_empty() {
            track.path.push(at);
        }
        track.end = Some(event.kind);
        track.at = Some(at);
    }

    /// Whether any robot was seen.
    pub fn is_empty(&self) -> bool {
        self.robots.is_empty()
    }

    /// The run as [`RunResult`], for `draw::snapshot`: robots in id
    /// (deployment) order; a robot that died counts as stuck (a beacon
    /// where last seen); `dt` converts steps to time.
    pub fn result(&self, dt: f64) -> RunResult {
        let mut robots = Vec::new();
        let mut beacons = Vec::new();
        for (&id, track) in self.robots.iter().filter(|(_, t)| !t.path.is_empty()) {
            let end = match track.end {
                Some(GateKind::Stopped { arrived: true }) => RobotEnd::Arrived,
                Some(GateKind::Stopped { arrived: false } | GateKind::Died) => RobotEnd::Stuck,
                _ => RobotEnd::Moving,
            };
            let position = track.at.or(track.path.last().copied()).unwrap_or(Vec2::new(0.0, 0.0));
            if end == RobotEnd::Stuck {
                beacons.push(position);
            }
            let steps = track.path.len().saturating_sub(1) as u64;
            robots.push(RobotRun { id, end, position, steps, trajectory: track.path.clone() });
        }
        let success = robots.iter().any(|r| r.end == RobotEnd::Arrived);
        let timed_out = self.robots.values().any(|t| t.end == Some(GateKind::Timeout));
        let outcome = match (success, timed_out) {
            (true, _) => Outcome::Arrived,
            (false, true) => Outcome::TimeLimit,
            (false, false) => Outcome::RobotsExhausted,
        };
        let steps = robots.iter().map(|r| r.steps).sum::<u64>();
        RunResult {
            success,
            outcome,
            steps,
            time: steps as f64 * dt,
            robots_used: robots.len() as u32,
            beacons,
            robots,
        }
    }
}

/// The snapshot picture of a traced run on `terrain` (start and goal set):
/// `heading` on the first title line, the verdict on the second.
pub fn picture(terrain: &Terrain, trace: &Trace, eps: f64, dt: f64, heading: &str) -> String {
    let result = trace.result(dt);
    let verdict = verdict(result.outcome, result.robots_used, result.time, result.beacons.len());
    super::snapshot::render(terrain, &result, eps, [heading, &verdict])
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
        trace.pose(&pose(1, 0.0));
        trace.gate(&event(1, GateKind::Deployed, 0.0));
        for x in [1.0, 2.0, 2.0] {
            trace.pose(&pose(1, x));
        }
        trace.gate(&event(1, GateKind::Stopped { arrived: false }, 2.0));
        trace.pose(&pose(1, 2.0)); // republished frozen pose: ignored
        trace.pose(&pose(2, 0.0));
        trace.pose(&pose(2, 0.5));
        trace.gate(&event(2, GateKind::Died, 0.5));
        trace.pose(&pose(3, 0.0));
        trace.pose(&pose(3, 3.0));
        trace.gate(&event(3, GateKind::Stopped { arrived: true }, 3.0));
        let r = trace.result(0.1);
        assert_eq!(r.outcome, Outcome::Arrived);
        assert_eq!(r.robots.iter().map(|r| r.steps).collect::<Vec<_>>(), [3, 1, 1]);
        assert_eq!(r.steps, 5);
        assert!((r.time - 0.5).abs() < 1e-12);
        assert_eq!(r.beacons, [Vec2::new(2.0, 1.0), Vec2::new(0.5, 1.0)]);
        assert_eq!(r.robots[2].end, RobotEnd::Arrived);
    }

    #[test]
    fn a_run_cut_short_keeps_its_moving_robot_and_a_timeout_is_a_time_limit() {
        let mut trace = Trace::new();
        trace.pose(&pose(1, 0.0));
        trace.pose(&pose(1, 1.0));
        let r = trace.result(0.1);
        assert_eq!((r.outcome, r.robots[0].end), (Outcome::RobotsExhausted, RobotEnd::Moving));
        trace.gate(&event(1, GateKind::Timeout, 1.0));
        assert_eq!(trace.result(0.1).outcome, Outcome::TimeLimit);
    }
}
