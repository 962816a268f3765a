//! Options shared by the commands that run the simulated world, and their
//! validation (every bad value gets a message naming the option).

use crate::exit::usage;
use anyhow::Result;
use bycoms_sim::runner::ConfigError;
use bycoms_sim::sensing::NoiseModel;
use bycoms_sim::RunConfig;
use clap::Args as ClapArgs;

/// Run parameters of the simulated world.
#[derive(Debug, Clone, ClapArgs)]
pub struct RunArgs {
    /// Circumferential radius ε in cells (threshold g_th = 1/ε²).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub eps: f64,
    /// Add the paper's sensing noise (g × U(0.8, 1.2), gradient + U(−π/6, π/6)).
    #[arg(long)]
    pub noise: bool,
    /// Deploy at most this many robots (default: until the time limit).
    #[arg(long, value_name = "N")]
    pub max_robots: Option<u32>,
    /// Simulated time limit of the run, seconds.
    #[arg(long, default_value_t = 10_000.0, value_name = "SECONDS", allow_negative_numbers = true)]
    pub time_limit: f64,
    /// A robot this close to the goal has arrived (robot radius).
    #[arg(long, default_value_t = 0.5)]
    pub success_radius: f64,
}

impl RunArgs {
    /// The run configuration, or a clear error for a bad value.
    pub fn to_config(&self, seed: u64) -> Result<RunConfig> {
        let mut cfg = RunConfig::paper(self.eps);
        cfg.noise = self.noise.then(NoiseModel::paper);
        cfg.seed = seed;
        cfg.max_robots = self.max_robots;
        cfg.time_limit = self.time_limit;
        cfg.success_radius = self.success_radius;
        check_run(&cfg, &FLAGS)?;
        Ok(cfg)
    }
}

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

/// The flags of `simulate` and `sweep` ([`RunArgs`]).
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
            ConfigError::FieldConstant(_) | ConfigError::Kinematics => "run parameters",
        };
        usage(format!("bad {option}: {e}"))
    })
}

/// ε must be a positive, finite number of cells with a finite threshold
/// 1/ε² (see [`check_run`]); named `--eps`.
pub fn check_eps(eps: f64) -> Result<()> {
    check_run(&RunConfig::paper(eps), &FLAGS)
}

/// `n` and the noun, singular or plural: "1 robot", "3 robots".
pub fn count(n: u64, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// The one verdict sentence of a run, for `simulate`, `launch` and the
/// pictures alike: "robot 4 arrived after 123.4 s (3 beacons)" and the
/// like. `arrived` is the number of the robot that arrived: not always
/// `robots_used`, since a robot whose agent died before it was deployed
/// keeps its number but is not used.
pub fn verdict(
    outcome: bycoms_sim::Outcome,
    robots_used: u32,
    arrived: Option<u32>,
    time_s: f64,
    beacons: usize,
) -> String {
    use bycoms_sim::Outcome;
    let beacons = count(beacons as u64, "beacon");
    match outcome {
        Outcome::Arrived => {
            let robot = arrived.unwrap_or(robots_used);
            format!("robot {robot} arrived after {time_s:.1} s ({beacons})")
        }
        Outcome::RobotsExhausted if robots_used == 1 => {
            format!("the only robot got stuck after {time_s:.1} s")
        }
        Outcome::RobotsExhausted => format!("all {robots_used} robots got stuck after {time_s:.1} s"),
        Outcome::TimeLimit => format!(
            "no robot arrived within {time_s:.0} s ({}, {beacons})",
            count(u64::from(robots_used), "robot")
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_sim::Outcome;

    #[test]
    fn the_verdict_counts_in_words() {
        assert_eq!(
            verdict(Outcome::Arrived, 3, Some(4), 98.25, 2),
            "robot 4 arrived after 98.2 s (2 beacons)"
        );
        assert_eq!(verdict(Outcome::Arrived, 2, None, 5.0, 1), "robot 2 arrived after 5.0 s (1 beacon)");
        assert_eq!(
            verdict(Outcome::TimeLimit, 1, None, 60.0, 0),
            "no robot arrived within 60 s (1 robot, 0 beacons)"
        );
        assert_eq!(
            verdict(Outcome::RobotsExhausted, 1, None, 7.0, 1),
            "the only robot got stuck after 7.0 s"
        );
        assert_eq!(verdict(Outcome::RobotsExhausted, 3, None, 7.0, 3), "all 3 robots got stuck after 7.0 s");
    }
}
