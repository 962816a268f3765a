//! `orchestrator replay FILE.mcap`: the launch re-run offline from a
//! recording, checked against the decisions the launch recorded.
//!
//! Why: a recording is only evidence if the decisions in it follow from
//! the inputs in it. A launch records every call it made on its core
//! (`launch::core::log`); the replay reads them back (`read`), checks that
//! every pose they hand the core is among the recorded poses, feeds them to
//! a new core made from the recorded setup, and compares every decision —
//! robot, kind, step, position — with the recorded gate events. A
//! recording from before the core's log is re-judged from its poses by the
//! launch's own referee (`judge`). Any difference is a mismatch, reported
//! event by event (non-zero exit).
//!
//! Positions are compared bit for bit: the replay computes nothing new
//! from them, it only picks the pose a decision was taken at.

pub mod judge;
pub mod read;
pub mod source;

pub use judge::rejudge;
pub use read::{read_recording, Entry, Recorded, RunMeta};
pub use source::ReplayPoseSource;

use bycoms_protocol::msg::{GateEvent, GateKind};
use std::fmt;

/// Why a recording cannot be replayed.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The file cannot be opened or is not MCAP (the recording reader's
    /// errors, the same for `draw` and `record recover`).
    #[error(transparent)]
    Record(#[from] bycoms_record::RecordError),
    /// The `run` record does not parse.
    #[error("the run metadata on {topic} does not parse: {reason}")]
    BadRunMeta {
        /// Its topic.
        topic: String,
        /// Why.
        reason: String,
    },
}

/// One line of the comparison.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Line {
    /// Recorded and replayed agree.
    Same(GateEvent),
    /// They differ.
    Differ {
        /// What the launch recorded.
        recorded: GateEvent,
        /// What the replay reached.
        replayed: GateEvent,
    },
    /// Recorded, never reached by the replay.
    OnlyRecorded(GateEvent),
    /// Reached by the replay, not in the recording.
    OnlyReplayed(GateEvent),
}

/// The whole comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// Event by event, in order.
    pub lines: Vec<Line>,
}

impl Comparison {
    /// Compares two event lists position by position.
    pub fn new(recorded: &[GateEvent], replayed: &[GateEvent]) -> Self {
        let n = recorded.len().max(replayed.len());
        let lines = (0..n)
            .map(|i| match (recorded.get(i), replayed.get(i)) {
                (Some(a), Some(b)) if same(a, b) => Line::Same(*a),
                (Some(a), Some(b)) => Line::Differ { recorded: *a, replayed: *b },
                (Some(a), None) => Line::OnlyRecorded(*a),
                (None, Some(b)) => Line::OnlyReplayed(*b),
                (None, None) => unreachable!("i < max of both lengths"),
            })
            .collect();
        Self { lines }
    }

    /// Whether every decision matched.
    pub fn matches(&self) -> bool {
        self.lines.iter().all(|l| matches!(l, Line::Same(_)))
    }

    /// Lines that do not match.
    pub fn mismatches(&self) -> usize {
        self.lines.iter().filter(|l| !matches!(l, Line::Same(_))).count()
    }
}

fn same(a: &GateEvent, b: &GateEvent) -> bool {
    a.robot == b.robot
        && a.kind == b.kind
        && a.step == b.step
        && a.x.to_bits() == b.x.to_bits()
        && a.y.to_bits() == b.y.to_bits()
}

/// A gate event in words, e.g. `robot 2 stuck at (3.10, 4.00), step 231`.
pub struct Described<'a>(pub &'a GateEvent);

impl fmt::Display for Described<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let e = self.0;
        let what = match e.kind {
            GateKind::Deployed => "deployed",
            GateKind::Stopped { arrived: true } => "arrived",
            GateKind::Stopped { arrived: false } => "stuck",
            GateKind::Died => "died",
            GateKind::Timeout => "timeout",
        };
        write!(f, "{} {what} at ({:.4}, {:.4}), step {}", e.robot, e.x, e.y, e.step)
    }
}

impl fmt::Display for Line {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Line::Same(e) => write!(f, "  same      {}", Described(e)),
            Line::Differ { recorded, replayed } => {
                write!(f, "  MISMATCH  recorded {} | replayed {}", Described(recorded), Described(replayed))
            }
            Line::OnlyRecorded(e) => {
                write!(f, "  MISMATCH  recorded {} | replay never reached it", Described(e))
            }
            Line::OnlyReplayed(e) => {
                write!(f, "  MISMATCH  replayed {} | not in the recording", Described(e))
            }
        }
    }
}

#[cfg(test)]
mod tests;
