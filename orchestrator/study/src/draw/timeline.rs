//! Where everything was at a given control period of a run, from its
//! recorded trajectories — what the strip of moments (`--snapshots`) and
//! the animation (`--animate`) draw.
//!
//! Robots are deployed one at a time: robot k starts at the period where
//! robot k − 1 ended (the runner's global step counter), and its
//! trajectory holds its position after each of its own periods, starting
//! with the start point. So the state at step s needs no re-simulation.

use bycoms_sim::runner::{RobotRunEnd, RunResult};
use bycoms_sim::Vec2;

/// A robot as it was at one step.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotAt {
    /// 1-based deployment order.
    pub id: u32,
    pub position: Vec2,
    /// Stuck by then (a beacon).
    pub stuck: bool,
    /// Arrived by then.
    pub arrived: bool,
    /// How many points of its trajectory it had walked (at least 1).
    pub trail: usize,
}

/// The global step at which each robot was deployed.
pub fn first_steps(result: &RunResult) -> Vec<u64> {
    let mut at = 0;
    result
        .robots
        .iter()
        .map(|r| {
            let first = at;
            at += r.steps;
            first
        })
        .collect()
}

/// The robots deployed by global step `step` (all of them at or after the
/// run's end), with where they were then. Needs recorded trajectories.
pub fn robots_at(result: &RunResult, step: u64) -> Vec<RobotAt> {
    // A robot starts at the step its predecessor ended: at that very step
    // the predecessor is shown stopped and this one at the start.
    result
        .robots
        .iter()
        .zip(first_steps(result))
        .filter(|&(_, first)| step >= first)
        .map(|(r, first)| {
            let walked = (step - first).min(r.steps);
            let index = (walked as usize).min(r.trajectory.len().saturating_sub(1));
            let done = walked == r.steps;
            RobotAt {
                id: r.id,
                position: r.trajectory.get(index).copied().unwrap_or(r.position),
                stuck: done && r.end == RobotRunEnd::Stuck,
                arrived: done && r.end == RobotRunEnd::Arrived,
                trail: index + 1,
            }
        })
        .collect()
}

/// The step nearest to `seconds` of simulated time, with the control period `dt`.
pub fn step_of(seconds: f64, dt: f64) -> u64 {
    (seconds / dt).round().max(0.0) as u64
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_sim::runner::{RobotRun, RunOutcome};

    fn line(n: u64, x0: f64) -> Vec<Vec2> {
        (0..=n).map(|i| Vec2::new(x0 + i as f64, 0.0)).collect()
    }

    fn two_robots() -> RunResult {
        RunResult {
            success: true,
            outcome: RunOutcome::Arrived,
            steps: 5,
            time: 0.5,
            robots_used: 2,
            beacons: vec![Vec2::new(2.0, 0.0)],
            robots: vec![
                RobotRun {
                    id: 1,
                    end: RobotRunEnd::Stuck,
                    position: Vec2::new(2.0, 0.0),
                    steps: 2,
                    trajectory: line(2, 0.0),
                },
                RobotRun {
                    id: 2,
                    end: RobotRunEnd::Arrived,
                    position: Vec2::new(3.0, 0.0),
                    steps: 3,
                    trajectory: line(3, 0.0),
                },
            ],
        }
    }

    #[test]
    fn robots_appear_in_turn_and_stop_where_they_ended() {
        let r = two_robots();
        assert_eq!(first_steps(&r), vec![0, 2]);
        let at0 = robots_at(&r, 0);
        assert_eq!(at0.len(), 1);
        assert_eq!((at0[0].position, at0[0].stuck, at0[0].trail), (Vec2::new(0.0, 0.0), false, 1));
        let at2 = robots_at(&r, 2);
        assert_eq!(at2.len(), 2);
        assert!(at2[0].stuck && at2[0].position == Vec2::new(2.0, 0.0));
        assert_eq!((at2[1].position, at2[1].trail), (Vec2::new(0.0, 0.0), 1));
        let at4 = robots_at(&r, 4);
        assert_eq!((at4[1].position, at4[1].arrived), (Vec2::new(2.0, 0.0), false));
        let end = robots_at(&r, 99);
        assert!(end[1].arrived && end[1].position == Vec2::new(3.0, 0.0) && end[1].trail == 4);
        assert_eq!(step_of(0.25, 0.1), 3);
    }
}
