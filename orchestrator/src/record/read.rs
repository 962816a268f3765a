//! Reading recordings back, including the truncated ones a crash leaves behind: the one
//! streaming reader of a recording.
//!
//! Why one reader: `draw FILE.mcap` ([`super::run`]), `replay` (`crate::replay::read`) and
//! `record recover` ([`recover`], [`super::rewrite`]) all read the same files, and each used to
//! walk them itself, with its own rule for where a cut file stops and when a file is "not a
//! recording". [`Reader::stream`] is that walk, once:
//!
//! * the file is streamed record by record through the `mcap` crate's sans-IO linear reader
//!   (chunks are opened by it, any compression MCAP allows), never through its summary, so a
//!   file without footer is read like any other; memory is one record or chunk, not the file;
//! * schemas and channels are linked as they come (the crate's `ChannelAccumulator`, with
//!   its checks), so every message arrives with its channel and schema;
//! * every complete message before the first damaged record is handed out, then reading
//!   stops and says why ([`End::stopped_by`]); a file whose magic is wrong before any message
//!   is [`RecordError::NotMcap`], the one "not a recording" error of every command.
//!
//! What a message *means* is [`super::decode`]'s, once as well.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use mcap::read::ChannelAccumulator;
use mcap::records::{MessageHeader, Metadata, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::{Channel, McapError};

use super::RecordError;

/// One thing a recording holds, in file order, as [`Reader::stream`] hands it out.
#[derive(Debug)]
pub enum Item<'a> {
    /// A channel, when its record is first met, linked to its schema.
    Channel(&'a Arc<Channel<'static>>),
    /// A message on a channel handed out before.
    Message {
        /// Its channel (and the channel's schema).
        channel: &'a Arc<Channel<'static>>,
        /// Its sequence number, log and publish times (channel id as in the file).
        header: MessageHeader,
        /// Its bytes, borrowed from the reader's buffer.
        data: &'a [u8],
    },
    /// A metadata record (e.g. `bycoms.clock`).
    Metadata(Metadata),
}

/// How reading a recording ended.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct End {
    /// Messages handed out.
    pub messages: u64,
    /// `None` if the file was read through its footer and end magic; otherwise the error
    /// that ended reading, typically a truncation where the recording process died.
    pub stopped_by: Option<String>,
}

/// A recording opened for reading (see the [module docs](self)).
#[derive(Debug)]
pub struct Reader {
    path: PathBuf,
    file: File,
    len: u64,
}

impl Reader {
    /// Opens the recording at `path` and checks that it is one ([`open_recording`]).
    pub fn open(path: &Path) -> Result<Self, RecordError> {
        let (file, len) = open_recording(path)?;
        Ok(Self { path: path.to_path_buf(), file, len })
    }

    /// Streams the recording through `visit`, item by item, up to its end or its first
    /// damaged record. Fails when the file is not MCAP or when `visit` fails (reading stops
    /// at once then).
    pub fn stream<E: From<RecordError>>(
        self,
        visit: impl FnMut(Item<'_>) -> Result<(), E>,
    ) -> Result<End, E> {
        let Reader { path, file, len } = self;
        stream_from(BufReader::new(file), len, visit).map_err(|stop| match stop {
            Stop::NotMcap(error) => not_mcap(&path, &error).into(),
            Stop::Visit(error) => error,
        })
    }
}

/// Why [`stream_from`] gave up.
enum Stop<E> {
    /// The source is not MCAP (wrong magic before any message).
    NotMcap(McapError),
    /// The visitor failed.
    Visit(E),
}

/// The streaming core of [`Reader::stream`]: `len` bounds the record lengths believed.
fn stream_from<R: Read, E>(
    mut source: R,
    len: u64,
    mut visit: impl FnMut(Item<'_>) -> Result<(), E>,
) -> Result<End, Stop<E>> {
    let limit = usize::try_from(len).unwrap_or(usize::MAX);
    let mut reader =
        LinearReader::new_with_options(LinearReaderOptions::default().with_record_length_limit(limit));
    let mut linked = ChannelAccumulator::default();
    let mut end = End::default();
    // The summary repeats schemas and channels: past the data end they are not linked again.
    let mut past_data_end = false;
    let mut footer = false;
    let error = loop {
        let Some(event) = reader.next_event() else { break None };
        let (opcode, data) = match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let read = loop {
                    match source.read(reader.insert(need)) {
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                        read => break read,
                    }
                };
                match read {
                    Ok(n) => reader.notify_read(n),
                    Err(e) => break Some(McapError::from(e)),
                }
                continue;
            }
            Ok(LinearReadEvent::Record { opcode, data }) => (opcode, data),
            Err(error) => break Some(error),
        };
        let record = match mcap::parse_record(opcode, data) {
            Ok(record) => record,
            Err(error) => break Some(error),
        };
        let visited = match record {
            Record::DataEnd(_) => {
                past_data_end = true;
                Ok(())
            }
            Record::Footer(_) => {
                footer = true;
                Ok(())
            }
            _ if past_data_end => Ok(()),
            Record::Schema { header, data } => match linked.add_schema_from_slice(header, &data) {
                Ok(()) => Ok(()),
                Err(error) => break Some(error),
            },
            Record::Channel(channel) => {
                let id = channel.id;
                let new = linked.get(id).is_none();
                if let Err(error) = linked.add_channel(channel) {
                    break Some(error);
                }
                match linked.get(id) {
                    Some(channel) if new => visit(Item::Channel(&channel)),
                    _ => Ok(()),
                }
            }
            Record::Message { header, data } => {
                let Some(channel) = linked.get(header.channel_id) else {
                    break Some(McapError::UnknownChannel(header.sequence, header.channel_id));
                };
                end.messages += 1;
                visit(Item::Message { channel: &channel, header, data: &data })
            }
            Record::Metadata(metadata) => visit(Item::Metadata(metadata)),
            _ => Ok(()),
        };
        visited.map_err(Stop::Visit)?;
    };
    match error {
        // Wrong magic before any message: this is not a recording.
        Some(McapError::BadMagic) if end.messages == 0 => return Err(Stop::NotMcap(McapError::BadMagic)),
        Some(error) => end.stopped_by = Some(error.to_string()),
        None if !footer => end.stopped_by = Some("the file ends without a footer".into()),
        None => {}
    }
    Ok(end)
}

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
}

/// Counts the messages per topic of a recording, finished or truncated by a crash.
pub fn read_counts(path: &Path) -> Result<BTreeMap<String, u64>, RecordError> {
    recover(path).map(|recovered| recovered.counts)
}

/// Reads every complete message of a recording, finished or truncated, and says whether (and
/// why) it stopped early. Fails only when the file cannot be opened or is not MCAP at all.
pub fn recover(path: &Path) -> Result<Recovered, RecordError> {
    let mut recovered = Recovered::default();
    let end = Reader::open(path)?.stream(|item| {
        if let Item::Message { channel, .. } = item {
            recovered.count(&channel.topic);
        }
        Ok::<_, RecordError>(())
    })?;
    recovered.stopped_by = end.stopped_by;
    Ok(recovered)
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

/// [`RecordError::NotMcap`] for a reader's complaint.
fn not_mcap(path: &Path, error: &McapError) -> RecordError {
    RecordError::NotMcap { path: path.to_path_buf(), reason: error.to_string() }
}

/// [`recover`] of any source: `len` bounds the record lengths believed.
#[cfg(test)]
fn recover_from<R: Read>(source: R, len: u64) -> Result<Recovered, McapError> {
    let mut recovered = Recovered::default();
    let end = stream_from(source, len, |item| {
        if let Item::Message { channel, .. } = item {
            recovered.count(&channel.topic);
        }
        Ok::<_, std::convert::Infallible>(())
    });
    match end {
        Ok(end) => {
            recovered.stopped_by = end.stopped_by;
            Ok(recovered)
        }
        Err(Stop::NotMcap(error)) => Err(error),
        Err(Stop::Visit(never)) => match never {},
    }
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
