//! The operator places robot k at the start; motion capture confirms it.
//!
//! Why: in a lab nobody but the operator can put a robot on the start
//! mark, and the gate must not open before it is there — a robot enabled
//! elsewhere would be judged from the wrong start. So the orchestrator
//! asks (on the terminal and in the log), then waits until mocap has seen
//! the robot's rigid body tracked within `radius` of the start for `hold`
//! seconds (not merely carried past it), and anchors the tracker there so
//! even the first streamed pose after enabling is checked for a swap.
//! Only then is the robot enabled. An operator who does not place it within
//! `timeout` ends the launch with an error naming the robot and its body.

use super::config::PlacementConfig;
use super::natnet_source::{NatNetPoseSource, SourceError};
use super::ArenaPose;
use bycoms_protocol::msg::Pose;
use bycoms_protocol::RobotId;
use bycoms_sim::Vec2;
use std::time::{Duration, Instant};

/// Why a placement failed.
#[derive(Debug, thiserror::Error)]
pub enum PlacementError {
    /// Not placed in time.
    #[error("{robot} (rigid body {body}) was not seen at the start ({x:.2}, {y:.2}) within {waited:.1?}; last seen: {last}")]
    NotPlaced {
        /// The robot.
        robot: RobotId,
        /// Its rigid body's name.
        body: String,
        /// The start.
        x: f64,
        /// The start.
        y: f64,
        /// How long we waited.
        waited: Duration,
        /// Where it was last seen, in words.
        last: String,
    },
    /// The mocap source failed.
    #[error(transparent)]
    Source(#[from] SourceError),
}

/// Sans-IO: is the robot at the start, and has it stayed there?
#[derive(Clone, Debug)]
pub struct PlacementWatch {
    robot: RobotId,
    start: Vec2,
    config: PlacementConfig,
    inside_since_us: Option<u64>,
    last: Option<Pose>,
}

impl PlacementWatch {
    /// Watches for `robot` at `start`.
    pub fn new(robot: RobotId, start: Vec2, config: PlacementConfig) -> Self {
        Self { robot, start, config, inside_since_us: None, last: None }
    }

    /// Takes one trusted pose (others' are ignored); true once the robot
    /// has been within the radius for the hold time. A pose outside the
    /// radius starts the hold again; a frame without the robot does not.
    pub fn observe(&mut self, pose: &Pose) -> bool {
        if pose.robot != self.robot {
            return false;
        }
        self.last = Some(*pose);
        let inside = Vec2::new(pose.x, pose.y).distance(self.start) <= self.config.radius;
        if !inside {
            self.inside_since_us = None;
            return false;
        }
        let since = *self.inside_since_us.get_or_insert(pose.time_us);
        pose.time_us.saturating_sub(since) as f64 * 1e-6 >= self.config.hold
    }

    /// The last trusted pose seen.
    pub fn last(&self) -> Option<Pose> {
        self.last
    }

    fn last_in_words(&self) -> String {
        match self.last {
            Some(p) => format!(
                "({:.2}, {:.2}), {:.2} from the start",
                p.x,
                p.y,
                Vec2::new(p.x, p.y).distance(self.start)
            ),
            None => "never (no trusted pose)".into(),
        }
    }
}

/// Asks the operator to place `robot` at `start` and waits until mocap sees
/// it there (see the module docs). Returns its pose at the start.
pub fn await_placement(
    source: &mut NatNetPoseSource,
    robot: RobotId,
    start: Vec2,
    config: PlacementConfig,
) -> Result<Pose, PlacementError> {
    let body = source.pipeline_mut().body_name(robot).to_owned();
    let prompt = format!(
        "OPERATOR: place {robot} (rigid body {body}) at the start ({:.2}, {:.2}) — it is enabled once motion capture sees it there",
        start.x, start.y
    );
    bycoms_logging::status_line(&prompt);
    tracing::info!(%robot, body, x = start.x, y = start.y, "operator asked to place the robot at the start");
    let mut watch = PlacementWatch::new(robot, start, config);
    let began = Instant::now();
    let timeout = Duration::from_secs_f64(config.timeout);
    let mut reminded = Instant::now();
    loop {
        let waited = began.elapsed();
        if waited >= timeout {
            let last = watch.last_in_words();
            return Err(PlacementError::NotPlaced { robot, body, x: start.x, y: start.y, waited, last });
        }
        // Carried by hand: no speed limit until it is placed.
        source.pipeline_mut().tracker_mut().forget(robot);
        if let Some(batch) = source.poll((timeout - waited).min(Duration::from_millis(100)))? {
            if let Some(pose) = batch.poses.iter().find(|p| p.robot == robot) {
                if watch.observe(pose) {
                    let at = ArenaPose { x: pose.x, y: pose.y, heading: pose.heading };
                    source.pipeline_mut().tracker_mut().anchor(robot, at, pose.time_us);
                    bycoms_logging::status_line(&format!("{robot} is at the start: enabling it"));
                    tracing::info!(%robot, x = pose.x, y = pose.y, "robot placed at the start");
                    return Ok(*pose);
                }
            }
        }
        if reminded.elapsed() >= Duration::from_secs(10) {
            reminded = Instant::now();
            let seen = watch.last_in_words();
            bycoms_logging::status_line(&format!(
                "still waiting for {robot} ({body}) at the start; seen at {seen}"
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(x: f64, t_ms: u64) -> Pose {
        Pose { robot: RobotId(2), x, y: 0.0, heading: 0.0, step: t_ms, time_us: t_ms * 1000 }
    }

    #[test]
    fn placed_only_after_holding_still_inside_the_radius() {
        let cfg = PlacementConfig { radius: 0.5, hold: 1.0, timeout: 10.0 };
        let mut w = PlacementWatch::new(RobotId(2), Vec2::new(0.0, 0.0), cfg);
        assert!(!w.observe(&pose(3.0, 0)), "far away");
        assert!(!w.observe(&pose(0.2, 100)), "inside: the hold starts");
        assert!(!w.observe(&pose(0.9, 600)), "carried past: outside again");
        assert!(!w.observe(&pose(0.1, 700)));
        assert!(!w.observe(&Pose { robot: RobotId(1), ..pose(0.0, 1800) }), "another robot's pose");
        assert!(!w.observe(&pose(0.1, 1600)), "0.9 s inside");
        assert!(w.observe(&pose(0.1, 1700)), "1 s inside");
    }
}
