//! The one error type of the recorder and its reader.

use std::fmt;
use std::io;
use std::path::PathBuf;

/// Everything that can go wrong while recording a run or reading a recording back.
///
/// Each variant names the file (or the topic) it is about, so a message printed by
/// `launch` says which recording failed.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The recording file could not be created (missing directory, permissions, …).
    #[error("cannot create recording {}: {source}", path.display())]
    Create {
        /// The file that was to be created.
        path: PathBuf,
        /// What the operating system said.
        source: io::Error,
    },
    /// The recording could not be opened for reading.
    #[error("cannot open recording {}: {source}", path.display())]
    Open {
        /// The file that was to be read.
        path: PathBuf,
        /// What the operating system said.
        source: io::Error,
    },
    /// Writing, flushing or finishing the recording failed (disk full, I/O error, …).
    #[error("cannot write recording {}: {source}", path.display())]
    Write {
        /// The recording being written.
        path: PathBuf,
        /// The MCAP writer's error (I/O errors arrive wrapped in it).
        source: mcap::McapError,
    },
    /// Making the finished recording durable (`fsync`) or sizing it failed.
    #[error("cannot sync recording {}: {source}", path.display())]
    Sync {
        /// The recording being finished.
        path: PathBuf,
        /// What the operating system said.
        source: io::Error,
    },
    /// The file does not start with the MCAP magic bytes (or is empty, or is no regular file):
    /// it is not MCAP at all. The one error of `record recover`, `draw` and `replay` for such a
    /// file (exit 1).
    #[error("{} is not an MCAP file: {reason}", path.display())]
    NotMcap {
        /// The file that was read.
        path: PathBuf,
        /// What is wrong with it ("the file is empty", …).
        reason: String,
    },
    /// A valid MCAP file that is not a launch recording (no run metadata): the one error of
    /// `record recover`, `draw` and `replay` for it (exit 1, nothing written).
    #[error("{} is an MCAP file but not a bycoms launch recording: {reason}", path.display())]
    NotLaunch {
        /// The file that was read.
        path: PathBuf,
        /// Why ("it holds no run metadata …").
        reason: String,
    },
    /// A launch's recording whose run metadata (its first message) is in a chunk left out as
    /// damaged: nothing of the run can be read without it (`record recover`, `draw`, `replay`).
    #[error(
        "{}: the chunk holding the run metadata (bycoms/<swarm>/run) is damaged ({damage}); without it nothing of the run can be read",
        path.display()
    )]
    RunMetaDamaged {
        /// The file that was read.
        path: PathBuf,
        /// The first chunk left out.
        damage: Damage,
    },
    /// A damaged part of a recording (a chunk whose CRC fails, …): `draw` and `replay` read
    /// no corrupt byte; `record recover` copies what verifies.
    #[error(
        "{} is damaged: {damage}; `orchestrator record recover {}` copies the parts that verify",
        path.display(),
        path.display()
    )]
    Damaged {
        /// The file that was read.
        path: PathBuf,
        /// Where and what.
        damage: Damage,
    },
    /// A JSON record could not be serialized.
    #[error("cannot encode a JSON record for topic {topic:?}: {source}")]
    Json {
        /// The topic the record was meant for.
        topic: String,
        /// serde_json's error.
        source: serde_json::Error,
    },
    /// A topic was first recorded with one encoding or schema and later with another.
    #[error("topic {topic:?} is recorded as {existing}, not {requested}")]
    TopicMismatch {
        /// The topic.
        topic: String,
        /// `encoding/schema` of the channel already in the file.
        existing: String,
        /// `encoding/schema` of the rejected call.
        requested: String,
    },
}

/// Which part of a file is damaged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// A chunk: its CRC fails, or it does not decompress or parse. Its messages are not read.
    Chunk,
    /// An attachment whose CRC fails.
    Attachment,
    /// A record outside the chunks that does not parse.
    Record,
    /// The data section's CRC (in its DataEnd record) fails: a record outside the chunks
    /// (metadata, message indexes) is damaged.
    DataSection,
    /// The summary section's CRC (in the footer) fails: the indexes other readers seek with.
    Summary,
}

/// One damaged part of a recording: where it starts and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Damage {
    /// Byte offset of the damaged record in the file.
    pub offset: u64,
    /// What it is.
    pub part: Part,
    /// What the check said.
    pub why: String,
}

impl fmt::Display for Damage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = match self.part {
            Part::Chunk => "the chunk",
            Part::Attachment => "the attachment",
            Part::Record => "the record",
            Part::DataSection => "the data section (checked at its end record)",
            Part::Summary => "the summary section (checked at the footer)",
        };
        write!(f, "{what} at byte {} is damaged: {}", self.offset, self.why)
    }
}
