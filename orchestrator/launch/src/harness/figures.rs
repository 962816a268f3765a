//! Figures of a launch that starts with robots missing (issue 19's
//! measure, printed by `orchestrator bench schedules`).

use super::*;

/// Figures of a launch that starts with robots missing (see
/// [`missing_robots`]).
#[derive(Clone, Debug)]
pub struct MissingFigures {
    /// From robot 1's registration to its deployment, µs.
    pub first_deploy_after_register_us: u64,
    /// The longest wait from one turn (a verdict, or the start) to the next
    /// deployment, per absent robot skipped in it, µs.
    pub longest_wait_per_absent_us: u64,
    /// Robots skipped as absent.
    pub absent: Vec<u32>,
    /// Robots deployed.
    pub deployed: usize,
    /// The launch itself.
    pub report: Report,
}

/// A launch of 50 robots of which 5 never come (robots 2, 4, 6, 8, 10)
/// and 5 die before they register (robots 3, 5, 7, 9, 11; processes
/// started here die twice, as the one restart they get dies too), with
/// remote agents or agents spawned here, and its figures.
pub fn missing_robots(remote: bool) -> MissingFigures {
    let mut case = Case::small(0);
    case.robots = 50;
    case.time_limit = 1000.0;
    let mut schedule = Schedule::clean(0, case.robots);
    schedule.remote = remote;
    for id in [2usize, 4, 6, 8, 10] {
        schedule.register_delay_us[id - 1] = None;
    }
    for id in [3usize, 5, 7, 9, 11] {
        schedule.early_deaths[id - 1] = if remote { 1 } else { 2 };
    }
    let report = run(&case, &schedule);
    let absent: Vec<u32> =
        (1..=case.robots).filter(|&id| report.robots[id as usize - 1].0 == SlotState::Absent).collect();
    let deployed_at = |id: u32| {
        report
            .gates
            .iter()
            .zip(&report.gate_times_us)
            .find(|(g, _)| g.robot.0 == id && g.kind == GateKind::Deployed)
            .map(|(_, &t)| t)
    };
    let registered = report.registered_us.first().copied().flatten().unwrap_or(0);
    let first_deploy_after_register_us = deployed_at(1).map_or(u64::MAX, |t| t.saturating_sub(registered));
    // Each deployment after the first: the wait since the last verdict,
    // shared among the absent robots skipped in between.
    let mut longest = 0;
    let mut turn_at = 0;
    let mut last_deployed = 0;
    for (g, &t) in report.gates.iter().zip(&report.gate_times_us) {
        if g.kind == GateKind::Deployed {
            let skipped = absent.iter().filter(|&&a| a > last_deployed && a < g.robot.0).count() as u64;
            longest = longest.max(t.saturating_sub(turn_at) / skipped.max(1));
            last_deployed = g.robot.0;
        } else {
            turn_at = t;
        }
    }
    let deployed = report.gates.iter().filter(|g| g.kind == GateKind::Deployed).count();
    MissingFigures {
        first_deploy_after_register_us,
        longest_wait_per_absent_us: longest,
        absent,
        deployed,
        report,
    }
}
