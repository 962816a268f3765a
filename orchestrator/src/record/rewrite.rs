//! `orchestrator record recover`: a complete copy of a recording cut short.
//!
//! Why: a recording cut by `kill -9` (or a power cut) is a valid MCAP
//! prefix without summary and footer. Streaming readers read it (Foxglove,
//! `mcap recover`, Python's `NonSeekingReader`, our [`super::recover`]), but
//! Python `mcap`'s `make_reader` seeks to the footer first and fails. This
//! copies every schema, channel, message (log and publish times, sequence
//! numbers, bytes) and metadata record up to the first damaged record into
//! a new file, finished with summary and footer, so every reader opens it.
//! It reads with the recording's one streaming reader ([`Reader::stream`],
//! the walk [`super::recover`] counts with, so the copy keeps exactly the
//! messages `recover` finds) and writes with the `mcap` crate's writer:
//! nothing of the format is hand-written here.

use std::collections::HashMap;
use std::io::BufWriter;
use std::path::Path;

use mcap::records::MessageHeader;
use mcap::{WriteOptions, Writer};

use super::read::{Item, Reader};
use super::{RecordError, Recovered, CHUNK_SIZE};
use crate::out::{write_with, OutputError};

/// Copies every complete record of `input` into a finished recording at
/// `output`, written to a temporary file beside it and renamed over it only
/// when complete: `input` is never truncated, even when it is `output`
/// (the caller applies the overwrite rule, `crate::out::files`). Returns
/// what was kept and why reading stopped (`None`: the input was complete).
pub fn rewrite(input: &Path, output: &Path) -> Result<Recovered, RecordError> {
    let reader = Reader::open(input)?;
    let write_error = |source| RecordError::Write { path: output.to_path_buf(), source };
    let sync_error = |source| RecordError::Sync { path: output.to_path_buf(), source };
    let written = write_with(output, |out| {
        let options =
            WriteOptions::new().compression(super::COMPRESSION).use_chunks(true).chunk_size(Some(CHUNK_SIZE));
        let mut writer = Writer::with_options(BufWriter::new(out), options).map_err(write_error)?;
        let recovered = copy(reader, &mut writer, output)?;
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
) -> Result<Recovered, RecordError> {
    let write_error = |source| RecordError::Write { path: output.to_path_buf(), source };
    // Ids in the input → ids in the output.
    let mut schema_ids: HashMap<u16, u16> = HashMap::new();
    let mut channel_ids: HashMap<u16, u16> = HashMap::new();
    let mut recovered = Recovered::default();
    let end = reader.stream(|item| {
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
        }
        Ok::<_, RecordError>(())
    });
    recovered.stopped_by = end?.stopped_by;
    Ok(recovered)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{recover, Recorder};

    /// `record recover` of a file cut anywhere — between chunks, inside a
    /// chunk, inside its message indexes — keeps exactly the messages a
    /// streaming reader finds in the cut file (every complete chunk), and
    /// writes a complete file.
    #[test]
    fn a_file_cut_anywhere_is_rewritten_with_every_complete_chunk() {
        let dir = tempfile::tempdir().expect("temp dir");
        let whole = dir.path().join("whole.mcap");
        let mut recorder = Recorder::create(&whole).expect("create");
        for i in 0..90u64 {
            let topic = ["a/pose", "b/cmd", "c/tick"][(i % 3) as usize];
            recorder.record_bytes(topic, "bycoms.Test", i, i, &i.to_le_bytes().repeat(4)).expect("record");
            if i % 30 == 29 {
                recorder.flush().expect("flush: a chunk");
            }
        }
        let summary = recorder.finish().expect("finish");
        assert!(summary.chunks >= 3, "{summary:?}");
        let bytes = std::fs::read(&whole).expect("read");
        let (cut, fixed) = (dir.path().join("cut.mcap"), dir.path().join("fixed.mcap"));
        let mut kept = std::collections::BTreeSet::new();
        for at in (mcap::MAGIC.len()..bytes.len()).step_by(7) {
            std::fs::write(&cut, &bytes[..at]).expect("write the cut file");
            let streamed = recover(&cut).expect("a cut file streams");
            let rewritten = rewrite(&cut, &fixed).expect("rewrites");
            assert_eq!(rewritten.counts, streamed.counts, "cut at {at}");
            let again = recover(&fixed).expect("the rewrite reads");
            assert!(again.is_complete(), "cut at {at}: {:?}", again.stopped_by);
            assert_eq!(again.counts, streamed.counts, "cut at {at}");
            kept.insert(streamed.messages);
        }
        // Cuts inside the chunks kept 0, 30, 60 and (with only the footer
        // cut) all 90 messages: whole chunks, never part of one.
        assert_eq!(kept.into_iter().collect::<Vec<_>>(), [0, 30, 60, 90]);
    }
}
