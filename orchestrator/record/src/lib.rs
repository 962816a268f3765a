//! MCAP recordings of launch runs: every bus message and every gate event, in one file.
//!
//! # Why MCAP
//!
//! MCAP is the container the robotics tooling reads: Foxglove opens it directly, the `mcap` CLI
//! (`mcap info`, `mcap cat`, `mcap recover`) and the Python/C++/TypeScript `mcap` libraries read
//! it, and ROS 2 bags use it too. One self-describing file per run: each record carries its topic,
//! its encoding, its log time (when the orchestrator saw it) and its publish time (when the sender
//! stamped it), so a run can be replayed, plotted or compared with the in-process simulator later.
//!
//! # What is recorded
//!
//! * Bus traffic, byte for byte, with [`Recorder::record_bytes`]: the postcard-encoded protocol
//!   messages exactly as they crossed the bus. Channel message encoding `postcard`; the schema
//!   record carries the Rust type name given by the caller (e.g. `bycoms.ToAgent`) with an empty
//!   schema encoding, since postcard has no self-describing schema format.
//! * Human-readable events with [`Recorder::record_json`]: gate decisions, run metadata, lost
//!   agents. Message encoding `json`, schema encoding `jsonschema` with empty schema data, which
//!   Foxglove decodes as plain JSON (its JSON channels need `jsonschema` or no schema).
//!
//! * Decoded channels with [`Recorder::record_encoded`]: messages already encoded (protobuf or
//!   JSON) with a real schema (Foxglove's well-known protobuf schemas, JSON schemas) — what
//!   `crate::scene` makes of the bus traffic, so Foxglove shows a run without a plugin.
//! * Metadata records ([`Recorder::write_metadata`]), e.g. `bycoms.clock`: what the log times
//!   mean (simulated time in lockstep, wall clock in real time).
//!
//! Every schema name and the recording's own topics are defined once, in [`schema`]. A
//! recording is read back by one streaming reader ([`Reader`], [`read`]) and its messages are
//! decoded in one place ([`decode`]): `draw` (`draw::run`), `replay` and `record recover`
//! ([`recover`], [`rewrite`]) share both, so they agree on what a file holds and where a cut
//! file stops. A cut recording is completed by [`rewrite`] (`orchestrator record recover`);
//! which files a recording may replace is the rule every output follows ([`bycoms_runtime::out::files`]).
//!
//! # Topic naming
//!
//! Topics are the caller's: bus messages keep the protocol's own topic names (whatever
//! `bycoms-protocol` calls the topic the message was published on), so a recording lists the same
//! names the bus uses. Orchestrator events go on topics of the same tree, e.g.
//! `bycoms/<swarm>/gate` for gate events and `bycoms/<swarm>/run` for run metadata. A channel is
//! created the first time a topic is used; one topic keeps one encoding and schema for the whole
//! run ([`RecordError::TopicMismatch`] otherwise).
//!
//! # Crash survival
//!
//! A run can end by `kill -9`, a panic or a power cut, and the recording must still hold
//! everything up to the last second. The file is written **chunked, zstd-compressed, with chunks
//! buffered in memory** (the `mcap` writer's `disable_seeking` mode):
//!
//! * messages go into an in-memory chunk; a chunk reaches the file only whole, as one record
//!   followed by its message indexes, so the file on disk is always a valid MCAP prefix: header,
//!   complete chunks, and at worst one torn chunk at the very end;
//! * a chunk is closed and handed to the kernel when it passes [`CHUNK_SIZE`] bytes and, above
//!   all, on every flush: `record_*` flushes by itself when [`FLUSH_INTERVAL`] (1 s) has passed
//!   since the last flush, and the caller calls [`Recorder::flush_if_due`] from its own timer so
//!   that the tail of a quiet period is not held back until the next message. Both ask the one
//!   clock of the recorder: one chunk a second, not one per timer (two clocks that drift cut
//!   twice as many, smaller chunks, which compress worse and index more);
//! * after a crash the file has no summary or footer; [`Reader`] (behind [`read_counts`],
//!   [`recover`], `draw` and `replay`; and `mcap recover`, or any streaming MCAP reader) reads it
//!   front to back and keeps every message
//!   before the first damaged record — every complete chunk, wherever the file was cut, even
//!   inside a chunk or its message indexes (`every_cut_of_a_file_reads_without_error_and_counts_grow`
//!   cuts a file at every third byte). What is lost is at most what arrived since the last flush.
//!
//! Chunking rather than writing bare message records costs nothing in durability (the open chunk
//! is the unflushed second either way) and gives a finished file chunk and message indexes, so
//! Foxglove and `mcap info` can seek in long runs instead of scanning them. Each chunk is
//! compressed with zstd ([`COMPRESSION`]), as the `mcap` CLI and the Python writer do by default.
//! Measured (`orchestrator/benches/record_throughput.rs`, "codec": a 20-robot lockstep crowd's
//! 1.57 M messages re-written with each compression): none 145 MB, lz4 54 MB, zstd 41 MB, and
//! zstd wrote 1.42 M messages/s against lz4's 1.30 M: smaller and no slower, hence zstd. The
//! real-time launch (3 robots, long obstacle, `--speed 10`) was 3.3 MB uncompressed.
//! Compression runs on the writer's thread (`compression_threads(0)`): the crate's default,
//! one zstd worker per core, competes with the launch's own threads for the cores at every
//! chunk. Reading accepts every compression MCAP allows (zstd, lz4).
//!
//! Where the bytes go: a message costs its compressed payload plus 16 bytes of message index
//! (log time and offset, uncompressed, as the spec lays them out) — in a lockstep crowd, where
//! most messages are a few bytes of bus traffic, the index is more than half the file. So what
//! shrinks a recording is fewer messages: the decoded channels send only what changed
//! (`crate::scene`), the raw bus bytes stay, one record per message, for exact replay.
//!
//! `flush` hands the data to the kernel, which survives the death of the process (the kill-9
//! case); it does not `fsync` every second. [`Recorder::finish`] writes the summary and footer and
//! `fsync`s the file once.

pub mod decode;
mod error;
pub mod read;
mod recovered;
mod rewrite;
pub mod scene;
pub mod schema;

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use mcap::records::MessageHeader;
use mcap::{WriteOptions, Writer};

pub use error::{Damage, Part, RecordError};
pub use read::{open_recording, End, Item, Reader};
pub use recovered::{read_counts, recover, Recovered};
pub use rewrite::rewrite;
pub use schema::{JSON, POSTCARD};

/// The name a recording's header gives as its writer (with the version): what tells a launch
/// recording cut before its first chunk from any other MCAP file.
pub const LIBRARY_NAME: &str = "bycoms-orchestrator";

/// The header's `library` of the recordings written here (`record recover`'s copies too).
pub fn library() -> String {
    format!("{LIBRARY_NAME}/{} {}", env!("CARGO_PKG_VERSION"), mcap::LIBRARY_IDENTIFIER)
}

/// The longest time data may sit in memory before `record_*` flushes it on its own.
pub const FLUSH_INTERVAL: Duration = Duration::from_secs(1);

/// How every chunk is compressed (see the module docs for the figures).
pub const COMPRESSION: Option<mcap::Compression> = Some(mcap::Compression::Zstd);

/// The uncompressed size past which a chunk is closed even before [`FLUSH_INTERVAL`]: the
/// `mcap` writer's default (1 MiB), the memory one open chunk may take.
pub const CHUNK_SIZE: u64 = 1024 * 1024;

/// What [`Recorder::finish`] reports about the finished file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Summary {
    /// The recording.
    pub path: PathBuf,
    /// Messages written per topic.
    pub counts: BTreeMap<String, u64>,
    /// All messages written.
    pub messages: u64,
    /// Chunks in the file.
    pub chunks: u32,
    /// The size of the finished file in bytes.
    pub bytes: u64,
}

/// One channel of the file: its id, what it carries, and its next sequence number.
struct Channel {
    id: u16,
    encoding: String,
    schema: String,
    sequence: u32,
    /// Messages written on it (kept here, not in a map keyed by topic: no lookup or allocation
    /// per message).
    count: u64,
}

/// Writes one MCAP recording; see the [module documentation](self) for the format and the
/// crash-survival design.
pub struct Recorder {
    path: PathBuf,
    writer: Writer<File>,
    channels: HashMap<String, Channel>,
    written: u64,
    durable: u64,
    last_flush: Instant,
}

impl Recorder {
    /// Creates (or truncates) the recording at `path` and writes its header, already flushed,
    /// so even a run killed at once leaves a readable, empty recording.
    pub fn create(path: &Path) -> Result<Recorder, RecordError> {
        let file =
            File::create(path).map_err(|source| RecordError::Create { path: path.to_path_buf(), source })?;
        let options = WriteOptions::new()
            .compression(COMPRESSION)
            .use_chunks(true)
            .chunk_size(Some(CHUNK_SIZE))
            .disable_seeking(true)
            // Compress on the writer's thread: zstd's worker threads would compete with the
            // launch for the cores on every chunk (see the module docs).
            .compression_threads(0)
            .library(library());
        let writer = Writer::with_options(file, options)
            .map_err(|source| RecordError::Create { path: path.to_path_buf(), source: into_io(source) })?;
        Ok(Recorder {
            path: path.to_path_buf(),
            writer,
            channels: HashMap::new(),
            written: 0,
            durable: 0,
            last_flush: Instant::now(),
        })
    }

    /// Records one bus message as raw bytes (message encoding `postcard`).
    ///
    /// A channel per topic, created on first use; `schema_name` names the message type, e.g.
    /// `bycoms.ToAgent` (empty: no schema record). Times are nanoseconds since the Unix epoch:
    /// `log_time_ns` when the orchestrator received it, `publish_time_ns` when it was sent.
    pub fn record_bytes(
        &mut self,
        topic: &str,
        schema_name: &str,
        log_time_ns: u64,
        publish_time_ns: u64,
        payload: &[u8],
    ) -> Result<(), RecordError> {
        self.write(topic, POSTCARD, schema_name, log_time_ns, publish_time_ns, payload)
    }

    /// Records one JSON-encoded value (message encoding `json`), for gate events and run
    /// metadata that people read. Publish time is the log time.
    pub fn record_json<T: serde::Serialize>(
        &mut self,
        topic: &str,
        schema_name: &str,
        log_time_ns: u64,
        value: &T,
    ) -> Result<(), RecordError> {
        let payload = serde_json::to_vec(value)
            .map_err(|source| RecordError::Json { topic: topic.to_string(), source })?;
        self.write(topic, JSON, schema_name, log_time_ns, log_time_ns, &payload)
    }

    /// Records one message already encoded as `encoding` (e.g. `protobuf`, `json`) with the
    /// schema `schema` gives (asked for only when the topic's channel is created): the decoded
    /// channels Foxglove reads (`crate::scene`).
    pub fn record_encoded(
        &mut self,
        topic: &str,
        encoding: &str,
        schema: impl FnOnce() -> Option<foxglove::Schema>,
        log_time_ns: u64,
        payload: &[u8],
    ) -> Result<(), RecordError> {
        match self.channels.get(topic) {
            Some(channel) if channel.encoding != encoding => {
                return Err(RecordError::TopicMismatch {
                    topic: topic.to_string(),
                    existing: format!("{}/{}", channel.encoding, channel.schema),
                    requested: encoding.to_string(),
                });
            }
            Some(_) => {}
            None => {
                let schema = schema();
                let schema_id = match &schema {
                    Some(s) => self.writer.add_schema(&s.name, &s.encoding, &s.data),
                    None => Ok(0),
                }
                .map_err(|source| self.write_error(source))?;
                let name = schema.map(|s| s.name).unwrap_or_default();
                self.add_channel(topic, encoding, &name, schema_id)?;
            }
        }
        let (channel_id, sequence) = self.next_sequence(topic)?;
        let header = MessageHeader { channel_id, sequence, log_time: log_time_ns, publish_time: log_time_ns };
        self.write_message(&header, payload)
    }

    /// Writes a metadata record (a name and string pairs), e.g. what the log times mean.
    pub fn write_metadata(
        &mut self,
        name: &str,
        metadata: BTreeMap<String, String>,
    ) -> Result<(), RecordError> {
        let record = mcap::records::Metadata { name: name.to_string(), metadata };
        self.writer.write_metadata(&record).map_err(|source| self.write_error(source))
    }

    /// Messages written so far, per topic.
    pub fn counts(&self) -> BTreeMap<String, u64> {
        self.channels.iter().filter(|(_, c)| c.count > 0).map(|(topic, c)| (topic.clone(), c.count)).collect()
    }

    /// Messages handed to the kernel by the last flush: what a crash from now on cannot lose.
    pub fn durable_messages(&self) -> u64 {
        self.durable
    }

    /// The recording's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes ([`Recorder::flush`]) when [`FLUSH_INTERVAL`] has passed since the last flush:
    /// what a caller's timer calls, so that the caller's timer and the recorder's own check
    /// (on every message) are one clock and close one chunk a second, not two.
    pub fn flush_if_due(&mut self) -> Result<(), RecordError> {
        if self.last_flush.elapsed() >= FLUSH_INTERVAL {
            self.flush()?;
        }
        Ok(())
    }

    /// How long until [`Recorder::flush_if_due`] flushes: what a writer that waits for messages
    /// waits at most, so a quiet tail is flushed on time too.
    pub fn flush_due_in(&self) -> Duration {
        FLUSH_INTERVAL.saturating_sub(self.last_flush.elapsed())
    }

    /// Closes the open chunk and hands everything written so far to the kernel, so it survives
    /// the death of this process. Cheap when nothing is pending; call it from a 1 s timer.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.writer.flush().map_err(|source| self.write_error(source))?;
        self.durable = self.written;
        self.last_flush = Instant::now();
        Ok(())
    }

    /// Writes the summary section and footer (indexes, statistics), `fsync`s the file and
    /// reports what it holds.
    pub fn finish(self) -> Result<Summary, RecordError> {
        let counts = self.counts();
        let Recorder { path, mut writer, .. } = self;
        let summary = writer.finish().map_err(|source| RecordError::Write { path: path.clone(), source })?;
        let file = writer.into_inner();
        let synced = file.sync_all().and_then(|()| file.metadata());
        let bytes = synced.map_err(|source| RecordError::Sync { path: path.clone(), source })?.len();
        let stats = summary.stats.unwrap_or_default();
        Ok(Summary { path, messages: counts.values().sum(), counts, chunks: stats.chunk_count, bytes })
    }

    fn write(
        &mut self,
        topic: &str,
        encoding: &'static str,
        schema_name: &str,
        log_time: u64,
        publish_time: u64,
        payload: &[u8],
    ) -> Result<(), RecordError> {
        let (channel_id, sequence) = self.channel(topic, encoding, schema_name)?;
        let header = MessageHeader { channel_id, sequence, log_time, publish_time };
        self.write_message(&header, payload)
    }

    fn write_message(&mut self, header: &MessageHeader, payload: &[u8]) -> Result<(), RecordError> {
        self.writer.write_to_known_channel(header, payload).map_err(|source| self.write_error(source))?;
        self.written += 1;
        self.flush_if_due()
    }

    /// The channel id for `topic` (created on first use) and the next sequence number on it.
    fn channel(
        &mut self,
        topic: &str,
        encoding: &'static str,
        schema: &str,
    ) -> Result<(u16, u32), RecordError> {
        if let Some(channel) = self.channels.get_mut(topic) {
            if channel.encoding != encoding || channel.schema != schema {
                return Err(RecordError::TopicMismatch {
                    topic: topic.to_string(),
                    existing: format!("{}/{}", channel.encoding, channel.schema),
                    requested: format!("{encoding}/{schema}"),
                });
            }
            let sequence = channel.sequence;
            channel.sequence = sequence.wrapping_add(1);
            channel.count += 1;
            return Ok((channel.id, sequence));
        }
        let schema_id = match (schema.is_empty(), encoding) {
            (true, _) => Ok(0),
            // Foxglove decodes `json` channels only with a `jsonschema` schema (or none); empty
            // schema data means "any JSON".
            (false, JSON) => self.writer.add_schema(schema, "jsonschema", &[]),
            (false, _) => self.writer.add_schema(schema, "", &[]),
        }
        .map_err(|source| self.write_error(source))?;
        let id = self.add_channel(topic, encoding, schema, schema_id)?;
        self.next_sequence(topic).map(|(_, sequence)| (id, sequence))
    }

    fn add_channel(
        &mut self,
        topic: &str,
        encoding: &str,
        schema: &str,
        schema_id: u16,
    ) -> Result<u16, RecordError> {
        let id = self
            .writer
            .add_channel(schema_id, topic, encoding, &BTreeMap::new())
            .map_err(|source| self.write_error(source))?;
        let channel =
            Channel { id, encoding: encoding.to_string(), schema: schema.to_string(), sequence: 0, count: 0 };
        self.channels.insert(topic.to_string(), channel);
        Ok(id)
    }

    /// The channel of `topic` (which exists) and its next sequence number.
    fn next_sequence(&mut self, topic: &str) -> Result<(u16, u32), RecordError> {
        let channel = self.channels.get_mut(topic).ok_or_else(|| RecordError::TopicMismatch {
            topic: topic.to_string(),
            existing: "no channel".into(),
            requested: "a message".into(),
        })?;
        let sequence = channel.sequence;
        channel.sequence = sequence.wrapping_add(1);
        channel.count += 1;
        Ok((channel.id, sequence))
    }

    fn write_error(&self, source: mcap::McapError) -> RecordError {
        RecordError::Write { path: self.path.clone(), source }
    }
}

/// The header write of a fresh file fails only on I/O; report it as the creation error it is.
fn into_io(error: mcap::McapError) -> std::io::Error {
    match error {
        mcap::McapError::Io(io) => io,
        other => std::io::Error::other(other),
    }
}

#[cfg(test)]
mod magic {
    #[test]
    fn the_outputs_know_an_mcap_file_by_the_specifications_magic() {
        assert_eq!(bycoms_runtime::out::kind::MCAP_MAGIC, mcap::MAGIC);
    }
}
