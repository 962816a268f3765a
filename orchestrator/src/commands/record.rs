//! `orchestrator record …`: tools for recordings. `record recover FILE`
//! writes a complete copy of a recording cut short (by `kill -9`, a crash,
//! a power cut), which every MCAP reader opens — including Python `mcap`'s
//! `make_reader`, which needs the summary and footer a cut file lacks.

use crate::out::{usage_unless_io, Kind, Outputs};
use crate::record::rewrite;
use anyhow::Result;
use std::path::{Path, PathBuf};

/// Work with `launch --record` files.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub command: RecordCommand,
}

#[derive(Debug, clap::Subcommand)]
pub enum RecordCommand {
    /// Copy every complete message of a cut recording into a finished file.
    Recover(RecoverArgs),
}

/// Copy a recording cut short (no summary, no footer) into a complete one.
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
    }
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
    let topics = crate::runs::count(recovered.counts.len() as u64, "topic");
    let messages = crate::runs::count(recovered.messages, "message");
    let line = match &recovered.stopped_by {
        Some(why) => format!(
            "recovered {messages} on {topics} into {} (the recording ends early: {why})",
            out.display()
        ),
        None => format!("the recording was complete; copied {messages} on {topics} into {}", out.display()),
    };
    crate::outln!("{line}")?;
    Ok(crate::exit::SUCCESS)
}
