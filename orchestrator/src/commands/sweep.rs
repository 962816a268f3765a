//! `orchestrator sweep`: the paper's simulation study (§V), resumable and
//! shardable. See `bycoms_study::sweep` for how the pieces fit.

use anyhow::{bail, Context, Result};
use bycoms_runtime::exit;
use bycoms_sim::terrain::WidthModel;
use bycoms_sim::RunConfig;
use bycoms_study::sweep::budget;
use bycoms_study::sweep::execute::{execute, Executed, Job};
use bycoms_study::sweep::plan::{parse_axis, Axes, Shard};
use bycoms_study::sweep::rows::{Row, RowWriter};
use bycoms_study::sweep::table::{tabulate, to_text, write_outputs};
use bycoms_study::sweep::terrains::{generate_bins, load_bins, SweepTerrain};
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// ε × width bin × terrains × noise; writes runs CSV, tables and heatmaps.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Circumferential radii ε: a list "1,2,3" or a range "start:end:step".
    #[arg(long, default_value = "1:5:0.5", allow_hyphen_values = true)]
    pub eps: String,
    /// Width bins (bin w holds w ≤ width < w + 0.5): list or range.
    #[arg(long, default_value = "1:5:0.5")]
    pub widths: String,
    /// Terrains per width bin.
    #[arg(long, default_value_t = 100)]
    pub terrains_per_bin: usize,
    /// Noise settings to run.
    #[arg(long, value_enum, default_value = "both")]
    pub noise: NoiseAxis,
    /// Seed of terrain generation and of the sensing noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Use the *.txt terrains of this directory (binned by their measured width) instead of generating.
    #[arg(long, value_name = "DIR")]
    pub terrains: Option<PathBuf>,
    /// Output directory (created if needed); rerunning into it resumes.
    #[arg(long, value_name = "DIR", default_value = "sweep-out")]
    pub out: PathBuf,
    /// Run only shard i of n (0-based, e.g. 0/4); combine the parts with `orchestrator merge`.
    #[arg(long, value_name = "i/n")]
    pub shard: Option<Shard>,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    pub jobs: Option<u16>,
    /// Robots per run (default: until the time limit).
    #[arg(long, value_name = "N")]
    pub max_robots: Option<u32>,
    /// Simulated time limit per run, seconds.
    #[arg(long, default_value_t = 10_000.0, value_name = "SECONDS")]
    pub time_limit: f64,
    /// Give up generating terrains after this many candidates.
    #[arg(long, default_value_t = 2_000_000)]
    pub max_candidates: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum NoiseAxis {
    Off,
    On,
    Both,
}

/// The sweep's identity, kept in `sweep.json`: a rerun (or another shard
/// writing to the same directory) must match it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Meta {
    /// Format of this file and of the rows (bumped when results would change).
    pub format: String,
    /// How terrain widths were measured.
    pub width_model: WidthModel,
    pub axes: Axes,
    pub seed: u64,
    pub terrains: Option<PathBuf>,
    pub max_robots: Option<u32>,
    pub time_limit: f64,
}

pub const META_FILE: &str = "sweep.json";

/// Current value of [`Meta::format`].
pub const FORMAT: &str = "bycoms-sweep/1";

/// Name of a shard's runs CSV.
pub fn runs_file(shard: Shard) -> String {
    if shard.is_whole() {
        "runs.csv".to_owned()
    } else {
        format!("runs-shard-{}-of-{}.csv", shard.index, shard.count)
    }
}

/// A bad option value: exit code 2 (see `bycoms_runtime::exit`).
fn usage(e: impl std::fmt::Display) -> anyhow::Error {
    exit::usage(format!("{e:#}"))
}

/// Why a runs file's row `k` (run `index`) does not belong to a sweep that
/// plans the runs `planned`, in words ("expected run 1 of this plan", not
/// `Some(1)`).
fn foreign_row(path: &Path, k: usize, index: usize, planned: &[usize]) -> String {
    let expected = match planned.get(k) {
        Some(run) if *run == index => format!("run {run} with other parameters than this plan's"),
        Some(run) => format!("expected run {run} of this plan"),
        None => format!("this plan has only {}", bycoms_study::runs::count(planned.len() as u64, "run")),
    };
    format!(
        "{} does not belong to this sweep (row {} is run {index}, {expected}); use another --out",
        path.display(),
        k + 2
    )
}

pub fn run(args: Args) -> Result<i32> {
    let started = Instant::now();
    let (axes, base, meta) = plan(&args)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    check_meta(&args.out, &meta)?;
    let stop_handle = bycoms_launch::interrupt_flag();
    let stop: &AtomicBool = &stop_handle;
    stop.store(false, Ordering::SeqCst);

    let terrains = match load_terrains(&args, &axes, stop) {
        Err(_) if stop.load(Ordering::SeqCst) => {
            tracing::warn!("interrupted while preparing terrains; nothing was run");
            return Ok(exit::INTERRUPTED);
        }
        other => other?,
    };
    // Only now, with terrains in hand, does the directory become this sweep's.
    write_meta(&args.out, &meta)?;
    write_terrain_list(&args.out, &axes, &terrains)?;

    let shard = args.shard.unwrap_or(Shard::WHOLE);
    let runs_path = args.out.join(runs_file(shard));
    let (mut writer, done) = RowWriter::open(&runs_path)?;
    let planned: Vec<usize> = shard.runs(axes.total_runs()).collect();
    let job = Job { axes: &axes, terrains: &terrains, base, seed: args.seed };
    check_resumed(&runs_path, &done, &planned, &job)?;
    let bar = progress_bar(planned.len(), done.len());
    let threads =
        args.jobs.map_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()), usize::from);
    let runs_started = Instant::now();
    let executed = execute(&job, &planned[done.len()..], &mut writer, threads, &bar, stop)?;
    bar.finish_and_clear();
    drop(writer);
    let kept = done.len() + executed.rows;
    // Printed last (after the tables, which `merge` prints the same).
    let speed = speed_line(executed, threads, runs_started.elapsed(), started.elapsed());
    conclude(&args, &axes, shard, &runs_path, (kept, planned.len()), &speed)
}

/// The sweep's axes, the base of its runs, and the metadata its directory
/// must match, from the flags (each checked, naming the flag).
fn plan(args: &Args) -> Result<(Axes, RunConfig, Meta)> {
    let axes = Axes {
        eps: parse_axis(&args.eps).context("--eps").map_err(usage)?,
        widths: parse_axis(&args.widths).context("--widths").map_err(usage)?,
        terrains_per_bin: args.terrains_per_bin,
        noise: match args.noise {
            NoiseAxis::Off => vec![false],
            NoiseAxis::On => vec![true],
            NoiseAxis::Both => vec![false, true],
        },
    };
    axes.validate().map_err(usage)?;
    // The run parameters' one check (`bycoms_study::runs::check_run`), as `simulate` makes it.
    let mut base = RunConfig::paper(1.0);
    base.time_limit = args.time_limit;
    base.max_robots = args.max_robots;
    bycoms_study::runs::check_run(&base, &bycoms_study::runs::FLAGS)?;
    let meta = Meta {
        format: FORMAT.to_owned(),
        width_model: WidthModel::default(),
        axes: axes.clone(),
        seed: args.seed,
        terrains: args.terrains.clone(),
        max_robots: args.max_robots,
        time_limit: args.time_limit,
    };
    Ok((axes, base, meta))
}

/// The rows already in the runs file are this plan's first runs, made by
/// `job` (a resumed sweep), or the file is another sweep's: an error.
fn check_resumed(runs_path: &Path, done: &[Row], planned: &[usize], job: &Job<'_>) -> Result<()> {
    for (k, row) in done.iter().enumerate() {
        if planned.get(k) != Some(&row.index) || !job.matches(row) {
            bail!("{}", foreign_row(runs_path, k, row.index, planned));
        }
    }
    if !done.is_empty() {
        tracing::info!(
            "resuming: {} of {} runs already in {}",
            done.len(),
            planned.len(),
            runs_path.display()
        );
    }
    Ok(())
}

/// The progress bar of `planned` runs, `done` of them done already.
fn progress_bar(planned: usize, done: usize) -> ProgressBar {
    let bar = ProgressBar::new(planned as u64).with_position(done as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} runs, {msg}, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// What the sweep says at its end, `kept` of `planned` runs in the runs
/// file: interrupted (run it again to resume), a shard done (merge the
/// shards), or the whole study (its tables written and printed).
fn conclude(
    args: &Args,
    axes: &Axes,
    shard: Shard,
    runs_path: &Path,
    (kept, planned): (usize, usize),
    speed: &str,
) -> Result<i32> {
    if kept < planned {
        tracing::warn!(
            "interrupted: {kept} of {planned} runs kept in {}; run the same command again to resume",
            runs_path.display()
        );
        bycoms_runtime::outln!("{speed}")?;
        return Ok(exit::INTERRUPTED);
    }
    if !shard.is_whole() {
        bycoms_runtime::outln!(
            "shard {}/{} done: {planned} runs in {}; combine the shards with `orchestrator merge`",
            shard.index,
            shard.count,
            runs_path.display()
        )?;
        bycoms_runtime::outln!("{speed}")?;
        return Ok(exit::SUCCESS);
    }
    let rows = bycoms_study::sweep::rows::read_rows(runs_path)?;
    let files = report(&args.out, axes, &rows, args.max_robots)?;
    bycoms_runtime::outln!("{} runs in {}", rows.len(), runs_path.display())?;
    for f in files {
        bycoms_runtime::outln!("wrote {}", f.display())?;
    }
    bycoms_runtime::outln!("{speed}")?;
    Ok(exit::SUCCESS)
}

/// Writes the study's tables and robot budgets as files into `out`, then
/// prints them (for `sweep` and `merge`); returns the files written. Every
/// file first: a stdout that fails (`sweep > /dev/full`) loses none of them.
pub fn report(out: &Path, axes: &Axes, rows: &[Row], max_robots: Option<u32>) -> Result<Vec<PathBuf>> {
    let tables = tabulate(axes, rows);
    let budgets = budget::tabulate(axes, rows, max_robots);
    let mut files = write_outputs(out, axes, &tables)?;
    files.extend(budget::write_outputs(out, axes, &budgets)?);
    for t in &tables {
        bycoms_runtime::outln!("{}", to_text(axes, t))?;
    }
    for t in &budgets {
        bycoms_runtime::outln!("{}", budget::to_text(axes, t))?;
    }
    Ok(files)
}

/// The sweep's speed: robot-steps (control periods) simulated, wall time of
/// the runs and of the whole command (terrains included), robot-steps per
/// second and ns per robot-step per worker thread.
fn speed_line(executed: Executed, threads: usize, runs: Duration, total: Duration) -> String {
    let secs = runs.as_secs_f64();
    let per_second = if secs > 0.0 { executed.robot_steps as f64 / secs } else { 0.0 };
    let ns_per_step = if executed.robot_steps > 0 {
        secs * 1e9 * threads as f64 / executed.robot_steps as f64
    } else {
        0.0
    };
    format!(
        "ran {} runs, {} robot-steps in {:.1} s ({:.1} s with terrains), {} threads: \
         {:.1} M robot-steps/s, {:.1} ns per robot-step per thread",
        executed.rows,
        executed.robot_steps,
        secs,
        total.as_secs_f64(),
        threads,
        per_second / 1e6,
        ns_per_step
    )
}

/// Errors if `out` already holds a different sweep.
fn check_meta(out: &Path, meta: &Meta) -> Result<()> {
    let path = out.join(META_FILE);
    if !path.exists() {
        return Ok(());
    }
    let text = bycoms_study::sweep::read_text(&path)?;
    let same = serde_json::from_str::<Meta>(&text).is_ok_and(|old| old == *meta);
    // A directory whose sweep never wrote a row may be reused freely.
    let has_rows = std::fs::read_dir(out)
        .with_context(|| format!("cannot read {}", out.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("runs")))
        .any(|p| bycoms_study::sweep::rows::read_rows(&p).map_or(true, |rows| !rows.is_empty()));
    if !same && has_rows {
        bail!(
            "{} holds a different sweep ({}); use another --out or delete it",
            out.display(),
            path.display()
        );
    }
    Ok(())
}

/// Records the sweep's identity (atomically: shards may start together).
fn write_meta(out: &Path, meta: &Meta) -> Result<()> {
    let text = serde_json::to_string_pretty(meta)? + "\n";
    bycoms_study::sweep::rows::write_atomic(&out.join(META_FILE), text.as_bytes())
}

fn load_terrains(args: &Args, axes: &Axes, stop: &AtomicBool) -> Result<Vec<Vec<SweepTerrain>>> {
    let per_bin = axes.terrains_per_bin;
    let bins = match &args.terrains {
        Some(dir) => {
            let loaded = load_bins(dir, &axes.widths, per_bin)?;
            if let Some(text) = loaded.outside_text(dir) {
                tracing::warn!("{text}");
            }
            if loaded.extra > 0 {
                tracing::info!(
                    "{} of {} not used: their bins already hold --terrains-per-bin {per_bin}",
                    bycoms_study::runs::count(loaded.extra as u64, "terrain"),
                    dir.display()
                );
            }
            let bins = loaded.bins;
            let short: Vec<String> = axes
                .widths
                .iter()
                .zip(&bins)
                .filter(|(_, t)| t.len() < per_bin)
                .map(|(w, t)| format!("bin {w}: {}", t.len()))
                .collect();
            if !short.is_empty() {
                bail!(
                    "{} has fewer than {per_bin} terrains in some width bins ({}); \
                     lower --terrains-per-bin or choose --widths",
                    dir.display(),
                    short.join(", ")
                );
            }
            bins
        }
        None => {
            let bar = ProgressBar::new((axes.widths.len() * per_bin) as u64);
            bar.set_style(
                ProgressStyle::with_template("{elapsed_precise} generating terrains [{bar:40}] {pos}/{len}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            let bins =
                generate_bins(args.seed, &axes.widths, per_bin, args.max_candidates, stop, |done, _| {
                    bar.set_position(done as u64);
                })?;
            bar.finish_and_clear();
            bins
        }
    };
    Ok(bins)
}

/// One line of `terrains.csv`.
#[derive(Serialize)]
struct TerrainEntry<'a> {
    width_bin: f64,
    terrain: &'a str,
    width: f64,
    threshold: Option<f64>,
}

/// `terrains.csv`: which terrain each bin used, with its measured width.
fn write_terrain_list(out: &Path, axes: &Axes, terrains: &[Vec<SweepTerrain>]) -> Result<()> {
    let entries = axes.widths.iter().zip(terrains).flat_map(|(&width_bin, ts)| {
        ts.iter().map(move |t| TerrainEntry {
            width_bin,
            terrain: &t.id,
            width: t.width,
            threshold: t.threshold,
        })
    });
    bycoms_study::sweep::rows::write_atomic(
        &out.join("terrains.csv"),
        &bycoms_study::sweep::rows::to_csv_bytes(entries)?,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_runs_file_of_another_sweep_is_said_in_words() {
        let path = Path::new("out/runs.csv");
        let said = foreign_row(path, 0, 7, &[1, 3, 5]);
        assert_eq!(
            said,
            "out/runs.csv does not belong to this sweep (row 2 is run 7, expected run 1 of this plan); \
             use another --out"
        );
        assert!(foreign_row(path, 3, 9, &[1, 3, 5]).contains("this plan has only 3 runs"));
        assert!(foreign_row(path, 0, 1, &[1]).contains("run 1 with other parameters than this plan's"));
        assert!(!foreign_row(path, 3, 9, &[1]).contains("Some"), "no Rust in the words");
    }
}
