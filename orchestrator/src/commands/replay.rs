//! `orchestrator replay FILE.mcap`: re-run the launch core on a launch
//! recording's inputs and check it reaches the recorded decisions
//! (see [`crate::replay`]). Exit 0 when every decision matches, 1 on any
//! mismatch or an unreadable file (a file that is not an MCAP recording is
//! the recording reader's error, `record::Reader`, the same as for `draw`
//! and `record recover`).

use crate::replay::{read_recording, rejudge, Comparison, Line, Recorded};
use anyhow::Result;
use bycoms_runtime::exit;
use std::io::Write;
use std::path::PathBuf;

/// Re-run the launch core on a recording's inputs and check it reaches the recorded decisions.
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
    // "Not a recording" is the same error (and exit 1) as for `draw` and
    // `record recover`: the three read with one reader.
    let recorded = read_recording(&args.file)?;
    if let Some(why) = &recorded.stopped_by {
        tracing::warn!("the recording ends early ({why}); replaying what it holds");
    }
    let recorded_events: Vec<_> = recorded.gate_events().copied().collect();
    // The launch's own core fed the launch's own calls; a recording from
    // before the core's log is re-judged from its poses by the same referee.
    let (replayed, how) = match recorded.core_log() {
        Some(core_log) => {
            let calls = core_log.calls;
            if let Some((robot, n)) = core_log.missing {
                writeln!(
                    std::io::stdout().lock(),
                    "MISMATCH: the core log hands the core a pose that is not on the record: robot {robot}'s pose number {n} (changed or missing)"
                )?;
                tracing::error!("the recording's core log names a pose the recording does not hold");
                return Ok(exit::ERROR);
            }
            if let Some(pose) = recorded.unrecorded_input(&calls) {
                let mut out = std::io::stdout().lock();
                writeln!(
                    out,
                    "MISMATCH: the core log hands the core a pose that is not on the record: {} at step {} ({:.4}, {:.4})",
                    pose.robot, pose.step, pose.x, pose.y
                )?;
                tracing::error!("the recording's core log does not agree with its recorded poses");
                return Ok(exit::ERROR);
            }
            let n = calls.len();
            (
                bycoms_launch::core::log::replay(core_log.setup, &calls).0,
                format!("the launch core, {n} recorded calls"),
            )
        }
        None => (rejudge(&recorded), "the gate's referee, from the poses (no core log)".to_string()),
    };
    let comparison = Comparison::new(&recorded_events, &replayed);
    let poses = recorded.entries.iter().filter(|e| matches!(e, crate::replay::Entry::Pose(_))).count();
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "replay of {} ({} terrain, {:?} clock) through {how}: {poses} poses, {} recorded gate events",
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
    verdict(&mut out, &comparison, &recorded)
}

/// The verdict line and the exit code: a match of a run the file holds
/// only part of (cut short, or a copy by `record recover` that lacks some
/// of it) says so, as the run may have gone on to decisions not in it.
fn verdict(out: &mut impl Write, comparison: &Comparison, recorded: &Recorded) -> Result<i32> {
    if comparison.matches() {
        let partial = match (&recorded.partial, &recorded.stopped_by) {
            (Some(lacks), _) => format!(" — of part of the run only: {lacks}"),
            (None, Some(why)) => format!(" — of part of the run only: the recording ends early ({why})"),
            (None, None) => String::new(),
        };
        writeln!(
            out,
            "MATCH: the gate reached every recorded decision at the same step and position{partial}"
        )?;
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
