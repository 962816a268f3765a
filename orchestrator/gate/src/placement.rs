//! The operator places robot k at the start; motion capture confirms it.
//!
//! Why: in a lab nobody but the operator can put a robot on the start
//! mark, and the gate must not open before it is there — a robot enabled
//! elsewhere would be judged from the wrong start. [`PlacementWatch`]
//! decides, from trusted poses, when the robot has been within `radius` of
//! the start for `hold` seconds (not merely carried past it). The launch
//! asks the operator and feeds the watch (`launch::lab`, whatever the pose
//! source); while the robot is carried the pose source accepts hand-speed
//! moves and then tracks it from where it was placed
//! (`launch::poses::PoseSource::carried`).
//!
//! Why in the gate's crate (`bycoms-gate`): the launch core decides
//! placement with these plain types and its setup carries the
//! `[placement]` table; motion capture (`bycoms_mocap`, with its NatNet
//! client) takes them too. A small crate below both, so that a change in the
//! launch core does not rebuild motion capture; both re-export them at
//! their old paths.

use bycoms_protocol::msg::Pose;
use bycoms_protocol::RobotId;
use bycoms_runtime::seconds::{check_seconds, Zero};
use bycoms_sim::Vec2;
use serde::{Deserialize, Serialize};

/// How a robot's placement at the start is confirmed: the launch's
/// `[placement]` table, one for every pose source (world units: metres in
/// a lab, as its scenario; lab seconds).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default, expecting = "a [placement] table")]
pub struct PlacementConfig {
    /// The robot counts as placed within this distance of the start, world units.
    pub radius: f64,
    /// ...seen there, tracked, for this long (s): not just carried past it.
    pub hold: f64,
    /// The operator gets this long (s) before the launch ends with an error.
    pub timeout: f64,
}

/// A real crawler robot (metres): within 10 cm of the start for 0.5 s of
/// motion capture; the operator has 10 minutes.
impl Default for PlacementConfig {
    fn default() -> Self {
        Self { radius: 0.1, hold: 0.5, timeout: 600.0 }
    }
}

impl PlacementConfig {
    /// Checks the numbers; the message names the key (`placement.radius`).
    pub fn validate(&self) -> Result<(), String> {
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return Err(format!("placement.radius must be a positive number, got {}", self.radius));
        }
        check_seconds("placement.timeout", self.timeout, Zero::Refused)?;
        check_seconds("placement.hold", self.hold, Zero::Allowed)?;
        Ok(())
    }
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
