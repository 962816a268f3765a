//! Reading recordings back, including the truncated ones a crash leaves behind: the one
//! streaming reader of a recording.
//!
//! Why one reader: `draw FILE.mcap` (`bycoms_study::draw::run`), `replay` (`bycoms_orchestrator::replay::read`) and
//! `record recover` ([`super::recover`], [`super::rewrite`]) all read the same files, and each used to
//! walk them itself, with its own rule for where a cut file stops and when a file is "not a
//! recording". [`Reader::stream`] is that walk, once:
//!
//! * the file is streamed record by record through the `mcap` crate's sans-IO linear reader
//!   (chunks are opened by it, any compression MCAP allows), never through its summary, so a
//!   file without footer is read like any other; memory is one record or chunk (at most
//!   [`MAX_CHUNK_BYTES`] decompressed), not the file;
//! * schemas and channels are linked as they come (the crate's `ChannelAccumulator`, with
//!   its checks), so every message arrives with its channel and schema;
//! * every CRC the file carries is checked: each chunk is decompressed whole and its
//!   `uncompressed_crc` checked *before* any of its messages is handed out, attachments'
//!   CRCs, the data section's (DataEnd) and the summary's (footer). `draw` and `replay`
//!   ([`Reader::stream`]) refuse a damaged file ([`RecordError::Damaged`], naming the file
//!   and the byte the damaged part starts at) rather than read corrupt bytes; `record
//!   recover` ([`Reader::salvage`]) leaves the damaged parts out and says which
//!   ([`End::damage`]), so a corrupt chunk is never copied under fresh CRCs. A damaged
//!   summary is only noted: nothing here reads it, and a copy rebuilds it;
//! * a file cut short (it ends inside a record) is read up to its last complete record,
//!   then reading stops and says why ([`End::stopped_by`]);
//! * a file whose magic is wrong is [`RecordError::NotMcap`], and a valid MCAP file without
//!   the run metadata is [`RecordError::NotLaunch`] ([`End::launch_recording`]): the one
//!   "not a recording" error of every command each.
//!
//! Why chunks are read whole (emitted by the linear reader, then read by a second one that
//! prevalidates their CRC) rather than streamed record by record: a streamed chunk's CRC is
//! known only after its messages were handed out, too late to leave them out.
//!
//! What a message *means* is [`super::decode`]'s, once as well.

use std::fmt;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use mcap::read::ChannelAccumulator;
use mcap::records::{self, op, MessageHeader, Metadata, Record, SchemaHeader};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::{Attachment, Channel, McapError};

use super::{schema, Damage, Part, RecordError};

/// The most bytes one chunk may hold once decompressed: what reading a chunk may take in
/// memory (it is decompressed whole and its CRC checked before any of its messages is handed
/// out). A recording's chunks hold about [`super::CHUNK_SIZE`] (1 MiB); a larger claim is
/// damage, not a reason to allocate.
pub const MAX_CHUNK_BYTES: usize = 256 * 1024 * 1024;

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
    /// An attachment whose CRC verified (a launch writes none; other tools may).
    Attachment(Attachment<'a>),
}

/// How reading a recording ended.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct End {
    /// Messages handed out.
    pub messages: u64,
    /// `None` if the file was read through its footer and end magic; otherwise why reading
    /// ended early: where the file is cut (the recording process died), or the damaged
    /// record [`Reader::salvage`] could not read past.
    pub stopped_by: Option<String>,
    /// Every damaged part met ([`Reader::salvage`]; [`Reader::stream`] refuses all but a
    /// damaged summary, which it does not read).
    pub damage: Vec<Damage>,
    /// Messages left out by [`Reader::salvage`] because their channel was defined in a
    /// dropped chunk (and the file has no summary to link them with, or a damaged one).
    pub orphans: u64,
    /// Messages of the run metadata (`bycoms/<swarm>/run`): a launch recording has one.
    pub runs: u64,
    /// The writer the header names (`bycoms-orchestrator/…` for the launch's recordings).
    pub library: Option<String>,
    /// What this copy lacks, when `record recover` wrote it from a recording cut short or
    /// damaged ([`schema::RECOVERED_METADATA`]): it is not the whole run.
    pub partial: Option<String>,
}

impl End {
    /// Chunks dropped as damaged.
    pub fn dropped_chunks(&self) -> usize {
        self.damage.iter().filter(|d| d.part == Part::Chunk).count()
    }

    /// Whether any data (not only the summary, which is rebuilt) was damaged.
    pub fn data_damaged(&self) -> bool {
        self.damage.iter().any(|d| d.part != Part::Summary)
    }

    /// `Ok` when the file is a launch recording (it holds the run metadata); otherwise
    /// [`RecordError::NotLaunch`], the one error of `draw`, `replay` and `record recover` for
    /// a valid MCAP file that is not a launch's.
    pub fn launch_recording(&self, path: &Path) -> Result<(), RecordError> {
        if self.runs > 0 {
            return Ok(());
        }
        let ours = self.library.as_deref().is_some_and(|l| l.starts_with(super::LIBRARY_NAME));
        // The launch writes its run metadata first: a launch's file without it whose
        // first chunk was left out lost it with that chunk.
        if let Some(damage) = self.damage.iter().find(|d| d.part == Part::Chunk).filter(|_| ours) {
            return Err(RecordError::RunMetaDamaged { path: path.to_path_buf(), damage: damage.clone() });
        }
        let ours = ours && self.messages == 0;
        let reason = if ours {
            "it holds no message: the launch was cut before it wrote anything (no run metadata, bycoms/<swarm>/run)"
        } else {
            "it holds no run metadata (bycoms/<swarm>/run)"
        };
        Err(RecordError::NotLaunch { path: path.to_path_buf(), reason: reason.into() })
    }
}

/// What [`stream_from`] does with a damaged part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// Stop with [`Stop::Damaged`] (before any message of a damaged chunk is handed out).
    Refuse,
    /// Leave the part out, note it in [`End::damage`] and read on.
    Skip,
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

    /// Streams the recording through `visit`, item by item, up to its end or where it is
    /// cut. Fails when the file is not MCAP, when `visit` fails (reading stops at once then),
    /// and at the first damaged part ([`RecordError::Damaged`], naming the file and the byte
    /// it starts at): a chunk whose CRC fails is refused before any of its messages is handed
    /// out. A damaged summary (never read here) is only warned about.
    pub fn stream<E: From<RecordError>>(
        self,
        visit: impl FnMut(Item<'_>) -> Result<(), E>,
    ) -> Result<End, E> {
        let path = self.path.clone();
        let end = self.read(Mode::Refuse, visit)?;
        for damage in &end.damage {
            tracing::warn!(
                "{}: {damage}; not used here (`orchestrator record recover` rebuilds it)",
                path.display()
            );
        }
        if let Some(partial) = &end.partial {
            tracing::warn!(
                "{}: not the whole run, a copy by `orchestrator record recover`: {partial}",
                path.display()
            );
        }
        Ok(end)
    }

    /// Streams what verifies through `visit`: a damaged chunk or attachment is left out and
    /// reading goes on after it; everything left out is in [`End::damage`]. What
    /// `record recover` copies.
    pub fn salvage<E: From<RecordError>>(
        self,
        visit: impl FnMut(Item<'_>) -> Result<(), E>,
    ) -> Result<End, E> {
        self.read(Mode::Skip, visit)
    }

    fn read<E: From<RecordError>>(
        self,
        mode: Mode,
        visit: impl FnMut(Item<'_>) -> Result<(), E>,
    ) -> Result<End, E> {
        let Reader { path, mut file, len } = self;
        let summary = match mode {
            Mode::Skip => summary_channels(&mut file, len),
            Mode::Refuse => None,
        };
        file.rewind().map_err(|source| RecordError::Open { path: path.clone(), source })?;
        stream_from(BufReader::new(file), len, mode, summary, visit).map_err(|stop| match stop {
            Stop::NotMcap(error) => not_mcap(&path, &error).into(),
            Stop::Damaged(damage) => RecordError::Damaged { path: path.clone(), damage }.into(),
            Stop::Visit(error) => error,
        })
    }
}

/// Why [`stream_from`] gave up.
enum Stop<E> {
    /// The source is not MCAP (wrong magic at its start).
    NotMcap(McapError),
    /// A damaged part, in [`Mode::Refuse`].
    Damaged(Damage),
    /// The visitor failed.
    Visit(E),
}

/// Where [`stream_from`] is: what every record read so far set.
struct Walk {
    mode: Mode,
    linked: ChannelAccumulator<'static>,
    /// The schemas and channels the summary repeats ([`summary_channels`]), for the messages
    /// whose channel was defined in a dropped chunk ([`Mode::Skip`]).
    summary: Option<ChannelAccumulator<'static>>,
    end: End,
}

impl Walk {
    /// A damaged part: refused, or noted and left out.
    fn damaged<E>(&mut self, offset: u64, part: Part, why: impl fmt::Display) -> Result<(), Stop<E>> {
        let damage = Damage { offset, part, why: why.to_string() };
        match self.mode {
            Mode::Refuse => Err(Stop::Damaged(damage)),
            Mode::Skip => {
                self.end.damage.push(damage);
                Ok(())
            }
        }
    }

    /// Takes one record of the data section (inside a chunk or not); `Err(Ok(error))`: the
    /// record is damaged.
    fn take<E>(
        &mut self,
        record: Record<'_>,
        visit: &mut impl FnMut(Item<'_>) -> Result<(), E>,
    ) -> Result<(), Result<McapError, E>> {
        match record {
            Record::Header(header) => self.end.library = Some(header.library),
            Record::Schema { header, data } => {
                self.linked.add_schema_from_slice(header, &data).map_err(Ok)?;
            }
            Record::Channel(channel) => {
                let id = channel.id;
                let new = self.linked.get(id).is_none();
                self.linked.add_channel(channel).map_err(Ok)?;
                if let Some(channel) = self.linked.get(id).filter(|_| new) {
                    visit(Item::Channel(&channel)).map_err(Err)?;
                }
            }
            Record::Message { header, data } => {
                let channel = match self.linked.get(header.channel_id) {
                    Some(channel) => channel,
                    // Its channel was defined in a chunk left out: the summary's copy of it
                    // (a finished file), or the message goes with the chunk.
                    None if self.end.dropped_chunks() > 0 => {
                        match self.link_from_summary(header.channel_id) {
                            Some(channel) => {
                                visit(Item::Channel(&channel)).map_err(Err)?;
                                channel
                            }
                            None => {
                                self.end.orphans += 1;
                                return Ok(());
                            }
                        }
                    }
                    None => return Err(Ok(McapError::UnknownChannel(header.sequence, header.channel_id))),
                };
                self.end.messages += 1;
                if is_run(&channel) {
                    self.end.runs += 1;
                }
                visit(Item::Message { channel: &channel, header, data: &data }).map_err(Err)?;
            }
            Record::Metadata(metadata) => {
                if metadata.name == schema::RECOVERED_METADATA {
                    self.end.partial = metadata.metadata.get(schema::RECOVERED_PARTIAL).cloned();
                }
                visit(Item::Metadata(metadata)).map_err(Err)?;
            }
            Record::Attachment { header, data, .. } => {
                let attachment = Attachment {
                    log_time: header.log_time,
                    create_time: header.create_time,
                    name: header.name,
                    media_type: header.media_type,
                    data,
                };
                visit(Item::Attachment(attachment)).map_err(Err)?;
            }
            _ => {}
        }
        Ok(())
    }

    /// Channel `id` as the summary defines it, linked from now on.
    fn link_from_summary(&mut self, id: u16) -> Option<Arc<Channel<'static>>> {
        let channel = self.summary.as_ref()?.get(id)?;
        if let Some(schema) = &channel.schema {
            let header =
                SchemaHeader { id: schema.id, name: schema.name.clone(), encoding: schema.encoding.clone() };
            self.linked.add_schema(header, schema.data.clone()).ok()?;
        }
        let record = records::Channel {
            id,
            schema_id: channel.schema.as_ref().map_or(0, |s| s.id),
            topic: channel.topic.clone(),
            message_encoding: channel.message_encoding.clone(),
            metadata: channel.metadata.clone(),
        };
        self.linked.add_channel(record).ok()?;
        self.linked.get(id)
    }

    /// Reads one chunk record (its body `body`, at byte `offset`): decompressed whole, its
    /// CRC checked, then its records taken. A chunk that fails is damaged.
    fn chunk<E>(
        &mut self,
        offset: u64,
        body: &[u8],
        visit: &mut impl FnMut(Item<'_>) -> Result<(), E>,
    ) -> Result<(), Stop<E>> {
        let options = LinearReaderOptions::default()
            .with_skip_start_magic(true)
            .with_skip_end_magic(true)
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(MAX_CHUNK_BYTES);
        let mut reader = LinearReader::new_with_options(options);
        let head = [[op::CHUNK].as_slice(), &(body.len() as u64).to_le_bytes()].concat();
        let mut source = head.as_slice().chain(body);
        let failed = loop {
            let (opcode, data) = match reader.next_event() {
                None => break None,
                Some(Ok(LinearReadEvent::ReadRequest(need))) => {
                    // Reading from memory cannot fail.
                    let n = source.read(reader.insert(need)).unwrap_or(0);
                    reader.notify_read(n);
                    continue;
                }
                Some(Ok(LinearReadEvent::Record { opcode, data })) => (opcode, data),
                Some(Err(error)) => break Some(error),
            };
            match mcap::parse_record(opcode, data).map_err(Ok).and_then(|r| self.take(r, visit)) {
                Ok(()) => {}
                Err(Ok(error)) => break Some(error),
                Err(Err(error)) => return Err(Stop::Visit(error)),
            }
        };
        match failed {
            Some(error) => self.damaged(offset, Part::Chunk, error),
            None => Ok(()),
        }
    }
}

/// The schemas and channels the summary of a finished file repeats, if its CRC verifies
/// (`None` for a cut file, which has no summary, or a damaged one): what
/// [`Reader::salvage`] links the messages to whose channel was defined in a dropped chunk.
/// Read from the data section's end record (13 bytes: opcode, length, CRC) before the
/// summary, so the linear reader checks the summary's CRC at the footer as it does for a
/// whole file.
fn summary_channels(file: &mut File, len: u64) -> Option<ChannelAccumulator<'static>> {
    const TAIL: u64 = 9 + 20 + 8; // the footer record and the end magic
    let mut tail = [0u8; TAIL as usize];
    file.seek(SeekFrom::Start(len.checked_sub(TAIL)?)).ok()?;
    file.read_exact(&mut tail).ok()?;
    if tail[0] != op::FOOTER || tail[29..] != *mcap::MAGIC {
        return None;
    }
    let summary_start = u64::from_le_bytes(tail[9..17].try_into().ok()?);
    let data_end = summary_start.checked_sub(13).filter(|&at| at >= mcap::MAGIC.len() as u64)?;
    file.seek(SeekFrom::Start(data_end)).ok()?;
    let options = LinearReaderOptions::default()
        .with_skip_start_magic(true)
        .with_validate_summary_section_crc(true)
        .with_record_length_limit(usize::try_from(len).unwrap_or(usize::MAX));
    let mut reader = LinearReader::new_with_options(options);
    let mut source = BufReader::new(file);
    let mut linked = ChannelAccumulator::default();
    while let Some(event) = reader.next_event() {
        match event.ok()? {
            LinearReadEvent::ReadRequest(need) => {
                let n = source.read(reader.insert(need)).ok()?;
                reader.notify_read(n);
            }
            LinearReadEvent::Record { opcode, data } => match mcap::parse_record(opcode, data).ok()? {
                Record::Schema { header, data } => linked.add_schema_from_slice(header, &data).ok()?,
                Record::Channel(channel) => linked.add_channel(channel).ok()?,
                _ => {}
            },
        }
    }
    Some(linked)
}

/// Whether `channel` carries the run metadata (what `decode` reads as `Content::Run`).
fn is_run(channel: &Channel<'_>) -> bool {
    channel.schema.as_ref().is_some_and(|s| s.name == schema::RUN) && schema::is_run_topic(&channel.topic)
}

/// The streaming core of [`Reader::stream`]: `len` bounds the record lengths believed.
fn stream_from<R: Read, E>(
    mut source: R,
    len: u64,
    mode: Mode,
    summary: Option<ChannelAccumulator<'static>>,
    mut visit: impl FnMut(Item<'_>) -> Result<(), E>,
) -> Result<End, Stop<E>> {
    let options = LinearReaderOptions::default()
        .with_emit_chunks(true)
        .with_validate_data_section_crc(true)
        .with_validate_summary_section_crc(true)
        .with_record_length_limit(usize::try_from(len).unwrap_or(usize::MAX));
    let mut reader = LinearReader::new_with_options(options);
    let mut walk = Walk { mode, linked: ChannelAccumulator::default(), summary, end: End::default() };
    // Where the next record starts; the summary repeats schemas and channels: past the data
    // end they are not linked again.
    let (mut offset, mut past_data_end, mut footer) = (mcap::MAGIC.len() as u64, false, false);
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
        let at = offset;
        offset += 9 + data.len() as u64;
        match opcode {
            op::DATA_END => past_data_end = true,
            op::FOOTER => footer = true,
            _ if past_data_end => {}
            op::CHUNK => walk.chunk(at, data, &mut visit)?,
            _ => match mcap::parse_record(opcode, data).map_err(Ok).and_then(|r| walk.take(r, &mut visit)) {
                Ok(()) => {}
                Err(Ok(error @ McapError::BadAttachmentCrc { .. })) => {
                    walk.damaged(at, Part::Attachment, error)?;
                }
                Err(Ok(error)) => walk.damaged(at, Part::Record, error)?,
                Err(Err(error)) => return Err(Stop::Visit(error)),
            },
        }
    };
    match error {
        None if !footer => {
            walk.end.stopped_by = Some("the file ends without a footer".into());
            Ok(walk.end)
        }
        None => Ok(walk.end),
        Some(error) => stopped(walk, error, offset, len),
    }
}

/// How reading that ended on `error` at byte `offset` of a file of `len` bytes ends: a cut
/// file, damage, or a file that is not MCAP.
fn stopped<E>(mut walk: Walk, error: McapError, offset: u64, len: u64) -> Result<End, Stop<E>> {
    match error {
        // Wrong magic where the file starts: this is not a recording.
        McapError::BadMagic if offset == mcap::MAGIC.len() as u64 && walk.end.messages == 0 => {
            Err(Stop::NotMcap(McapError::BadMagic))
        }
        // The file ends inside a record: cut where the recording process died.
        McapError::UnexpectedEof => {
            walk.end.stopped_by = Some(format!("{error} (the record at byte {offset} is cut short)"));
            Ok(walk.end)
        }
        // A record longer than the file is believed only as far as the file goes: the file
        // was cut inside it (or its length is damaged; the two look alike).
        McapError::RecordTooLarge { len: claimed, .. }
            if offset.saturating_add(9).saturating_add(claimed) > len =>
        {
            walk.end.stopped_by = Some(format!(
                "the file ends inside the record at byte {offset} ({claimed} bytes long): cut short"
            ));
            Ok(walk.end)
        }
        // A damaged chunk or record fails the data section's CRC too: said once.
        McapError::BadDataCrc { .. } if walk.end.data_damaged() => Ok(walk.end),
        McapError::BadDataCrc { .. } => walk.damaged(offset, Part::DataSection, error).map(|()| walk.end),
        McapError::BadSummaryCrc { .. } => {
            walk.end.damage.push(Damage { offset, part: Part::Summary, why: error.to_string() });
            Ok(walk.end)
        }
        error => {
            walk.damaged(offset, Part::Record, &error)?;
            walk.end.stopped_by =
                Some(format!("the record at byte {offset} is damaged ({error}); nothing after it is read"));
            Ok(walk.end)
        }
    }
}

/// Opens a recording to read and returns it with its length, after checking that it is one: it starts with the MCAP magic bytes. An
/// empty file, a text, random bytes or garbage is [`RecordError::NotMcap`], the one "not an
/// MCAP file" error of every command that reads recordings (a recording cut by a crash still
/// starts with the magic: `Recorder::create` writes it at once).
pub fn open_recording(path: &Path) -> Result<(File, u64), RecordError> {
    let open_error = |source| RecordError::Open { path: path.to_path_buf(), source };
    let mut file = File::open(path).map_err(open_error)?;
    let meta = file.metadata().map_err(open_error)?;
    let regular = meta.is_file();
    let reason = if meta.is_dir() {
        Some("it is a directory")
    } else if regular && meta.len() == 0 {
        Some("the file is empty")
    } else {
        // A device or a pipe has no length (`/dev/urandom` is not "empty"): its first bytes
        // say what it is. Read once, they are handed to the reader again.
        let mut head = Vec::with_capacity(mcap::MAGIC.len());
        (&mut file).take(mcap::MAGIC.len() as u64).read_to_end(&mut head).map_err(open_error)?;
        if regular {
            file.rewind().map_err(open_error)?;
        }
        match head.len() {
            0 => Some("the file is empty"),
            _ if head != mcap::MAGIC => Some("it does not start with the MCAP magic bytes"),
            _ if !regular => Some("it is not a regular file (a recording is read from a file)"),
            _ => None,
        }
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

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::io::Cursor;

    use super::*;
    use crate::{recover, Recorder, Recovered};

    /// [`crate::recover`] of any source: `len` bounds the record lengths believed.
    fn recover_from<R: Read>(source: R, len: u64) -> Result<Recovered, McapError> {
        let mut recovered = Recovered::default();
        let end = stream_from(source, len, Mode::Skip, None, |item| {
            if let Item::Message { channel, .. } = item {
                recovered.count(&channel.topic);
            }
            Ok::<_, std::convert::Infallible>(())
        });
        match end {
            Ok(end) => {
                recovered.ended(end);
                Ok(recovered)
            }
            Err(Stop::NotMcap(error)) => Err(error),
            Err(Stop::Damaged(damage)) => unreachable!("skipped, not refused: {damage}"),
            Err(Stop::Visit(never)) => match never {},
        }
    }

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

    /// [`sample`] with one byte of its file changed by `damage` (given the bytes and the
    /// finished file's summary), written to a file of its own.
    fn damaged(
        damage: impl FnOnce(&mut Vec<u8>, &mcap::Summary),
    ) -> (tempfile::TempDir, PathBuf, BTreeMap<String, u64>) {
        let (mut bytes, counts) = sample();
        let summary = mcap::Summary::read(&bytes).expect("summary").expect("a finished file");
        damage(&mut bytes, &summary);
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("damaged.mcap");
        std::fs::write(&path, &bytes).expect("write");
        (dir, path, counts)
    }

    /// The second chunk's start and its messages per topic.
    fn second_chunk(summary: &mcap::Summary) -> (u64, u64) {
        let chunk = &summary.chunk_indexes[1];
        (chunk.chunk_start_offset, chunk.message_index_offsets.len() as u64)
    }

    /// Strict reading ([`Reader::stream`]), counting messages.
    fn strict(path: &Path) -> Result<End, RecordError> {
        Reader::open(path)?.stream(|_| Ok::<_, RecordError>(()))
    }

    #[test]
    fn a_chunk_whose_crc_fails_is_refused_by_readers_and_left_out_by_recover() {
        // The second chunk's stored CRC (after opcode, length, start and end times and size).
        let at = std::cell::Cell::new(0);
        let (_dir, path, counts) = damaged(|bytes, summary| {
            let (offset, _) = second_chunk(summary);
            at.set(offset);
            bytes[offset as usize + 9 + 24] ^= 0x01;
        });
        let error = strict(&path).expect_err("a damaged chunk is refused");
        let text = error.to_string();
        assert!(
            matches!(&error, RecordError::Damaged { damage, .. } if damage.part == Part::Chunk && damage.offset == at.get()),
            "{error:?}"
        );
        assert!(
            text.contains("damaged.mcap") && text.contains(&format!("chunk at byte {}", at.get())),
            "{text}"
        );
        assert!(text.contains("CRC"), "{text}");
        let recovered = recover(&path).expect("recover salvages");
        assert_eq!(recovered.dropped_chunks(), 1, "{:?}", recovered.damage);
        assert_eq!(
            recovered.damage.len(),
            1,
            "the data CRC's failure is the chunk's: said once: {:?}",
            recovered.damage
        );
        assert_eq!(
            recovered.messages,
            counts.values().sum::<u64>() - 20,
            "the chunk's 20 messages are left out"
        );
    }

    #[test]
    fn a_chunk_whose_bytes_are_damaged_is_refused_too() {
        let (_dir, path, _) = damaged(|bytes, summary| {
            let chunk = &summary.chunk_indexes[1];
            let middle = chunk.chunk_start_offset + chunk.chunk_length - 4;
            bytes[middle as usize] ^= 0x40;
        });
        let error = strict(&path).expect_err("refused");
        assert!(
            matches!(&error, RecordError::Damaged { damage, .. } if damage.part == Part::Chunk),
            "{error:?}"
        );
        assert_eq!(recover(&path).expect("salvaged").dropped_chunks(), 1);
    }

    #[test]
    fn a_damaged_record_outside_the_chunks_fails_the_data_section_crc() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("meta.mcap");
        let mut recorder = Recorder::create(&path).expect("create");
        recorder.record_bytes("a/pose", "bycoms.Test", 1, 1, b"x").expect("record");
        let meta = BTreeMap::from([("clock".to_string(), "wall-clock-time".to_string())]);
        recorder.write_metadata("bycoms.clock", meta).expect("metadata");
        recorder.finish().expect("finish");
        let mut bytes = std::fs::read(&path).expect("read");
        let at = bytes.windows(15).position(|w| w == b"wall-clock-time").expect("the metadata's bytes");
        bytes[at] = b'W';
        std::fs::write(&path, &bytes).expect("write");
        let error = strict(&path).expect_err("refused");
        assert!(
            matches!(&error, RecordError::Damaged { damage, .. } if damage.part == Part::DataSection),
            "{error:?}"
        );
        let recovered = recover(&path).expect("salvaged");
        assert_eq!(recovered.damage.iter().map(|d| d.part).collect::<Vec<_>>(), [Part::DataSection]);
    }

    #[test]
    fn a_damaged_summary_is_noted_but_not_refused() {
        let (_dir, path, counts) = damaged(|bytes, _| {
            // The statistics record's message count, in the summary (before the footer).
            let footer = bytes.len() - mcap::MAGIC.len() - 9 - 20;
            bytes[footer - 30] ^= 0x01;
        });
        let end = strict(&path).expect("the summary is not read");
        assert_eq!(end.damage.iter().map(|d| d.part).collect::<Vec<_>>(), [Part::Summary]);
        let recovered = recover(&path).expect("salvaged");
        assert_eq!(recovered.counts, counts);
        assert_eq!(recovered.damage.iter().map(|d| d.part).collect::<Vec<_>>(), [Part::Summary]);
    }

    #[test]
    fn an_attachment_whose_crc_fails_is_refused_and_left_out_and_a_sound_one_is_handed_out() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("attached.mcap");
        let mut writer =
            mcap::Writer::new(std::io::BufWriter::new(File::create(&path).expect("create"))).expect("writer");
        for name in ["first", "second"] {
            let data = std::borrow::Cow::Borrowed(&b"attached bytes"[..]);
            let attachment = Attachment {
                log_time: 1,
                create_time: 1,
                name: name.into(),
                media_type: "text/plain".into(),
                data,
            };
            writer.attach(&attachment).expect("attach");
        }
        writer.finish().expect("finish");
        drop(writer);
        let mut bytes = std::fs::read(&path).expect("read");
        let at = bytes.windows(14).rposition(|w| w == b"attached bytes").expect("the second's bytes");
        bytes[at] = b'A';
        std::fs::write(&path, &bytes).expect("write");
        let error = strict(&path).expect_err("refused");
        assert!(
            matches!(&error, RecordError::Damaged { damage, .. } if damage.part == Part::Attachment),
            "{error:?}"
        );
        let mut names = Vec::new();
        let end = Reader::open(&path)
            .expect("open")
            .salvage(|item| {
                if let Item::Attachment(a) = item {
                    names.push(a.name);
                }
                Ok::<_, RecordError>(())
            })
            .expect("salvaged");
        assert_eq!(names, ["first"]);
        assert_eq!(end.damage.iter().map(|d| d.part).collect::<Vec<_>>(), [Part::Attachment]);
    }

    #[test]
    fn random_bytes_from_a_device_are_not_an_mcap_file_not_an_empty_one() {
        let error = open_recording(Path::new("/dev/urandom")).expect_err("not MCAP");
        let text = error.to_string();
        assert!(text.contains("/dev/urandom is not an MCAP file"), "{text}");
        assert!(text.contains("does not start with the MCAP magic bytes"), "{text}");
        let error = open_recording(Path::new("/dev/null")).expect_err("not MCAP");
        assert!(error.to_string().contains("is empty"), "{error}");
    }
}
