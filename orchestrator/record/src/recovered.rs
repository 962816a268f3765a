//! What could be read from a recording that may be damaged or cut short
//! (`orchestrator record recover`, and every reader's count): messages per
//! topic, the damage left out, and whether the copy is the whole run.
//!
//! Why its own file: the reader (`read.rs`) walks the bytes; this is the
//! account of a walk ([`recover`] walks and counts), which `record recover`,
//! `replay` and `record export` word. The reader knows nothing of it.

use std::collections::BTreeMap;
use std::path::Path;

use super::read::{End, Item, Reader};
use super::{Damage, Part, RecordError};

/// What could be read from a recording.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Recovered {
    /// Messages per topic.
    pub counts: BTreeMap<String, u64>,
    /// All messages recovered.
    pub messages: u64,
    /// `None` if the file was read through its footer and end magic; otherwise the error that
    /// ended reading, typically a truncation where the recording process died.
    pub stopped_by: Option<String>,
    /// The damaged parts left out ([`End::damage`]).
    pub damage: Vec<Damage>,
    /// Messages left out with the chunk that defined their channel ([`End::orphans`]).
    pub orphans: u64,
}

impl Recovered {
    /// Whether the file was complete (finished by [`Recorder::finish`](super::Recorder::finish)).
    pub fn is_complete(&self) -> bool {
        self.stopped_by.is_none()
    }

    /// Counts one message on `topic`.
    pub(crate) fn count(&mut self, topic: &str) {
        match self.counts.get_mut(topic) {
            Some(count) => *count += 1,
            None => {
                self.counts.insert(topic.to_string(), 1);
            }
        }
        self.messages += 1;
    }

    /// Takes how reading ended.
    pub(crate) fn ended(&mut self, end: End) {
        self.stopped_by = end.stopped_by;
        self.damage = end.damage;
        self.orphans = end.orphans;
    }

    /// Chunks left out as damaged.
    pub fn dropped_chunks(&self) -> usize {
        self.damage.iter().filter(|d| d.part == Part::Chunk).count()
    }

    /// The damaged parts left out, counted: "2 chunks, 40 messages whose channel a dropped
    /// chunk defined".
    pub fn left_out(&self) -> String {
        let count = |part: Part| self.damage.iter().filter(|d| d.part == part).count() as u64;
        let mut parts = vec![];
        if count(Part::Chunk) > 0 {
            parts.push(bycoms_runtime::words::count(count(Part::Chunk), "chunk"));
        }
        if self.orphans > 0 {
            parts.push(format!(
                "{} whose channel a dropped chunk defined",
                bycoms_runtime::words::count(self.orphans, "message")
            ));
        }
        for (part, name) in [(Part::Attachment, "attachment"), (Part::Record, "record")] {
            if count(part) > 0 {
                parts.push(bycoms_runtime::words::count(count(part), name));
            }
        }
        if count(Part::DataSection) > 0 {
            parts.push("a record outside the chunks (the data section's CRC fails)".into());
        }
        if count(Part::Summary) > 0 {
            parts.push("the summary (rebuilt)".into());
        }
        parts.join(", ")
    }

    /// What a copy of this read lacks of the run, if anything: the input was cut short, or
    /// data was left out as damaged (a rebuilt summary lacks nothing).
    pub fn partial(&self) -> Option<String> {
        let damaged = self.damage.iter().any(|d| d.part != Part::Summary);
        let mut said = Vec::new();
        if let Some(why) = &self.stopped_by {
            said.push(format!("the recording ends early ({why})"));
        }
        if damaged {
            said.push(format!("left out as damaged: {}", self.left_out()));
        }
        (!said.is_empty()).then(|| {
            format!(
                "{} of the run are in it; {}",
                bycoms_runtime::words::count(self.messages, "message"),
                said.join("; ")
            )
        })
    }
}

/// Counts the messages per topic of a recording, finished or truncated by a crash.
pub fn read_counts(path: &Path) -> Result<BTreeMap<String, u64>, RecordError> {
    recover(path).map(|recovered| recovered.counts)
}

/// Reads every complete message of a recording, finished or truncated, and says whether (and
/// why) it stopped early and what it left out as damaged ([`Reader::salvage`]). Fails only
/// when the file cannot be opened or is not MCAP at all.
pub fn recover(path: &Path) -> Result<Recovered, RecordError> {
    let mut recovered = Recovered::default();
    let end = Reader::open(path)?.salvage(|item| {
        if let Item::Message { channel, .. } = item {
            recovered.count(&channel.topic);
        }
        Ok::<_, RecordError>(())
    })?;
    recovered.ended(end);
    Ok(recovered)
}
