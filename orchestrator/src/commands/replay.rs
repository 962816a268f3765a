//! `orchestrator replay FILE.mcap`: re-run the deployment gate from a
//! launch recording's poses and check it reaches the recorded decisions
//! (see [`crate::replay`]). Exit 0 when every decision matches, 1 on any
//! mismatch or an unreadable file (a file that is not an MCAP recording is
//! `record::check_recording`'s error, the same as for `draw` and `record recover`).

use crate::exit;
use crate::replay::{read_recording, rejudge, Comparison, Line};
use anyhow::Result;
use std::io::Write;
use std::path::PathBuf;

/// Replay a launch recording through the gate.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A recording written by `launch --record FILE.mcap`.
    #[arg(value_name = "FILE.mcap")]
    pub file: PathBuf,
    /// Print only mismatches and the verdict line.
    #[arg(long)]
    pub quiet: bool,
}

pub fn run(args: Args) -> Result<i32> {
    // "Not a recording" is the same error (and exit 1) as for `draw` and `record recover`.
    crate::record::check_recording(&args.file)?;
    let recorded = read_recording(&args.file)?;
    if let Some(why) = &recorded.stopped_by {
        tracing::warn!("the recording ends early ({why}); replaying what it holds");
    }
    let recorded_events: Vec<_> = recorded.gate_events().copied().collect();
    let replayed = rejudge(&recorded);
    let comparison = Comparison::new(&recorded_events, &replayed);
    let poses = recorded.entries.iter().filter(|e| matches!(e, crate::replay::Entry::Pose(_))).count();
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "replay of {} ({} terrain, {:?} clock): {poses} poses, {} recorded gate events",
        args.file.display(),
        recorded.run.terrain,
        recorded.run.config.clock,
        recorded_events.len()
    )?;
    for line in &comparison.lines {
        if !args.quiet || !matches!(line, Line::Same(_)) {
            writeln!(out, "{line}")?;
        }
    }
    if comparison.matches() {
        writeln!(out, "MATCH: the gate reached every recorded decision at the same step and position")?;
        Ok(exit::SUCCESS)
    } else {
        writeln!(
            out,
            "MISMATCH: {} of {} decisions differ",
            comparison.mismatches(),
            comparison.lines.len()
        )?;
        tracing::error!(mismatches = comparison.mismatches(), "replay does not reach the recorded decisions");
        Ok(exit::ERROR)
    }
}
