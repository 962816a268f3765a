//! `orchestrator record recover`: a complete copy of a recording cut short.
//!
//! Why: a recording cut by `kill -9` (or a power cut) is a valid MCAP
//! prefix without summary and footer. Streaming readers read it (Foxglove,
//! `mcap recover`, Python's `NonSeekingReader`, our [`super::recover`]), but
//! Python `mcap`'s `make_reader` seeks to the footer first and fails. This
//! copies every schema, channel, message (log and publish times, sequence
//! numbers, bytes) and metadata record up to the first damaged record into
//! a new file, finished with summary and footer, so every reader opens it.
//! It streams through the `mcap` crate's sans-IO linear reader (chunks are
//! opened by the reader) and writes with the crate's writer: nothing of the
//! format is hand-written here.

use std::collections::HashMap;
use std::io::{BufReader, BufWriter, Read};
use std::path::Path;

use mcap::records::{MessageHeader, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::{McapError, WriteOptions, Writer};

use super::read::{not_mcap, open_recording};
use super::{RecordError, Recovered, CHUNK_SIZE};
use crate::out::{write_with, OutputError};

/// Copies every complete record of `input` into a finished recording at
/// `output`, written to a temporary file beside it and renamed over it only
/// when complete: `input` is never truncated, even when it is `output`
/// (the caller applies the overwrite rule, `crate::out::files`). Returns
/// what was kept and why reading stopped (`None`: the input was complete).
pub fn rewrite(input: &Path, output: &Path) -> Result<Recovered, RecordError> {
    let (file, len) = open_recording(input)?;
    let write_error = |source| RecordError::Write { path: output.to_path_buf(), source };
    let sync_error = |source| RecordError::Sync { path: output.to_path_buf(), source };
    let written = write_with(output, |out| {
        let options =
            WriteOptions::new().compression(super::COMPRESSION).use_chunks(true).chunk_size(Some(CHUNK_SIZE));
        let mut writer = Writer::with_options(BufWriter::new(out), options).map_err(write_error)?;
        let recovered = copy(BufReader::new(file), len, &mut writer).map_err(|e| match e {
            Failure::Read(source) => not_mcap(input, &source),
            Failure::Write(source) => write_error(source),
        })?;
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

enum Failure {
    /// The input is not MCAP at all.
    Read(McapError),
    /// The output could not be written.
    Write(McapError),
}

/// Streams the records of `source` into `writer`.
fn copy<R: Read, W: std::io::Write + std::io::Seek>(
    mut source: R,
    len: u64,
    writer: &mut Writer<W>,
) -> Result<Recovered, Failure> {
    let limit = usize::try_from(len).unwrap_or(usize::MAX);
    let mut reader =
        LinearReader::new_with_options(LinearReaderOptions::default().with_record_length_limit(limit));
    let mut schemas: HashMap<u16, (String, String, Vec<u8>)> = HashMap::new();
    let mut schema_ids: HashMap<u16, u16> = HashMap::new();
    let mut channels: HashMap<u16, (u16, String)> = HashMap::new();
    let mut recovered = Recovered::default();
    let mut complete = false;
    let stop = |recovered: &mut Recovered, error: McapError| -> Result<(), Failure> {
        match (&error, recovered.messages) {
            (McapError::BadMagic, 0) => Err(Failure::Read(error)),
            _ => {
                recovered.stopped_by = Some(error.to_string());
                Ok(())
            }
        }
    };
    while let Some(event) = reader.next_event() {
        let (opcode, data) = match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let read = loop {
                    match source.read(reader.insert(need)) {
                        Ok(n) => break n,
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                        Err(e) => {
                            stop(&mut recovered, e.into())?;
                            return Ok(recovered);
                        }
                    }
                };
                reader.notify_read(read);
                continue;
            }
            Ok(LinearReadEvent::Record { opcode, data }) => (opcode, data),
            Err(error) => {
                stop(&mut recovered, error)?;
                return Ok(recovered);
            }
        };
        let record = match mcap::parse_record(opcode, data) {
            Ok(record) => record,
            Err(error) => {
                stop(&mut recovered, error)?;
                return Ok(recovered);
            }
        };
        match record {
            Record::Schema { header, data } => {
                schemas.insert(header.id, (header.name, header.encoding, data.into_owned()));
            }
            Record::Channel(channel) => {
                let schema_id = match channel.schema_id {
                    0 => 0,
                    id => match (schema_ids.get(&id), schemas.get(&id)) {
                        (Some(&new), _) => new,
                        (None, Some((name, encoding, data))) => {
                            let new = writer.add_schema(name, encoding, data).map_err(Failure::Write)?;
                            schema_ids.insert(id, new);
                            new
                        }
                        // A channel whose schema record was lost: keep it without one.
                        (None, None) => 0,
                    },
                };
                let new = writer
                    .add_channel(schema_id, &channel.topic, &channel.message_encoding, &channel.metadata)
                    .map_err(Failure::Write)?;
                channels.insert(channel.id, (new, channel.topic));
            }
            Record::Message { header, data } => {
                let Some((channel_id, topic)) = channels.get(&header.channel_id) else { continue };
                let header = MessageHeader { channel_id: *channel_id, ..header };
                writer.write_to_known_channel(&header, &data).map_err(Failure::Write)?;
                *recovered.counts.entry(topic.clone()).or_insert(0) += 1;
                recovered.messages += 1;
            }
            Record::Metadata(metadata) => writer.write_metadata(&metadata).map_err(Failure::Write)?,
            Record::Footer(_) => complete = true,
            _ => {}
        }
    }
    if !complete && recovered.stopped_by.is_none() {
        recovered.stopped_by = Some("the file ends without a footer".into());
    }
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
