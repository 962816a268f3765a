//! Options shared by the commands that run the simulated world, and their
//! validation (every bad value gets a message naming the option).

use anyhow::{bail, Result};
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
        check_eps(self.eps)?;
        if !(self.time_limit.is_finite() && self.time_limit > 0.0) {
            bail!("--time-limit must be a positive number of seconds, got {}", self.time_limit);
        }
        if !(self.success_radius.is_finite() && self.success_radius > 0.0) {
            bail!("--success-radius must be positive, got {}", self.success_radius);
        }
        if self.max_robots == Some(0) {
            bail!("--max-robots must be at least 1");
        }
        let mut cfg = RunConfig::paper(self.eps);
        cfg.noise = self.noise.then(NoiseModel::paper);
        cfg.seed = seed;
        cfg.max_robots = self.max_robots;
        cfg.time_limit = self.time_limit;
        cfg.success_radius = self.success_radius;
        cfg.validate()?;
        Ok(cfg)
    }
}

/// ε must be a positive, finite number of cells.
pub fn check_eps(eps: f64) -> Result<()> {
    if !(eps.is_finite() && eps > 0.0) {
        bail!("ε (--eps) must be a positive number of cells, got {eps}");
    }
    Ok(())
}
