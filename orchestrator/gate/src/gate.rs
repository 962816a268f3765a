//! The deployment gate's judgement, from poses alone.
//!
//! Why no terrain: in a lab the orchestrator sees robots only through
//! motion capture, and a robot never says "I am stuck". So the gate infers
//! it the way a person watching would: a robot that has neither moved
//! faster than `stop_speed` nor turned faster than `stop_turn_rate` for
//! `dwell` has stopped; if its pose is within the goal radius it has
//! arrived, otherwise it is stuck and becomes a beacon. A pose within the
//! goal radius is an arrival at once (the robot is then told to stop).
//!
//! Why the turn rate too: a robot turning in place has zero speed, for up
//! to 120 periods without noise — but with sensing noise its target jumps
//! ±30° every period while it turns 3° per period towards it, and it can
//! spin in place for far longer than any sensible dwell. Judged by speed
//! alone it would be declared stuck while still moving. A moving simulated
//! robot always either moves 0.1 (1 unit/s) or turns π/60 (0.52 rad/s) per
//! period, so with both thresholds well below those a moving robot is never
//! "still", and the dwell only has to outlast mocap jitter. Setting
//! `stop_turn_rate` to 0 ignores turning (speed only, as with mocap whose
//! heading is too noisy to trust; then the dwell must outlast any turn).
//!
//! Counting steps without counting the dwell: a moving simulated robot
//! changes its pose every period (it either moves 0.1 or turns π/60), and a
//! stuck one never does again. So a robot's *active steps* are the periods
//! from its start pose to the last pose that differed from the one before —
//! exactly the runner's `RobotRun::steps`, however long the gate then
//! watched it stand still. The run's time budget is charged with active
//! steps only, as the runner's is. Steps are counted in control periods of
//! pose time (`period_us`), not in poses: a simulated agent publishes one
//! pose per period (pose time = step × period, so this is its step count
//! exactly), but motion capture streams at its own rate (20 Hz from the
//! emulated lab's bus, 120 Hz over NatNet), and counting its frames would
//! make `time_limit` and the summary's steps wrong in a lab.
//!
//! Sans-IO: poses in, verdicts out; the launch loop owns the bus.
//!
//! Why in a crate of its own (`bycoms-gate`): the launch core judges with
//! it, and so do the replay (`replay::judge`) and the picture of a recorded
//! run (`draw::trace`), which sit on either side of the launch; a rule all
//! three share lives below them all, in a small crate, so that a change in
//! the launch core rebuilds neither the study nor motion capture.
//! `bycoms_launch_core::gate` and `bycoms_study::gate` re-export it
//! (ARCHITECTURE.md, "Crates of the orchestrator").

use bycoms_agent::angle::wrap;
use bycoms_protocol::msg::Pose;
use bycoms_sim::runner::arrived;
use bycoms_sim::Vec2;

/// A robot's active steps: control periods of pose time from its start
/// pose (`start_us`) to its last change of pose (`last_change_us`), rounded
/// to whole periods. The one definition of a run's time: the summary's
/// steps come from it through [`Watch`], and the picture's title
/// (`draw::trace`) from the same poses in the recording.
pub fn active_periods(start_us: u64, last_change_us: u64, period_us: u64) -> u64 {
    let active_us = last_change_us.saturating_sub(start_us);
    let period = period_us.max(1);
    (active_us + period / 2) / period
}

/// Whether two poses are the same pose (bit for bit): a robot whose pose
/// does not change is standing still.
pub fn same_pose(a: &Pose, b: &Pose) -> bool {
    a.x.to_bits() == b.x.to_bits()
        && a.y.to_bits() == b.y.to_bits()
        && a.heading.to_bits() == b.heading.to_bits()
}

/// What the gate concluded about a moving robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    /// Within the goal radius.
    Arrived(Pose),
    /// Still for the dwell time, away from the goal.
    Stuck(Pose),
}

/// The motion test's parameters.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GateParams {
    /// The goal.
    pub goal: Vec2,
    /// Arrival radius, world units ([`bycoms_sim::runner::arrived`]).
    pub goal_radius: f64,
    /// Still below this speed, units per simulated second.
    pub stop_speed: f64,
    /// Still below this turn rate, rad per simulated second (0: ignore turning).
    pub stop_turn_rate: f64,
    /// Still for this long has stopped, simulated µs.
    pub dwell_us: u64,
    /// The control period, µs: active steps are pose time over this.
    pub period_us: u64,
}

/// The gate's view of the one moving robot.
#[derive(Clone, Debug)]
pub struct Watch {
    params: GateParams,
    start: Pose,
    last: Pose,
    /// The pose before `last`.
    previous: Pose,
    /// Pose time of the last change of pose, µs.
    last_change_us: u64,
    still_since_us: Option<u64>,
    verdict: Option<Verdict>,
}

impl Watch {
    /// Starts watching a robot deployed at `start` (its first pose).
    pub fn new(params: GateParams, start: Pose) -> Self {
        Self {
            params,
            start,
            last: start,
            previous: start,
            last_change_us: start.time_us,
            still_since_us: None,
            verdict: None,
        }
    }

    /// The robot's latest pose.
    pub fn last(&self) -> Pose {
        self.last
    }

    /// The pose before the latest one.
    pub fn previous(&self) -> Pose {
        self.previous
    }

    /// Control periods from the start pose to the last change of pose
    /// (pose time, rounded to whole periods).
    pub fn active_steps(&self) -> u64 {
        active_periods(self.start.time_us, self.last_change_us, self.params.period_us)
    }

    /// The verdict, once reached.
    pub fn verdict(&self) -> Option<Verdict> {
        self.verdict
    }

    /// Control periods of pose time from the start pose to the latest pose
    /// (the dwell included).
    pub fn watched_periods(&self) -> u64 {
        active_periods(self.start.time_us, self.last.time_us, self.params.period_us)
    }

    /// The run's time is up while the robot stands still: it is judged
    /// stuck now (returned once), without waiting out the rest of the dwell.
    /// Why: the dwell only makes sure that a robot has stopped, and past the
    /// time limit nothing a robot does counts any more; a still robot has
    /// stopped within the limit, as the runner counts it. Without this a
    /// dwell longer than the run (`--dwell 1e9`) watched a robot that had
    /// stopped for ever, whatever the time limit. Whatever the gate's
    /// thresholds say, too: a pose that did not change is a robot that
    /// stands still (with `stop_speed` 0 nothing was ever "still", and a
    /// lockstep launch ran without end). `None` for a robot whose latest
    /// pose changed (it moves: the budget ends it) or was judged already.
    pub fn still_at_the_limit(&mut self) -> Option<Verdict> {
        if self.verdict.is_some() || !same_pose(&self.last, &self.previous) {
            return None;
        }
        self.verdict = Some(Verdict::Stuck(self.last));
        self.verdict
    }

    /// Takes the robot's next pose; returns the verdict when it is reached
    /// (once). Poses older than the latest are ignored.
    pub fn observe(&mut self, pose: Pose) -> Option<Verdict> {
        if self.verdict.is_some() || pose.step <= self.last.step {
            return None;
        }
        let prev = self.last;
        self.previous = prev;
        self.last = pose;
        if !same_pose(&pose, &prev) {
            self.last_change_us = pose.time_us;
        }
        // The runner's test (one function), so the gate decides as it does.
        if arrived(Vec2::new(pose.x, pose.y), self.params.goal, self.params.goal_radius) {
            self.verdict = Some(Verdict::Arrived(pose));
            return self.verdict;
        }
        let elapsed_us = pose.time_us.saturating_sub(prev.time_us);
        if elapsed_us > 0 {
            let seconds = elapsed_us as f64 * 1e-6;
            let speed = Vec2::new(prev.x, prev.y).distance(Vec2::new(pose.x, pose.y)) / seconds;
            let turn_rate = wrap(pose.heading - prev.heading).abs() / seconds;
            let turning = self.params.stop_turn_rate > 0.0 && turn_rate >= self.params.stop_turn_rate;
            if speed < self.params.stop_speed && !turning {
                self.still_since_us.get_or_insert(prev.time_us);
            } else {
                self.still_since_us = None;
            }
        }
        if let Some(since) = self.still_since_us {
            if pose.time_us.saturating_sub(since) >= self.params.dwell_us {
                self.verdict = Some(Verdict::Stuck(pose));
            }
        }
        self.verdict
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::RobotId;

    fn params() -> GateParams {
        GateParams {
            goal: Vec2::new(10.0, 0.0),
            goal_radius: 0.5,
            stop_speed: 0.05,
            stop_turn_rate: 0.0,
            dwell_us: 2_000_000,
            period_us: 100_000,
        }
    }

    fn pose(step: u64, x: f64, heading: f64) -> Pose {
        Pose { robot: RobotId(1), x, y: 0.0, heading, step, time_us: step * 100_000 }
    }

    #[test]
    fn turning_in_place_is_not_stopping_but_standing_still_is() {
        let mut w = Watch::new(params(), pose(10, 0.0, 0.0));
        // 5 straight steps, then 15 periods of turning in place (1.5 s < dwell).
        for s in 11..=15 {
            assert_eq!(w.observe(pose(s, 0.1 * (s - 10) as f64, 0.0)), None);
        }
        for s in 16..=30 {
            assert_eq!(w.observe(pose(s, 0.5, 0.05 * (s - 15) as f64)), None);
        }
        // Moving again resets the dwell; then it freezes at step 35.
        for s in 31..=35 {
            assert_eq!(w.observe(pose(s, 0.5 + 0.1 * (s - 30) as f64, 0.75)), None);
        }
        let frozen = 1.0;
        let mut verdict = None;
        for s in 36..=60 {
            verdict = verdict.or(w.observe(pose(s, frozen, 0.75)));
        }
        let Some(Verdict::Stuck(at)) = verdict else { panic!("no verdict: {verdict:?}") };
        assert_eq!(at.step, 55, "still since step 35, dwell 2 s = 20 periods");
        assert_eq!(w.active_steps(), 25, "steps 11..=35, the dwell is not counted");
        assert_eq!(w.observe(pose(61, 1.0, 0.75)), None, "one verdict only");
    }

    #[test]
    fn with_a_turn_rate_threshold_spinning_in_place_is_never_stopping() {
        let params = GateParams { stop_turn_rate: 0.05, ..params() };
        let mut w = Watch::new(params, pose(0, 0.0, 0.0));
        // 100 periods (10 s, five times the dwell) of turning in place.
        for s in 1..=100 {
            assert_eq!(w.observe(pose(s, 0.0, 0.05 * s as f64)), None, "step {s}");
        }
        let mut verdict = None;
        for s in 101..=125 {
            verdict = verdict.or(w.observe(pose(s, 0.0, 5.0)));
        }
        assert!(matches!(verdict, Some(Verdict::Stuck(p)) if p.step == 120), "{verdict:?}");
        assert_eq!(w.active_steps(), 100);
    }

    #[test]
    fn a_pose_within_the_goal_radius_is_an_arrival_at_once() {
        let mut w = Watch::new(params(), pose(0, 9.0, 0.0));
        assert_eq!(w.observe(pose(1, 9.4, 0.0)), None);
        assert!(matches!(w.observe(pose(2, 9.5, 0.0)), Some(Verdict::Arrived(p)) if p.step == 2));
        assert_eq!(w.active_steps(), 2);
    }

    #[test]
    fn active_steps_are_control_periods_of_pose_time_not_mocap_frames() {
        // Motion capture at 120 Hz (frame numbers from 1000, 8333 µs apart):
        // 3 s of driving, then still. 3 s are 30 periods of 0.1 s, not 360.
        let frame = |n: u64, x: f64| Pose {
            robot: RobotId(1),
            x,
            y: 0.0,
            heading: 0.0,
            step: 1000 + n,
            time_us: n * 8_333,
        };
        let mut w = Watch::new(params(), frame(0, 0.0));
        for n in 1..=360 {
            assert_eq!(w.observe(frame(n, 0.001 * n as f64)), None);
        }
        let mut verdict = None;
        for n in 361..=700 {
            verdict = verdict.or(w.observe(frame(n, 0.36)));
        }
        assert!(matches!(verdict, Some(Verdict::Stuck(_))), "{verdict:?}");
        assert_eq!(w.active_steps(), 30, "360 frames over 3.0 s");
    }

    #[test]
    fn stale_and_repeated_poses_are_ignored() {
        let mut w = Watch::new(params(), pose(5, 0.0, 0.0));
        assert_eq!(w.observe(pose(5, 3.0, 0.0)), None);
        assert_eq!(w.observe(pose(4, 3.0, 0.0)), None);
        assert_eq!(w.last().x, 0.0);
    }
}
