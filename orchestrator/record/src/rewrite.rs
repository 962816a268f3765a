//! `orchestrator record recover`: a complete copy of a recording cut short or damaged.
//!
//! Why: a recording cut by `kill -9` (or a power cut) is a valid MCAP
//! prefix without summary and footer. Streaming readers read it (Foxglove,
//! `mcap recover`, Python's `NonSeekingReader`, our [`super::recover`]), but
//! Python `mcap`'s `make_reader` seeks to the footer first and fails. This
//! copies every schema, channel, message (log and publish times, sequence
//! numbers, bytes), metadata record and attachment up to where the file is
//! cut into a new file, finished with summary and footer, so every reader
//! opens it. Only what verifies is copied: a chunk whose CRC fails (or that
//! does not decompress) is left out with its messages, never copied under
//! fresh CRCs, and the result says what was left out ([`Recovered::damage`]).
//! A copy that is not the whole run (the input was cut short, or data was
//! left out) says so in its `bycoms.recovered` metadata, which every reader
//! of the copy repeats ([`Reader::stream`](super::Reader::stream)): a replay
//! or an export of it never passes for the whole run.
//! It reads with the recording's one streaming reader ([`Reader::salvage`],
//! the walk [`super::recover`] counts with, so the copy keeps exactly the
//! messages `recover` finds) and writes with the `mcap` crate's writer:
//! nothing of the format is hand-written here. A file that is not a launch
//! recording is refused before anything is written.

use std::collections::HashMap;
use std::io::BufWriter;
use std::path::Path;

use mcap::records::MessageHeader;
use mcap::{WriteOptions, Writer};

use super::read::{End, Item, Reader};
use super::{RecordError, Recovered, CHUNK_SIZE};
use bycoms_runtime::out::{write_with, OutputError};

/// Copies every complete record of `input` that verifies into a finished
/// recording at `output`, written to a temporary file beside it and renamed
/// over it only when complete: `input` is never truncated, even when it is
/// `output` (the caller applies the overwrite rule, `bycoms_runtime::out::files`).
/// Returns what was kept, what was left out as damaged and why reading
/// stopped (`None`: the input was complete). A valid MCAP file that is not a
/// launch recording is [`RecordError::NotLaunch`], and nothing is written.
pub fn rewrite(input: &Path, output: &Path) -> Result<Recovered, RecordError> {
    let reader = Reader::open(input)?;
    let write_error = |source| RecordError::Write { path: output.to_path_buf(), source };
    let sync_error = |source| RecordError::Sync { path: output.to_path_buf(), source };
    let written = write_with(output, |out| {
        let options =
            WriteOptions::new().compression(super::COMPRESSION).use_chunks(true).chunk_size(Some(CHUNK_SIZE));
        let options = options.library(super::library());
        let mut writer = Writer::with_options(BufWriter::new(out), options).map_err(write_error)?;
        let (recovered, end) = copy(reader, &mut writer, output)?;
        end.launch_recording(input)?;
        if let Some(partial) = recovered.partial() {
            // Every reader of the copy says it is not the whole run (`Reader::stream`).
            let metadata = [(super::schema::RECOVERED_PARTIAL.to_string(), partial)].into();
            let record = mcap::records::Metadata { name: super::schema::RECOVERED_METADATA.into(), metadata };
            writer.write_metadata(&record).map_err(write_error)?;
        }
        writer.finish().map_err(write_error)?;
        let out = writer.into_inner().into_inner().map_err(|e| sync_error(e.into_error()))?;
        Ok((recovered, out))
    });
    match written {
        Ok(result) => result,
        Err(OutputError::Write { source, .. }) => {
            Err(RecordError::Create { path: output.to_path_buf(), source })
        }
        Err(other) => {
            Err(RecordError::Create { path: output.to_path_buf(), source: std::io::Error::other(other) })
        }
    }
}

/// Streams the records of `reader` into `writer`, the writer of `output`.
fn copy<W: std::io::Write + std::io::Seek>(
    reader: Reader,
    writer: &mut Writer<W>,
    output: &Path,
) -> Result<(Recovered, End), RecordError> {
    let write_error = |source| RecordError::Write { path: output.to_path_buf(), source };
    // Ids in the input → ids in the output.
    let mut schema_ids: HashMap<u16, u16> = HashMap::new();
    let mut channel_ids: HashMap<u16, u16> = HashMap::new();
    let mut recovered = Recovered::default();
    let end = reader.salvage(|item| {
        match item {
            Item::Channel(channel) => {
                let schema_id = match &channel.schema {
                    None => 0,
                    Some(schema) => match schema_ids.get(&schema.id) {
                        Some(&new) => new,
                        None => {
                            let new = writer
                                .add_schema(&schema.name, &schema.encoding, &schema.data)
                                .map_err(write_error)?;
                            schema_ids.insert(schema.id, new);
                            new
                        }
                    },
                };
                let new = writer
                    .add_channel(schema_id, &channel.topic, &channel.message_encoding, &channel.metadata)
                    .map_err(write_error)?;
                channel_ids.insert(channel.id, new);
            }
            Item::Message { channel, header, data } => {
                // Every message's channel was handed out before it.
                let Some(&channel_id) = channel_ids.get(&channel.id) else { return Ok(()) };
                let header = MessageHeader { channel_id, ..header };
                writer.write_to_known_channel(&header, data).map_err(write_error)?;
                recovered.count(&channel.topic);
            }
            Item::Metadata(metadata) => writer.write_metadata(&metadata).map_err(write_error)?,
            Item::Attachment(attachment) => writer.attach(&attachment).map_err(write_error)?,
        }
        Ok::<_, RecordError>(())
    });
    let end = end?;
    recovered.ended(end.clone());
    Ok((recovered, end))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{recover, Recorder};
    use std::path::Path;

    /// A launch-like recording of 90 messages (and the run metadata) in
    /// three chunks of 30, the run metadata in the first.
    fn three_chunks(path: &Path) {
        let mut recorder = Recorder::create(path).expect("create");
        recorder.record_json("bycoms/s/run", super::super::schema::RUN, 0, &"run").expect("run");
        for i in 0..90u64 {
            let topic = ["a/pose", "b/cmd", "c/tick"][(i % 3) as usize];
            recorder.record_bytes(topic, "bycoms.Test", i, i, &i.to_le_bytes().repeat(4)).expect("record");
            if i % 30 == 29 {
                recorder.flush().expect("flush: a chunk");
            }
        }
        let summary = recorder.finish().expect("finish");
        assert!(summary.chunks >= 3, "{summary:?}");
    }

    /// `record recover` of a file cut anywhere — between chunks, inside a
    /// chunk, inside its message indexes — keeps exactly the messages a
    /// streaming reader finds in the cut file (every complete chunk), and
    /// writes a complete file; cut before the run metadata, it writes none.
    #[test]
    fn a_file_cut_anywhere_is_rewritten_with_every_complete_chunk() {
        let dir = tempfile::tempdir().expect("temp dir");
        let whole = dir.path().join("whole.mcap");
        three_chunks(&whole);
        let bytes = std::fs::read(&whole).expect("read");
        let (cut, fixed) = (dir.path().join("cut.mcap"), dir.path().join("fixed.mcap"));
        let mut kept = std::collections::BTreeSet::new();
        for at in (mcap::MAGIC.len()..bytes.len()).step_by(7) {
            std::fs::write(&cut, &bytes[..at]).expect("write the cut file");
            let _ = std::fs::remove_file(&fixed);
            let streamed = recover(&cut).expect("a cut file streams");
            kept.insert(streamed.messages);
            if streamed.messages == 0 {
                let refused = rewrite(&cut, &fixed);
                assert!(matches!(refused, Err(RecordError::NotLaunch { .. })), "cut at {at}: {refused:?}");
                assert!(!fixed.exists(), "cut at {at}: nothing is written");
                continue;
            }
            let rewritten = rewrite(&cut, &fixed).expect("rewrites");
            assert_eq!(rewritten.counts, streamed.counts, "cut at {at}");
            let again = recover(&fixed).expect("the rewrite reads");
            assert!(again.is_complete(), "cut at {at}: {:?}", again.stopped_by);
            assert_eq!(again.counts, streamed.counts, "cut at {at}");
        }
        // Cuts inside the chunks kept 0, 31, 61 and (with only the footer
        // cut) all 91 messages: whole chunks, never part of one.
        assert_eq!(kept.into_iter().collect::<Vec<_>>(), [0, 31, 61, 91]);
    }

    /// A chunk whose CRC fails is not copied under fresh CRCs: the copy
    /// holds the other chunks, verifies, and the result names what was left out.
    #[test]
    fn a_damaged_chunk_is_left_out_of_the_copy() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (path, fixed) = (dir.path().join("damaged.mcap"), dir.path().join("fixed.mcap"));
        three_chunks(&path);
        let mut bytes = std::fs::read(&path).expect("read");
        let summary = mcap::Summary::read(&bytes).expect("summary").expect("finished");
        let second = summary.chunk_indexes[1].chunk_start_offset;
        bytes[second as usize + 9 + 24] ^= 0x80; // its stored CRC
        std::fs::write(&path, &bytes).expect("write");
        let recovered = rewrite(&path, &fixed).expect("rewrites what verifies");
        assert_eq!(recovered.messages, 61, "the second chunk's 30 messages are left out");
        assert_eq!(recovered.dropped_chunks(), 1);
        assert_eq!(recovered.damage[0].offset, second);
        let copy = recover(&fixed).expect("the copy reads");
        assert!(copy.is_complete() && copy.damage.is_empty(), "{copy:?}");
        assert_eq!(copy.counts, recovered.counts);
    }

    /// The channels a dropped chunk defined: a finished file's summary
    /// repeats them, so the later chunks' messages on them are copied; a cut
    /// file has none, and they are left out and counted.
    #[test]
    fn messages_whose_channel_a_dropped_chunk_defined_are_linked_by_the_summary() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (path, fixed) = (dir.path().join("damaged.mcap"), dir.path().join("fixed.mcap"));
        let mut recorder = Recorder::create(&path).expect("create");
        recorder.record_json("bycoms/s/run", super::super::schema::RUN, 0, &"run").expect("run");
        recorder.flush().expect("flush: the run's chunk");
        for i in 0..60u64 {
            // Every topic is first used in the second chunk.
            let topic = ["a/pose", "b/cmd", "c/tick"][(i % 3) as usize];
            recorder.record_bytes(topic, "bycoms.Test", i, i, &i.to_le_bytes()).expect("record");
            if i == 29 {
                recorder.flush().expect("flush: a chunk");
            }
        }
        recorder.finish().expect("finish");
        let mut bytes = std::fs::read(&path).expect("read");
        let summary = mcap::Summary::read(&bytes).expect("summary").expect("finished");
        let second = summary.chunk_indexes[1].chunk_start_offset as usize;
        let third_end =
            (summary.chunk_indexes[2].chunk_start_offset + summary.chunk_indexes[2].chunk_length) as usize;
        bytes[second + 9 + 24] ^= 0x01;
        std::fs::write(&path, &bytes).expect("write");
        let recovered = rewrite(&path, &fixed).expect("rewrites");
        assert_eq!((recovered.messages, recovered.orphans, recovered.dropped_chunks()), (31, 0, 1));
        let copy = recover(&fixed).expect("the copy reads");
        assert_eq!(copy.counts.get("a/pose"), Some(&10), "{copy:?}");
        // Cut after the third chunk: no summary to link with.
        std::fs::write(&path, &bytes[..third_end]).expect("cut");
        let recovered = rewrite(&path, &fixed).expect("rewrites");
        assert_eq!((recovered.messages, recovered.orphans, recovered.dropped_chunks()), (1, 30, 1));
    }

    /// A valid MCAP file without run metadata is not a launch recording:
    /// refused, and no "recovered" file is written.
    #[test]
    fn an_mcap_file_that_is_not_a_launch_recording_writes_nothing() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (path, fixed) = (dir.path().join("other.mcap"), dir.path().join("fixed.mcap"));
        let mut recorder = Recorder::create(&path).expect("create");
        recorder.record_bytes("a/pose", "bycoms.Test", 1, 1, b"x").expect("record");
        recorder.finish().expect("finish");
        let error = rewrite(&path, &fixed).expect_err("refused");
        assert!(matches!(error, RecordError::NotLaunch { .. }), "{error:?}");
        assert!(
            error.to_string().contains("other.mcap is an MCAP file but not a bycoms launch recording"),
            "{error}"
        );
        assert!(!fixed.exists());
        // A launch's recording cut before its first chunk: its header names the launch.
        let cut = dir.path().join("cut.mcap");
        drop(Recorder::create(&cut).expect("create"));
        let bytes = std::fs::read(&cut).expect("read");
        let header_only = after_header(&bytes);
        std::fs::write(&cut, &bytes[..header_only]).expect("cut");
        let error = rewrite(&cut, &fixed).expect_err("refused");
        assert!(error.to_string().contains("the launch was cut before it wrote anything"), "{error}");
        assert!(!fixed.exists());
    }

    /// Where the records after the header start: magic, then the header record.
    fn after_header(bytes: &[u8]) -> usize {
        let at = mcap::MAGIC.len();
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().expect("8 bytes"));
        at + 9 + len as usize
    }
}
