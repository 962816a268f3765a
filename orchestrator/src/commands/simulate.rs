//! `orchestrator simulate`: one in-process run, like one panel of the
//! paper's `fig:sim_result`.

use crate::commands::world::RunArgs;
use crate::draw::snapshot;
use crate::exit;
use crate::scenario::{self, WorldSource};
use anyhow::{Context, Result};
use bycoms_sim::terrain::min_path_width;
use bycoms_sim::{run as run_world, Outcome, RunResult, Vec2};
use serde::Serialize;
use std::path::PathBuf;

/// One run on a terrain file, a generated terrain or a built-in scenario.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Terrain file in the text format ('#' impassable, '.' free, 'S' start, 'G' goal).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["seed", "scenario"])]
    pub terrain: Option<PathBuf>,
    /// Generate a Perlin terrain from this seed (the first feasible one of its stream).
    #[arg(long, conflicts_with = "scenario")]
    pub seed: Option<u64>,
    /// Built-in scenario (used when neither --terrain nor --seed is given).
    #[arg(long, default_value = scenario::DEFAULT, value_parser = scenario::names())]
    pub scenario: String,
    /// Seed of the sensing noise (default: --seed, or 0).
    #[arg(long)]
    pub noise_seed: Option<u64>,
    #[command(flatten)]
    pub run: RunArgs,
    /// Where to draw the snapshot (SVG).
    #[arg(long, value_name = "FILE", default_value = "simulate.svg")]
    pub svg: PathBuf,
    /// Do not draw the snapshot.
    #[arg(long, conflicts_with = "svg")]
    pub no_svg: bool,
    /// Print the result as JSON on stdout (the summary goes to stderr).
    #[arg(long)]
    pub json: bool,
}

/// What `--json` prints.
#[derive(Debug, Serialize)]
pub struct Report<'a> {
    pub terrain: &'a str,
    pub min_path_width: f64,
    pub eps: f64,
    pub noise: bool,
    pub success: bool,
    pub outcome: Outcome,
    pub time_s: f64,
    pub steps: u64,
    pub robots_used: u32,
    pub beacons: &'a [Vec2],
}

pub fn run(args: Args) -> Result<i32> {
    let source = match (&args.terrain, args.seed) {
        (Some(path), _) => WorldSource::File(path.clone()),
        (None, Some(seed)) => WorldSource::Generated(seed),
        (None, None) => WorldSource::Scenario(args.scenario.clone()),
    };
    let world = scenario::load(&source)?;
    let seed = args.noise_seed.or(args.seed).unwrap_or(0);
    let mut cfg = args.run.to_config(seed)?;
    cfg.record_trajectories = !args.no_svg;
    if !args.no_svg {
        // Fail before the run, not after it, if the picture cannot be written.
        std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&args.svg)
            .with_context(|| format!("cannot write the snapshot to {}", args.svg.display()))?;
    }
    let result = run_world(&world.terrain, &cfg);
    let width = min_path_width(&world.terrain);

    if !args.no_svg {
        let line2 = format!(
            "ε = {}, noise {}: {}",
            cfg.eps,
            if cfg.noise.is_some() { "on" } else { "off" },
            summary_line(&result)
        );
        let svg = snapshot::render(&world.terrain, &result, cfg.eps, [&world.name, &line2]);
        std::fs::write(&args.svg, svg)
            .with_context(|| format!("cannot write the snapshot to {}", args.svg.display()))?;
    }
    let report = Report {
        terrain: &world.name,
        min_path_width: width,
        eps: cfg.eps,
        noise: cfg.noise.is_some(),
        success: result.success,
        outcome: result.outcome,
        time_s: result.time,
        steps: result.steps,
        robots_used: result.robots_used,
        beacons: &result.beacons,
    };
    let summary = format!(
        "terrain {} (min path width {:.2}), ε = {}, noise {}: {}{}",
        world.name,
        width,
        cfg.eps,
        if report.noise { "on" } else { "off" },
        summary_line(&result),
        if args.no_svg { String::new() } else { format!("\nsnapshot: {}", args.svg.display()) }
    );
    if args.json {
        bycoms_logging::status_line(&summary);
        crate::outln!("{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        crate::outln!("{summary}")?;
    }
    Ok(if result.success { exit::SUCCESS } else { exit::NOT_ARRIVED })
}

/// "robot 4 arrived after 123.4 s (3 beacons)" and the like.
pub fn summary_line(r: &RunResult) -> String {
    let beacons = r.beacons.len();
    match r.outcome {
        Outcome::Arrived => format!(
            "robot {} arrived after {:.1} s ({} beacon{})",
            r.robots_used,
            r.time,
            beacons,
            if beacons == 1 { "" } else { "s" }
        ),
        Outcome::TimeLimit => {
            format!("no robot arrived within {:.0} s ({} robots, {} beacons)", r.time, r.robots_used, beacons)
        }
        Outcome::RobotsExhausted => {
            format!("all {} robots got stuck after {:.1} s", r.robots_used, r.time)
        }
    }
}
