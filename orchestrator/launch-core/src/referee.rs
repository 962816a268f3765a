//! The gate and the time budget, once: shared by the launch core and
//! `orchestrator replay`.
//!
//! Why one referee: a replay must reach the launch's decisions from the same
//! poses by the same rules. When the replay had its own copy of these rules
//! it drifted (the lockstep start pose's time was rewritten by the launch
//! and not by the replay). Here a deployment's start pose opens the watch
//! (in lockstep counted from the last completed tick), the robot's poses go
//! through [`Watch`], a verdict closes the watch and charges the robot's
//! active steps, and the budget rule ends a robot that runs past the time
//! limit. The referee decides; whoever holds it says what happens next.

use crate::gate::{GateParams, Verdict, Watch};
use bycoms_protocol::msg::Pose;

/// How a robot's deployment ended, as the referee saw it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closed {
    /// The robot.
    pub robot: u32,
    /// Its active steps (charged).
    pub steps: u64,
    /// The pose the decision is about.
    pub pose: Pose,
}

/// The gate's watch over the one moving robot, and the budget.
#[derive(Clone, Debug)]
pub struct Referee {
    params: GateParams,
    limit: u64,
    lockstep: bool,
    watch: Option<(u32, Watch)>,
    spent: u64,
}

impl Referee {
    /// A referee with the gate's `params`, a budget of `limit` active steps,
    /// on the lockstep clock or not.
    pub fn new(params: GateParams, limit: u64, lockstep: bool) -> Self {
        Self { params, limit, lockstep, watch: None, spent: 0 }
    }

    /// The robot under watch.
    pub fn watched(&self) -> Option<u32> {
        self.watch.as_ref().map(|(id, _)| *id)
    }

    /// The watched robot's latest pose.
    pub fn last(&self) -> Option<(u32, Pose)> {
        self.watch.as_ref().map(|(id, w)| (*id, w.last()))
    }

    /// Active steps charged so far.
    pub fn spent(&self) -> u64 {
        self.spent
    }

    /// Robot `id`'s start pose: it is deployed and under watch. In lockstep
    /// its periods count from `ticks`, the last completed tick. Returns the
    /// start pose as judged.
    pub fn open(&mut self, id: u32, pose: Pose, ticks: u64) -> Pose {
        let mut start = pose;
        if self.lockstep {
            start.step = ticks;
            start.time_us = ticks * self.params.period_us;
        }
        self.watch = Some((id, Watch::new(self.params, start)));
        start
    }

    /// Robot `id`'s next pose: the verdict, once reached (poses of other
    /// robots are not the referee's business). A pose past the budget gives
    /// none: [`Referee::budget_spent`] ends the robot at the limit. A robot
    /// that stands still when its watch runs past what is left of the
    /// budget is stuck then, whatever is left of the dwell, so the time
    /// limit bounds every run.
    pub fn observe(&mut self, id: u32, pose: Pose) -> Option<Verdict> {
        let (watched, watch) = self.watch.as_mut()?;
        if *watched != id {
            return None;
        }
        let verdict = watch.observe(pose);
        let left = self.limit.saturating_sub(self.spent);
        // A verdict on a pose past the budget is not one: the runner stops
        // at the limit, and the budget rule ends the robot there.
        if watch.active_steps() > left {
            return None;
        }
        if verdict.is_none() && watch.watched_periods() > left {
            return watch.still_at_the_limit();
        }
        verdict
    }

    /// Closes robot `id`'s watch (a verdict acted on, or its death) and
    /// charges its active steps; `None` if it was not under watch.
    pub fn close(&mut self, id: u32) -> Option<Closed> {
        if self.watched() != Some(id) {
            return None;
        }
        let (_, watch) = self.watch.take()?;
        let steps = watch.active_steps();
        self.spent += steps;
        Some(Closed { robot: id, steps, pose: watch.last() })
    }

    /// Whether the budget is used up. With a robot under watch whose active
    /// steps run past what is left, the watch is closed at the limit and the
    /// robot is returned (`Err`): it is unfinished. A robot whose active
    /// steps exactly reach the budget may have stopped on its very last
    /// period (the runner counts it stuck), so it is watched on, without
    /// charge, until it changes pose once more or is judged stopped.
    pub fn budget_spent(&mut self) -> Result<bool, Closed> {
        let Some((id, watch)) = &self.watch else {
            return Ok(self.spent >= self.limit);
        };
        let budget = self.limit.saturating_sub(self.spent);
        let (id, steps) = (*id, watch.active_steps());
        if steps <= budget {
            return Ok(false);
        }
        // One change past the budget: the pose at the limit is the one before.
        let pose = if steps == budget + 1 { watch.previous() } else { watch.last() };
        self.watch = None;
        self.spent += budget;
        Err(Closed { robot: id, steps: budget, pose })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::RobotId;
    use bycoms_sim::Vec2;

    fn params() -> GateParams {
        GateParams {
            goal: Vec2::new(10.0, 0.0),
            goal_radius: 0.5,
            stop_speed: 0.05,
            stop_turn_rate: 0.0,
            dwell_us: 300_000,
            period_us: 100_000,
        }
    }

    fn pose(step: u64, x: f64) -> Pose {
        Pose { robot: RobotId(1), x, y: 0.0, heading: 0.0, step, time_us: step * 100_000 }
    }

    #[test]
    fn lockstep_counts_from_the_last_tick_in_step_and_time() {
        let mut r = Referee::new(params(), 100, true);
        let start = r.open(1, pose(2, 0.0), 7);
        assert_eq!((start.step, start.time_us), (7, 700_000));
        for s in 8..=10 {
            assert_eq!(r.observe(1, pose(s, 0.1 * (s - 7) as f64)), None);
        }
        assert_eq!(r.observe(2, pose(11, 9.9)), None, "not the watched robot");
        let mut verdict = None;
        for s in 11..=14 {
            verdict = verdict.or(r.observe(1, pose(s, 0.1 * 3.0)));
        }
        assert!(matches!(verdict, Some(Verdict::Stuck(_))), "{verdict:?}");
        let closed = r.close(1).expect("watched");
        assert_eq!((closed.steps, r.spent()), (3, 3));
        assert_eq!(r.close(1), None);
    }

    /// Issue 31: `--dwell 1e9` with a time limit watched a robot that had
    /// stopped for ever. Past the budget a still robot is stuck, with the
    /// active steps it had (as the runner counts it).
    #[test]
    fn a_dwell_longer_than_the_run_ends_at_the_time_limit() {
        let params = GateParams { dwell_us: 1_000_000_000_000_000, ..params() };
        let mut r = Referee::new(params, 50, true);
        r.open(1, pose(0, 0.0), 0);
        let mut verdict = None;
        let mut last = 0;
        for s in 1..=10_000 {
            let x = 0.1 * s.min(20) as f64;
            last = s;
            if let Some(v) = r.observe(1, pose(s, x)) {
                verdict = Some(v);
                break;
            }
        }
        assert!(matches!(verdict, Some(Verdict::Stuck(p)) if p.x == 2.0), "{verdict:?}");
        assert_eq!(last, 51, "judged one period past the budget");
        assert_eq!(r.close(1).map(|c| c.steps), Some(20), "its active steps");
    }

    /// Issue 49: with `--stop-speed 0` no robot was ever still, and a
    /// robot that had stopped was watched for ever (1.25 M lockstep ticks
    /// with a time limit of 2000 periods). The time limit ends it in run
    /// time whatever the gate's thresholds: one period past the budget.
    #[test]
    fn the_time_limit_ends_a_still_robot_whatever_the_gate_thresholds() {
        for lockstep in [true, false] {
            let params = GateParams { stop_speed: 0.0, ..params() };
            let mut r = Referee::new(params, 50, lockstep);
            r.open(1, pose(0, 0.0), 0);
            let mut judged = None;
            for s in 1..=10_000 {
                if let Some(v) = r.observe(1, pose(s, 0.1 * s.min(20) as f64)) {
                    judged = Some((s, v));
                    break;
                }
                assert_eq!(r.budget_spent(), Ok(false), "step {s}");
            }
            let (at, verdict) = judged.expect("judged within the run's time");
            assert_eq!(at, 51, "one period past the budget (lockstep {lockstep})");
            assert!(matches!(verdict, Verdict::Stuck(p) if p.x == 2.0), "{verdict:?}");
            assert_eq!(r.close(1).map(|c| c.steps), Some(20), "its active steps");
        }
    }

    #[test]
    fn the_budget_ends_a_robot_at_the_limit() {
        let mut r = Referee::new(params(), 5, false);
        r.open(1, pose(0, 0.0), 0);
        for s in 1..=5 {
            r.observe(1, pose(s, 0.1 * s as f64));
            assert_eq!(r.budget_spent(), Ok(false), "step {s}");
        }
        r.observe(1, pose(6, 0.6));
        let closed = r.budget_spent().expect_err("past the budget");
        assert_eq!((closed.steps, closed.pose.step), (5, 5), "the pose at the limit");
        assert_eq!(r.budget_spent(), Ok(true));
    }
}
