//! `orchestrator simulate`: one in-process run, like one panel of the
//! paper's `fig:sim_result` (or, with `--snapshots`, a strip of moments;
//! with `--animate`, a movie like Movie1/Movie2).
//!
//! The result is printed before any picture is written: a picture that
//! cannot be written is reported (exit 1) after the result, never instead
//! of it.

use crate::commands::world::RunArgs;
use anyhow::Result;
use bycoms_runtime::exit;
use bycoms_runtime::out::{usage_unless_io, writing, Kind, Outputs};
use bycoms_runtime::seconds::Zero;
use bycoms_sim::runner::RobotRunEnd;
use bycoms_sim::terrain::min_path_width;
use bycoms_sim::terrain::Terrain;
use bycoms_sim::{run as run_world, RunConfig, RunOutcome, RunResult, Vec2};
use bycoms_study::draw::{animate, snapshot, timeline};
use bycoms_study::runs::summary_line;
use bycoms_study::scenario::{self, TerrainSource};
use serde::Serialize;
use std::path::PathBuf;

/// One run on a terrain file, a generated terrain or a built-in scenario.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Terrain file in the text format ('#' impassable, '.' free, 'S' start, 'G' goal).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["terrain_seed", "scenario"])]
    pub terrain: Option<PathBuf>,
    /// Generate a Perlin terrain from this seed (the first feasible one of its stream).
    #[arg(long, value_name = "SEED", conflicts_with = "scenario")]
    pub terrain_seed: Option<u64>,
    /// Built-in scenario (used when neither --terrain nor --terrain-seed is given)
    /// [default: long-wall].
    #[arg(long, value_parser = scenario::names())]
    pub scenario: Option<String>,
    /// A lab's arena instead of a terrain (exp-short, exp-long or a lab
    /// scenario file): its room in 2 cm cells, frames and walls grown by a
    /// body's radius, as a mixed swarm's simulated robots run it; --eps and
    /// --success-radius are then in metres, and the picture is the room's.
    #[arg(
        long,
        value_name = "NAME|FILE",
        conflicts_with_all = ["terrain", "terrain_seed", "scenario", "animate"]
    )]
    pub lab_scenario: Option<String>,
    /// With --lab-scenario: the robots' straight-line speed, m/s [default:
    /// 0.22, a TurtleBot 3 Burger's].
    #[arg(long, value_name = "M/S", requires = "lab_scenario", allow_negative_numbers = true)]
    pub robot_speed: Option<f64>,
    /// Run seed of the robots' noise streams, as launch's --seed [default: 0].
    #[arg(long)]
    pub seed: Option<u64>,
    /// The old name of --seed (kept: it is the same number).
    #[arg(long, hide = true, value_name = "SEED")]
    pub noise_seed: Option<u64>,
    #[command(flatten)]
    pub run: RunArgs,
    /// Where to draw the snapshot (SVG).
    #[arg(long, value_name = "FILE", default_value = DEFAULT_SVG)]
    pub svg: PathBuf,
    /// Do not draw the snapshot.
    #[arg(long, conflicts_with_all = ["svg", "snapshots"])]
    pub no_svg: bool,
    /// Draw a strip of moments instead of the end alone: simulated times in
    /// seconds, e.g. "10,60,120" (as the panels of the paper's fig:sim_result).
    #[arg(long, value_name = "T1,T2,…", value_delimiter = ',', num_args = 1..)]
    pub snapshots: Option<Vec<f64>>,
    /// Also write the run as a movie: an animated SVG that loops in a browser.
    #[arg(long, value_name = "FILE")]
    pub animate: Option<PathBuf>,
    /// Length of the movie in seconds (the whole run is fitted into it).
    #[arg(long, value_name = "SECONDS", default_value_t = 20.0, requires = "animate")]
    pub animate_seconds: f64,
    /// Replace --svg and --animate if they are already SVG pictures (never
    /// another kind of file, never the terrain); an SVG picture at the
    /// default simulate.svg is replaced without it.
    #[arg(long)]
    pub force: bool,
    /// Print the result as JSON on stdout, with every robot's trajectory
    /// (the summary goes to stderr).
    #[arg(long)]
    pub json: bool,
}

/// The snapshot's default name: a picture of its own kind there is
/// replaced without `--force` (`bycoms_runtime::out::replaces`), so the README's
/// first commands run twice in one folder.
pub const DEFAULT_SVG: &str = "simulate.svg";

/// One robot in `--json`: how it ended and every position it took.
#[derive(Debug, Serialize)]
pub struct RobotReport<'a> {
    /// 1-based deployment order.
    pub id: u32,
    pub end: RobotRunEnd,
    /// Control periods it was deployed for.
    pub steps: u64,
    /// Where it stopped (or was at the end).
    pub position: Vec2,
    /// Position after each control period (every `dt_s`), starting at the start point.
    pub trajectory: &'a [Vec2],
}

/// What `--json` prints.
#[derive(Debug, Serialize)]
pub struct Report<'a> {
    pub terrain: &'a str,
    pub min_path_width: f64,
    pub eps: f64,
    pub noise: bool,
    pub success: bool,
    pub outcome: RunOutcome,
    pub time_s: f64,
    pub steps: u64,
    pub robots_used: u32,
    pub beacons: &'a [Vec2],
    /// Control period, s (trajectory points are this far apart in time).
    pub dt_s: f64,
    pub robots: Vec<RobotReport<'a>>,
}

/// The terrain and the noise seed of `args`. Issue 49: `--seed` was the
/// terrain generator here and the noise seed in `launch`, so a launch's
/// flags copied to `simulate` ran another world. It is the noise seed in
/// both; the terrain generator is `--terrain-seed`. `--noise-seed`, the old
/// name, still works; with `--seed` as well it was a terrain and a noise
/// seed, and is refused naming the new flag rather than read otherwise.
fn terrain_and_seed(args: &Args) -> Result<(TerrainSource, u64)> {
    if let (Some(seed), Some(noise)) = (args.seed, args.noise_seed) {
        return Err(exit::usage(format!(
            "--seed {seed} with --noise-seed {noise}: --seed is the noise seed now (as in launch); \
             generate a terrain with --terrain-seed {seed} --seed {noise}"
        )));
    }
    let source = match (&args.terrain, args.terrain_seed, &args.scenario) {
        (Some(path), ..) => TerrainSource::File(path.clone()),
        (None, Some(seed), _) => TerrainSource::Generated(seed),
        (None, None, Some(name)) => TerrainSource::Scenario(name.clone()),
        (None, None, None) => {
            if let Some(seed) = args.seed {
                tracing::warn!(
                    "--seed {seed} is the noise seed (as in launch) on the scenario {}; a terrain generated \
                     from seed {seed} (what --seed was before) is --terrain-seed {seed}",
                    scenario::DEFAULT
                );
            }
            TerrainSource::Scenario(scenario::DEFAULT.to_string())
        }
    };
    Ok((source, args.seed.or(args.noise_seed).unwrap_or(0)))
}

/// A lab's arena (`--lab-scenario`): the room the picture draws the run in
/// (its size and frames, on the launch's terrain of whole metres, as a
/// launch in the lab draws it).
struct LabRoom {
    scenario: bycoms_lab::scenario::Scenario,
    drawn_on: Terrain,
}

/// The world of `--lab-scenario NAME` as a mixed swarm's simulated robots
/// run it (`bycoms_launch::lab::mixed_arena`'s cells), the room it is drawn
/// in, and `cfg` set to its cells and the robots' speed.
fn lab_arena(
    name: &str,
    robot_speed: Option<f64>,
    cfg: &mut RunConfig,
) -> Result<(scenario::NamedTerrain, LabRoom)> {
    let scenario = bycoms_lab::process::load_scenario(name).map_err(|e| exit::usage(e.to_string()))?;
    let speed = robot_speed.unwrap_or(bycoms_launch::lab::DEFAULT_SIMULATED_SPEED);
    if !(speed.is_finite() && speed > 0.0) {
        return Err(exit::usage(format!("--robot-speed must be a positive number of m/s, got {speed}")));
    }
    let cell = bycoms_lab::arena::DEFAULT_CELL;
    let terrain = bycoms_lab::arena::terrain(&scenario, cell).map_err(|e| exit::usage(format!("{e:#}")))?;
    (cfg.cell, cfg.kinematics.speed) = (cell, speed);
    let drawn_on = bycoms_launch::lab::world_of(&scenario)?.terrain;
    let named = scenario::NamedTerrain {
        name: format!("lab scenario {} in {} m cells", scenario.name, cell),
        terrain,
    };
    Ok((named, LabRoom { scenario, drawn_on }))
}

pub fn run(args: Args) -> Result<i32> {
    let (source, seed) = terrain_and_seed(&args)?;
    check_picture_args(&args)?;
    let mut cfg = args.run.to_config(seed)?;
    let (world, room) = match &args.lab_scenario {
        Some(name) => lab_arena(name, args.robot_speed, &mut cfg).map(|(w, r)| (w, Some(r)))?,
        None => (scenario::load(&source)?, None),
    };
    cfg.record_trajectories = !args.no_svg || args.animate.is_some() || args.json;
    let result = run_world(&world.terrain, &cfg);
    // In the world's units (cells, or metres in a lab's arena).
    let width = min_path_width(&world.terrain) * cfg.cell;

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
        dt_s: cfg.kinematics.dt,
        robots: result
            .robots
            .iter()
            .map(|r| RobotReport {
                id: r.id,
                end: r.end,
                steps: r.steps,
                position: r.position,
                trajectory: &r.trajectory,
            })
            .collect(),
    };
    let summary = format!(
        "terrain {} (min path width {:.2}), ε = {}, noise {}: {}",
        world.name,
        width,
        cfg.eps,
        if report.noise { "on" } else { "off" },
        summary_line(&result),
    );
    if args.json {
        bycoms_runtime::logging::status_line(&summary);
        bycoms_runtime::outln!("{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        bycoms_runtime::outln!("{summary}")?;
    }
    // Pictures last: the result above is never lost to a picture's error.
    for written in draw_pictures(&args, &world, room.as_ref(), &cfg, &result)? {
        if args.json {
            bycoms_runtime::logging::status_line(&written);
        } else {
            bycoms_runtime::outln!("{written}")?;
        }
    }
    Ok(if result.success { exit::SUCCESS } else { exit::NOT_ARRIVED })
}

/// Picture options that can be checked before the run.
fn check_picture_args(args: &Args) -> Result<()> {
    if let Some(times) = &args.snapshots {
        if let Some(t) = times.iter().find(|t| !(t.is_finite() && **t >= 0.0)) {
            return Err(exit::usage(format!("--snapshots takes simulated times in seconds (≥ 0), got {t}")));
        }
    }
    bycoms_runtime::seconds::check_seconds("--animate-seconds", args.animate_seconds, Zero::Refused)
        .map_err(exit::usage)?;
    // The overwrite rule (`bycoms_runtime::out::files`), before the run.
    let mut rule = Outputs::new(args.force);
    if let Some(terrain) = &args.terrain {
        rule = rule.input(terrain);
    }
    if !args.no_svg {
        rule = rule.default_output("--svg", &args.svg, Kind::Svg, DEFAULT_SVG);
    }
    if let Some(movie) = &args.animate {
        rule = rule.output("--animate", movie, Kind::Svg);
    }
    rule.check().map_err(usage_unless_io)
}

/// Writes the snapshot (or strip) and the movie; returns "snapshot: FILE"
/// lines. A lab's arena is drawn in its `room`, in metres.
fn draw_pictures(
    args: &Args,
    world: &scenario::NamedTerrain,
    room: Option<&LabRoom>,
    cfg: &RunConfig,
    result: &RunResult,
) -> Result<Vec<String>> {
    let line2 = format!(
        "ε = {}, noise {}: {}",
        cfg.eps,
        if cfg.noise.is_some() { "on" } else { "off" },
        summary_line(result)
    );
    let title = [world.name.as_str(), line2.as_str()];
    let (terrain, opts) = match room {
        Some(room) => {
            (&room.drawn_on, snapshot::Options::in_room(snapshot::Unit::Metre, Some(&room.scenario)))
        }
        None => (&world.terrain, snapshot::Options::default()),
    };
    let opts = snapshot::Options { field_constant: cfg.field_constant, ..opts };
    let mut written = Vec::new();
    if !args.no_svg {
        let svg = match &args.snapshots {
            Some(times) => {
                let dt = cfg.kinematics.dt;
                if let Some(t) = times.iter().find(|&&t| timeline::step_of(t, dt) > result.steps) {
                    anyhow::bail!(
                        "--snapshots {t}: the run ended at {:.1} s; no snapshot written to {}",
                        result.time,
                        args.svg.display()
                    );
                }
                let moments: Vec<(u64, String)> = times
                    .iter()
                    .map(|&t| {
                        (timeline::step_of(t, dt), format!("t = {} s", bycoms_study::draw::svg::number(t)))
                    })
                    .collect();
                snapshot::render_strip(terrain, result, cfg.eps, title, &moments, &opts)
            }
            None => snapshot::render_with(terrain, result, cfg.eps, title, &opts),
        };
        let force = bycoms_runtime::out::replaces(args.force, &args.svg, DEFAULT_SVG);
        bycoms_runtime::out::write(&args.svg, Kind::Svg, force, svg.as_bytes())
            .map_err(writing("the snapshot"))?;
        written.push(format!("snapshot: {}", args.svg.display()));
    }
    if let Some(path) = &args.animate {
        let movie = animate::Movie { seconds: args.animate_seconds, field_constant: cfg.field_constant };
        let svg = animate::render(terrain, result, cfg.eps, title, &movie);
        bycoms_runtime::out::write(path, Kind::Svg, args.force, svg.as_bytes())
            .map_err(writing("the animation"))?;
        written.push(format!("animation: {}", path.display()));
    }
    Ok(written)
}
