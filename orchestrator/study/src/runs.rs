//! Runs of the simulated world as every command checks and tells them:
//! the one validation of a run's parameters (a usage error naming the value
//! as the user spelled it), the one verdict sentence of a run, and the one
//! message of a terrain file that cannot be read.
//!
//! Why a module of its own, low in the crate: `simulate`, `sweep`, `launch`
//! and the pictures (`draw::trace`) all say these things, and the launch
//! and the study sit below the CLI (ARCHITECTURE.md, "Crates of the
//! orchestrator"). The flags that set a run's parameters stay with the CLI
//! (`commands::world::RunArgs`).

use anyhow::Result;
use bycoms_runtime::exit::usage;
use bycoms_sim::runner::{ConfigError, RobotRunEnd};
use bycoms_sim::terrain::ReadError;
use bycoms_sim::{RunConfig, RunResult};

/// How a command's user spells each run parameter, for its messages: a
/// flag (`--eps`) where only flags set it, a config key with its flag
/// (`eps (--eps)`) where a config file may set it too.
#[derive(Clone, Copy, Debug)]
pub struct RunNames {
    /// ε.
    pub eps: &'static str,
    /// The simulated time limit.
    pub time_limit: &'static str,
    /// The arrival (success) radius.
    pub success_radius: &'static str,
    /// The robot budget.
    pub max_robots: &'static str,
}

/// The flags of `simulate` and `sweep` (`commands::world::RunArgs`).
pub const FLAGS: RunNames = RunNames {
    eps: "--eps",
    time_limit: "--time-limit",
    success_radius: "--success-radius",
    max_robots: "--max-robots",
};

/// The one validation of run parameters, [`RunConfig::validate`] — the very
/// check a `sim-agent` makes — as a usage error (exit code 2) naming the
/// value as `names` spell it. Every command that runs the world
/// (`simulate`, `sweep`, `launch`) goes through it, so a value one accepts
/// none of the others (or an agent) refuses later.
pub fn check_run(cfg: &RunConfig, names: &RunNames) -> Result<()> {
    cfg.validate().map_err(|e| {
        let option = match e {
            ConfigError::Eps(_) => names.eps,
            ConfigError::TimeLimit(_) => names.time_limit,
            ConfigError::SuccessRadius(_) => names.success_radius,
            ConfigError::NoRobots => names.max_robots,
            ConfigError::FieldConstant(_) | ConfigError::Kinematics | ConfigError::Cell(_) => {
                "run parameters"
            }
        };
        usage(format!("bad {option}: {e}"))
    })
}

/// ε must be a positive, finite number of cells with a finite threshold
/// 1/ε² (see [`check_run`]); named `--eps`.
pub fn check_eps(eps: f64) -> Result<()> {
    check_run(&RunConfig::paper(eps), &FLAGS)
}

/// `n` and the noun, singular or plural: "1 robot", "3 robots" (the
/// runtime's one rule, which the doctor of every host shares).
pub use bycoms_runtime::words::count;

/// The one verdict sentence of a run, for `simulate`, `launch` and the
/// pictures alike: "robot 4 arrived after 123.4 s (3 beacons)" and the
/// like. `arrived` is the number of the robot that arrived: not always
/// `robots_used`, since a robot whose agent died before it was deployed
/// keeps its number but is not used.
pub fn verdict(
    outcome: bycoms_sim::RunOutcome,
    robots_used: u32,
    arrived: Option<u32>,
    time_s: f64,
    beacons: usize,
) -> String {
    use bycoms_sim::RunOutcome;
    let beacons = count(beacons as u64, "beacon");
    match outcome {
        RunOutcome::Arrived => {
            let robot = arrived.unwrap_or(robots_used);
            format!("robot {robot} arrived after {time_s:.1} s ({beacons})")
        }
        RunOutcome::RobotsExhausted if robots_used == 1 => {
            format!("the only robot got stuck after {time_s:.1} s")
        }
        RunOutcome::RobotsExhausted => format!("all {robots_used} robots got stuck after {time_s:.1} s"),
        RunOutcome::TimeLimit => format!(
            "no robot arrived within {time_s:.0} s ({}, {beacons})",
            count(u64::from(robots_used), "robot")
        ),
    }
}

/// "robot 4 arrived after 123.4 s (3 beacons)" and the like: the verdict
/// `launch` prints too ([`verdict`]), naming the
/// robot that arrived by its number.
pub fn summary_line(r: &RunResult) -> String {
    let arrived = r.robots.iter().find(|k| k.end == RobotRunEnd::Arrived).map(|k| k.id);
    verdict(r.outcome, r.robots_used, arrived, r.time, r.beacons.len())
}

/// "cannot read terrain file F: …" or "bad terrain file F: line 3, …".
pub fn file_error(path: &std::path::Path, e: ReadError) -> anyhow::Error {
    let what = match e {
        ReadError::Parse(_) => "bad terrain file",
        _ => "cannot read terrain file",
    };
    anyhow::Error::new(e).context(format!("{what} {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_sim::{RunOutcome, Vec2};

    #[test]
    fn the_verdict_counts_in_words() {
        assert_eq!(
            verdict(RunOutcome::Arrived, 3, Some(4), 98.25, 2),
            "robot 4 arrived after 98.2 s (2 beacons)"
        );
        assert_eq!(verdict(RunOutcome::Arrived, 2, None, 5.0, 1), "robot 2 arrived after 5.0 s (1 beacon)");
        assert_eq!(
            verdict(RunOutcome::TimeLimit, 1, None, 60.0, 0),
            "no robot arrived within 60 s (1 robot, 0 beacons)"
        );
        assert_eq!(
            verdict(RunOutcome::RobotsExhausted, 1, None, 7.0, 1),
            "the only robot got stuck after 7.0 s"
        );
        assert_eq!(
            verdict(RunOutcome::RobotsExhausted, 3, None, 7.0, 3),
            "all 3 robots got stuck after 7.0 s"
        );
    }

    fn result(outcome: RunOutcome, robots_used: u32, beacons: usize) -> RunResult {
        RunResult {
            success: outcome == RunOutcome::Arrived,
            outcome,
            steps: 10,
            time: 1.0,
            robots_used,
            beacons: vec![Vec2::new(0.0, 0.0); beacons],
            robots: Vec::new(),
        }
    }

    #[test]
    fn summaries_count_in_words_with_the_right_plural() {
        let cases = [
            (RunOutcome::Arrived, 2, 1, "robot 2 arrived after 1.0 s (1 beacon)"),
            (RunOutcome::Arrived, 1, 0, "robot 1 arrived after 1.0 s (0 beacons)"),
            (RunOutcome::TimeLimit, 1, 0, "no robot arrived within 1 s (1 robot, 0 beacons)"),
            (RunOutcome::TimeLimit, 3, 2, "no robot arrived within 1 s (3 robots, 2 beacons)"),
            (RunOutcome::RobotsExhausted, 1, 1, "the only robot got stuck after 1.0 s"),
            (RunOutcome::RobotsExhausted, 4, 4, "all 4 robots got stuck after 1.0 s"),
        ];
        for (outcome, robots_used, beacons, said) in cases {
            assert_eq!(summary_line(&result(outcome, robots_used, beacons)), said);
        }
    }
}
