//! `orchestrator record …`: tools for recordings. `record recover FILE`
//! writes a complete copy of a recording cut short (by `kill -9`, a crash,
//! a power cut), which every MCAP reader opens — including Python `mcap`'s
//! `make_reader`, which needs the summary and footer a cut file lacks. It
//! copies only what verifies: a damaged chunk is left out, said, and makes
//! the command exit 1 (the copy is written, but it is not the whole run).
//! `record export --ros2 IN --out OUT` writes the run as a ROS 2 bag
//! (`bycoms_launch::ros2::bag`), through the same messages `launch --ros2`
//! publishes.

use anyhow::Result;
use bycoms_launch::ros2::bag;
use bycoms_record::{rewrite, Part, Recovered};
use bycoms_runtime::out::{usage_unless_io, write_with, Kind, Outputs};
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// Work with `launch --record` files.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub command: RecordCommand,
}

#[derive(Debug, clap::Subcommand)]
pub enum RecordCommand {
    /// Copy every complete message that verifies of a cut or damaged recording into a finished file.
    Recover(RecoverArgs),
    /// Write a recording's run as a ROS 2 bag (rosbag2 MCAP) that `ros2 bag play` reads.
    Export(ExportArgs),
}

/// Write a recording's run as a ROS 2 bag: the same topics and messages as
/// `launch --ros2` publishes (poses, /tf, /clock, paths, the map, beacons,
/// diagnostics), in rosbag2's MCAP format (profile `ros2`, CDR, `ros2msg`
/// schemas), timed by the run's clock.
#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// Export as a ROS 2 bag (the only export there is; required so a later format is a new flag).
    #[arg(long, required = true)]
    pub ros2: bool,
    /// The launch recording (read only).
    #[arg(value_name = "IN.mcap")]
    pub file: PathBuf,
    /// The bag to write.
    #[arg(long, value_name = "OUT.mcap")]
    pub out: PathBuf,
    /// Replace --out if it is already an MCAP file (never anything else, never IN itself).
    #[arg(long)]
    pub force: bool,
}

/// Copy a recording cut short (no summary, no footer) or damaged into a complete one.
///
/// Only what verifies is copied: a chunk whose CRC fails is left out (the
/// command says how many and exits 1). A file that is not a launch
/// recording is refused and nothing is written.
#[derive(Debug, clap::Args)]
pub struct RecoverArgs {
    /// The cut recording (read only).
    #[arg(value_name = "FILE.mcap")]
    pub file: PathBuf,
    /// The complete copy [default: FILE.recovered.mcap beside FILE].
    #[arg(long, value_name = "FILE.mcap")]
    pub out: Option<PathBuf>,
    /// Replace --out if it is already a recording (never anything else, never FILE itself).
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: Args) -> Result<i32> {
    match args.command {
        RecordCommand::Recover(a) => recover(a),
        RecordCommand::Export(a) => export(a),
    }
}

fn export(args: ExportArgs) -> Result<i32> {
    Outputs::new(args.force)
        .input(&args.file)
        .output("--out", &args.out, Kind::Recording)
        .check()
        .map_err(usage_unless_io)?;
    let name = args.out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let written = write_with(&args.out, |file| {
        let (exported, out) = bag::export(&args.file, BufWriter::new(file), &name)?;
        let file = out.into_inner().map_err(|e| anyhow::Error::new(e.into_error()))?;
        Ok::<_, anyhow::Error>((exported, file))
    })?;
    let exported = written?;
    let messages: u64 = exported.counts.values().sum();
    bycoms_runtime::outln!(
        "exported {} of {} ({}) into {}",
        bycoms_study::runs::count(messages, "ROS 2 message"),
        bycoms_study::runs::count(exported.counts.len() as u64, "topic"),
        bycoms_study::runs::count(exported.poses, "pose"),
        args.out.display()
    )?;
    Ok(bycoms_runtime::exit::SUCCESS)
}

/// `FILE.mcap` → `FILE.recovered.mcap`.
pub fn default_out(file: &Path) -> PathBuf {
    let stem =
        file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "recording".into());
    file.with_file_name(format!("{stem}.recovered.mcap"))
}

fn recover(args: RecoverArgs) -> Result<i32> {
    let out = args.out.clone().unwrap_or_else(|| default_out(&args.file));
    // The same file however spelled (./X.mcap, an absolute path, a link) is refused.
    Outputs::new(args.force)
        .input(&args.file)
        .output("--out", &out, Kind::Recording)
        .check()
        .map_err(usage_unless_io)?;
    let recovered = rewrite(&args.file, &out)?;
    bycoms_runtime::outln!("{}", recovered_line(&recovered, &out))?;
    for damage in &recovered.damage {
        tracing::warn!("{}: {damage}", args.file.display());
    }
    if recovered.damage.iter().any(|d| d.part != Part::Summary) {
        tracing::error!(
            "{} is damaged: {} left out of {} (it holds only what verifies)",
            args.file.display(),
            recovered.left_out(),
            out.display()
        );
        return Ok(bycoms_runtime::exit::ERROR);
    }
    Ok(bycoms_runtime::exit::SUCCESS)
}

/// What was copied, in one line.
fn recovered_line(recovered: &Recovered, out: &Path) -> String {
    let topics = bycoms_study::runs::count(recovered.counts.len() as u64, "topic");
    let messages = bycoms_study::runs::count(recovered.messages, "message");
    let copied = format!("{messages} on {topics} into {}", out.display());
    let mut line = match &recovered.stopped_by {
        Some(why) => format!("recovered {copied} (the recording ends early: {why})"),
        None if recovered.damage.is_empty() => format!("the recording was complete; copied {copied}"),
        None => format!("recovered {copied}"),
    };
    if !recovered.damage.is_empty() {
        line.push_str(&format!("; left out as damaged: {}", recovered.left_out()));
    }
    line
}
