//! `orchestrator draw FILE.mcap`: a recorded launch as the snapshot picture
//! (terrain, start, goal, every robot's trajectory and number, beacons with
//! their ε circles, potential contours), so anyone can see a run without
//! Foxglove. Terrain, start, goal and ε come from the recording's run
//! metadata channel, trajectories from the recorded poses, beacons from the
//! gate decisions (`draw::run`, `draw::trace`).

use anyhow::{Context, Result};
use bycoms_runtime::exit::usage;
use bycoms_runtime::out::{usage_unless_io, writing, Kind, Outputs};
use bycoms_sim::terrain::parse;
use bycoms_sim::RunConfig;
use bycoms_study::draw::run::read_run;
use bycoms_study::draw::snapshot::{Options, Unit};
use bycoms_study::draw::trace::picture_in;
use std::path::PathBuf;

/// Draw a recorded launch (`launch --record FILE.mcap`) as an SVG snapshot.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The recording (a finished one, or one cut short by a crash).
    #[arg(value_name = "FILE.mcap")]
    pub file: PathBuf,
    /// Where to write the picture [default: FILE with the extension .svg].
    #[arg(long, value_name = "FILE.svg")]
    pub out: Option<PathBuf>,
    /// Draw the measurements instead (like the paper's fig:bag_3robots):
    /// each robot's positions in its own colour, the goal, and the measured
    /// gradient as arrows whose length is V_ave (real robots' telemetry).
    #[arg(long)]
    pub measurements: bool,
    /// Replace --out if it is already an SVG picture (never anything else, never FILE itself;
    /// FILE.svg, the default, is replaced without it).
    #[arg(long)]
    pub force: bool,
}

/// Where the picture goes: --out, or FILE with the extension .svg.
fn out_path(args: &Args) -> PathBuf {
    args.out.clone().unwrap_or_else(|| default_out(args))
}

/// The picture's default name: FILE with the extension .svg. A picture
/// there is this command's own, replaced without --force
/// (`bycoms_runtime::out::replaces`), so drawing a recording twice works.
fn default_out(args: &Args) -> PathBuf {
    args.file.with_extension("svg")
}

pub fn run(args: Args) -> Result<i32> {
    // Refused before anything is read: the picture never replaces the recording or another file.
    Outputs::new(args.force)
        .input(&args.file)
        .default_output("--out", out_path(&args), Kind::Svg, &default_out(&args).to_string_lossy())
        .check()
        .map_err(usage_unless_io)?;
    let run = read_run(&args.file)?;
    let meta = run.meta.ok_or_else(|| {
        anyhow::anyhow!("the run metadata of {} (bycoms/<swarm>/run) does not parse", args.file.display())
    })?;
    if args.measurements {
        if !run.measurements.has_telemetry() {
            tracing::warn!(
                "{} holds no robot telemetry (simulated agents send none): drawing positions only",
                args.file.display()
            );
        }
        let swarm = meta.swarm.as_deref().unwrap_or("?");
        let title = format!("{} — measurements, swarm {swarm}", meta.terrain);
        let room = lab_room(&meta.config);
        let svg = run.measurements.picture_in(meta.goal, &title, room.as_ref());
        return write(&args, &svg);
    }
    let text = meta.terrain_text.as_deref().ok_or_else(|| {
        usage(format!(
            "{} records no terrain (made by an older orchestrator); it cannot be drawn",
            args.file.display()
        ))
    })?;
    let mut terrain =
        parse(text).with_context(|| format!("the terrain recorded in {}", args.file.display()))?;
    terrain.set_start(meta.start);
    terrain.set_goal(meta.goal);
    let eps = meta.eps().context("the recorded configuration has no ε")?;
    if let Some(why) = &run.stopped_by {
        tracing::warn!("{} ends early ({why}); drawing what it holds", args.file.display());
    }
    if run.trace.is_empty() {
        tracing::warn!("{} holds no pose: drawing the arena only", args.file.display());
    }
    let dt = RunConfig::paper(eps).kinematics.dt;
    let swarm = meta.swarm.as_deref().unwrap_or("?");
    let heading = format!("{} — ε = {eps}, {} launch, swarm {swarm}", meta.terrain, meta.clock());
    let unit = unit_of(&meta.config);
    let room = if unit == Unit::Metre { lab_room(&meta.config) } else { None };
    let opts = Options { real: &meta.real, ..Options::in_room(unit, room.as_ref()) };
    let svg = picture_in(&terrain, &run.trace, eps, dt, &heading, &opts);
    write(&args, &svg)
}

/// The lab scenario of a run of real robots (its room, frames and start),
/// if the recording names one that can be loaded here.
fn lab_room(config: &serde_json::Value) -> Option<bycoms_lab::scenario::Scenario> {
    let name = config["agents"]["scenario"].as_str()?;
    match bycoms_lab::process::load_scenario(name) {
        Ok(scenario) => Some(scenario),
        Err(e) => {
            tracing::warn!(
                "cannot load the lab scenario {name:?} the recording names ({e}): drawing no room"
            );
            None
        }
    }
}

/// Metres for a run of real robots (a lab: `agents.source = "real"`), else
/// cells.
fn unit_of(config: &serde_json::Value) -> Unit {
    match config["agents"]["source"].as_str() {
        Some("real") => Unit::Metre,
        _ => Unit::Cell,
    }
}

fn write(args: &Args, svg: &str) -> Result<i32> {
    let out = out_path(args);
    let force = bycoms_runtime::out::replaces(args.force, &out, &default_out(args).to_string_lossy());
    bycoms_runtime::out::write(&out, Kind::Svg, force, svg.as_bytes()).map_err(writing("the picture"))?;
    bycoms_runtime::outln!("picture: {}", out.display())?;
    Ok(bycoms_runtime::exit::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recording_of_real_robots_is_drawn_in_metres() {
        let lab = serde_json::json!({ "eps": 3.0, "agents": { "source": "real", "scenario": "exp-short" } });
        assert_eq!(unit_of(&lab), Unit::Metre);
        assert_eq!(
            unit_of(&serde_json::json!({ "eps": 3.0, "agents": { "source": "spawned" } })),
            Unit::Cell
        );
        assert_eq!(unit_of(&serde_json::json!({ "eps": 3.0 })), Unit::Cell, "older recordings");
    }
}
