//! Reading recordings back, including the truncated ones a crash leaves behind.
//!
//! The file is streamed record by record (`mcap::io::MessageReader`, the crate's linear reader
//! over any `Read`), never through its summary, so a file without footer is read like any other:
//! every complete message before the first damaged record is counted, then reading stops.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek};
use std::path::Path;

use mcap::io::MessageReader;
use mcap::sans_io::LinearReaderOptions;
use mcap::McapError;

use super::RecordError;

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
}

impl Recovered {
    /// Whether the file was complete (finished by [`Recorder::finish`](super::Recorder::finish)).
    pub fn is_complete(&self) -> bool {
        self.stopped_by.is_none()
    }
}

/// Counts the messages per topic of a recording, finished or truncated by a crash.
pub fn read_counts(path: &Path) -> Result<BTreeMap<String, u64>, RecordError> {
    recover(path).map(|recovered| recovered.counts)
}

/// Reads every complete message of a recording, finished or truncated, and says whether (and
/// why) it stopped early. Fails only when the file cannot be opened or is not MCAP at all.
pub fn recover(path: &Path) -> Result<Recovered, RecordError> {
    let (file, len) = open_recording(path)?;
    recover_from(BufReader::new(file), len).map_err(|source| not_mcap(path, &source))
}

/// Opens a recording to read and returns it with its length, after checking that it is one:
/// it starts with the MCAP magic bytes. An empty file, a text or garbage is
/// [`RecordError::NotMcap`], the one "not a recording" error of every command that reads
/// recordings (a recording cut by a crash still starts with the magic: `Recorder::create`
/// writes it at once).
pub fn open_recording(path: &Path) -> Result<(File, u64), RecordError> {
    let open_error = |source| RecordError::Open { path: path.to_path_buf(), source };
    let mut file = File::open(path).map_err(open_error)?;
    let meta = file.metadata().map_err(open_error)?;
    let reason = if meta.is_dir() {
        Some("it is a directory")
    } else if meta.len() == 0 {
        Some("the file is empty")
    } else {
        let mut head = Vec::with_capacity(mcap::MAGIC.len());
        (&mut file).take(mcap::MAGIC.len() as u64).read_to_end(&mut head).map_err(open_error)?;
        file.rewind().map_err(open_error)?;
        (head != mcap::MAGIC).then_some("it does not start with the MCAP magic bytes")
    };
    match reason {
        Some(reason) => Err(RecordError::NotMcap { path: path.to_path_buf(), reason: reason.into() }),
        None => Ok((file, meta.len())),
    }
}

/// Checks that `path` is an MCAP recording (see [`open_recording`]).
pub fn check_recording(path: &Path) -> Result<(), RecordError> {
    open_recording(path).map(drop)
}

/// [`RecordError::NotMcap`] for a reader's complaint.
pub(crate) fn not_mcap(path: &Path, error: &McapError) -> RecordError {
    RecordError::NotMcap { path: path.to_path_buf(), reason: error.to_string() }
}

/// The streaming core of [`recover`]: `len` bounds the record lengths believed.
fn recover_from<R: Read>(source: R, len: u64) -> Result<Recovered, McapError> {
    let limit = usize::try_from(len).unwrap_or(usize::MAX);
    let options = LinearReaderOptions::default().with_record_length_limit(limit);
    let mut recovered = Recovered::default();
    for item in MessageReader::new_with_options(source, options) {
        match item {
            Ok(message) => {
                let topic = &message.channel.topic;
                match recovered.counts.get_mut(topic) {
                    Some(count) => *count += 1,
                    None => {
                        recovered.counts.insert(topic.clone(), 1);
                    }
                }
                recovered.messages += 1;
            }
            // Wrong magic before any message: this is not a recording.
            Err(McapError::BadMagic) if recovered.messages == 0 => return Err(McapError::BadMagic),
            Err(error) => {
                recovered.stopped_by = Some(error.to_string());
                break;
            }
        }
    }
    Ok(recovered)
}

#[cfg(test)]
mod tests {
    use std::io::Cursor;

    use super::*;
    use crate::record::Recorder;

    /// A small finished recording of several chunks, and its per-topic counts.
    fn sample() -> (Vec<u8>, BTreeMap<String, u64>) {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("sample.mcap");
        let mut recorder = Recorder::create(&path).expect("create");
        for i in 0..60u64 {
            let topic = ["a/pose", "b/cmd", "c/tick"][(i % 3) as usize];
            recorder.record_bytes(topic, "bycoms.Test", i, i, &i.to_le_bytes()).expect("record");
            if i % 20 == 19 {
                recorder.flush().expect("flush");
            }
        }
        recorder.record_json("bycoms/s/gate", "bycoms.Gate", 99, &"open").expect("json");
        let summary = recorder.finish().expect("finish");
        assert!(summary.chunks >= 3, "flushes cut chunks: {summary:?}");
        let bytes = std::fs::read(&path).expect("read back");
        (bytes, summary.counts)
    }

    #[test]
    fn every_cut_of_a_file_reads_without_error_and_counts_grow() {
        let (bytes, counts) = sample();
        let total: u64 = counts.values().sum();
        let mut last = 0;
        for cut in (0..bytes.len()).step_by(3).chain([bytes.len() - 1]) {
            let part = &bytes[..cut];
            let recovered = recover_from(Cursor::new(part), part.len() as u64).expect("cut file reads");
            assert!(!recovered.is_complete(), "cut at {cut} is not complete");
            assert!(recovered.messages >= last, "cut at {cut}: {} < {last}", recovered.messages);
            assert!(recovered.messages <= total);
            last = recovered.messages;
        }
        assert_eq!(last, total, "all but the footer recovers every message");
        let whole = recover_from(Cursor::new(&bytes), bytes.len() as u64).expect("whole file");
        assert!(whole.is_complete(), "{whole:?}");
        assert_eq!(whole.counts, counts);
    }

    #[test]
    fn a_file_that_is_not_mcap_is_an_error() {
        let junk = b"this is not an mcap file at all, just text".to_vec();
        assert!(matches!(recover_from(Cursor::new(&junk), junk.len() as u64), Err(McapError::BadMagic)));
    }
}
