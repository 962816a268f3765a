//! Options shared by the commands that run the simulated world. Their
//! validation (every bad value gets a message naming the option) and the
//! verdict sentence of a run are `bycoms_study::runs`, below the launch and the
//! study, which use them too.

use anyhow::Result;
use bycoms_sim::runner::DEFAULT_SUCCESS_RADIUS;
use bycoms_sim::sensing::NoiseModel;
use bycoms_sim::RunConfig;
use bycoms_study::runs::{check_run, FLAGS};
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
    #[arg(long, default_value_t = DEFAULT_SUCCESS_RADIUS)]
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
