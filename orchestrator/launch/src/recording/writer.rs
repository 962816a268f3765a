//! The recording's own thread: it feeds the scene, encodes and writes, so
//! the launch loop only copies bytes (and the core's inputs and outputs,
//! decoded already: nothing is decoded twice).
//!
//! Why a thread: in a lockstep launch the loop *is* the swarm's clock —
//! every microsecond it spends on the recording is a microsecond every robot
//! waits. A recorded message costs the loop a copy into a [`Batch`]; the
//! scene's Foxglove messages, JSON, the MCAP index, zstd and
//! the writes happen here, on the other core, while the loop waits for its
//! agents. A 1000-robot launch records about 8 million messages; written
//! inline they doubled its wall time.
//!
//! Order and times are the loop's: items are written in the order they were
//! recorded, each at the log time stamped when it was recorded (simulated
//! time in lockstep). The channel to this thread is bounded
//! ([`QUEUE_BATCHES`]): when the disk cannot keep up the loop waits for it
//! rather than lose a message or grow without bound. Spent batches come
//! back to the loop to be filled again, so a steady run allocates nothing.
//!
//! Durability is the recorder's (at most the last second is lost): this
//! thread flushes on the recorder's one clock, waking on its own when no
//! batch comes ([`Recorder::flush_due_in`]), and the loop hands over what it
//! recorded every 50 ms (`HAND_OVER_EVERY`).

use super::seen::Seen;
use crate::core::view::{BeaconAt, StateChange};
use bycoms_record::scene::{Out, SharedScene};
use bycoms_record::schema;
use bycoms_record::{RecordError, Recorder, Summary};
use std::collections::BTreeMap;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};

/// How many batches may wait for the writer before the loop waits for it.
pub const QUEUE_BATCHES: usize = 256;

/// Items past which a batch is handed over at once (it bounds the memory
/// of what waits in the loop).
pub const BATCH_ITEMS: usize = 4096;

/// Recorded messages waiting for the writer: their bytes in one buffer,
/// and what each one is.
#[derive(Default)]
pub struct Batch {
    data: Vec<u8>,
    items: Vec<Item>,
}

/// One thing to write.
pub enum Item {
    /// A bus message, byte for byte.
    Bus { at: u64, topic: Range<usize>, schema: Range<usize>, payload: Range<usize> },
    /// One of the core's inputs or outputs, for the scene.
    Seen { at: u64, seen: Seen },
    /// A JSON message whose channel's schema is `schema_of()`, named `schema`.
    Json {
        at: u64,
        topic: Range<usize>,
        schema: &'static str,
        schema_of: fn() -> Vec<u8>,
        payload: Range<usize>,
    },
    /// A metadata record.
    Metadata(String, BTreeMap<String, String>),
    /// The scene's world (the terrain, the goal), once at the start.
    World { at: u64 },
    /// Written up to here: the writer answers once everything before it is
    /// written and shown.
    Barrier(Sender<()>),
}

impl Batch {
    fn put(&mut self, bytes: &[u8]) -> Range<usize> {
        let start = self.data.len();
        self.data.extend_from_slice(bytes);
        start..self.data.len()
    }

    /// Adds a bus message recorded at `at`.
    pub fn bus(&mut self, at: u64, topic: &str, schema: &str, payload: &[u8]) {
        let (topic, schema, payload) =
            (self.put(topic.as_bytes()), self.put(schema.as_bytes()), self.put(payload));
        self.items.push(Item::Bus { at, topic, schema, payload });
    }

    /// Adds a JSON message recorded at `at`.
    pub fn json(
        &mut self,
        at: u64,
        topic: &str,
        schema: &'static str,
        schema_of: fn() -> Vec<u8>,
        payload: &[u8],
    ) {
        let (topic, payload) = (self.put(topic.as_bytes()), self.put(payload));
        self.items.push(Item::Json { at, topic, schema, schema_of, payload });
    }

    /// Adds any other item.
    pub fn push(&mut self, item: Item) {
        self.items.push(item);
    }

    /// Items in the batch.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether the batch holds nothing.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    fn text(&self, range: &Range<usize>) -> &str {
        // Only ever filled from `&str`s, whole: always UTF-8.
        self.data.get(range.clone()).and_then(|b| std::str::from_utf8(b).ok()).unwrap_or_default()
    }

    fn bytes(&self, range: &Range<usize>) -> &[u8] {
        self.data.get(range.clone()).unwrap_or_default()
    }

    fn clear(&mut self) {
        self.data.clear();
        self.items.clear();
    }
}

/// What the writer thread owns.
pub struct Writer {
    /// The file (none: the run is only shown, `launch --serve`).
    pub recorder: Option<Recorder>,
    /// The run's scene, fed with every message the launch decoded.
    pub scene: Option<SharedScene>,
    /// The scene's output not yet taken by the loop for its observers.
    pub shown: Arc<Mutex<Vec<Out>>>,
    /// Set at the first write error: the loop stops recording.
    pub failed: Arc<AtomicBool>,
    /// The first write error.
    pub error: Option<String>,
}

impl Writer {
    /// Writes every batch that comes, hands each back on `spent`, and
    /// finishes the file when the loop hangs up: its summary, or the first
    /// error.
    pub fn run(mut self, batches: Receiver<Batch>, spent: Sender<Batch>) -> Result<Option<Summary>, String> {
        loop {
            let wait = self.recorder.as_ref().map_or(bycoms_record::FLUSH_INTERVAL, Recorder::flush_due_in);
            match batches.recv_timeout(wait) {
                Ok(mut batch) => {
                    self.write(&batch);
                    batch.clear();
                    // The loop may have ended: then the batch is simply dropped.
                    let _ = spent.send(batch);
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            self.with(Recorder::flush_if_due);
        }
        self.finish()
    }

    fn finish(mut self) -> Result<Option<Summary>, String> {
        if let Some(e) = self.error.take() {
            // Close what can be closed; the first error is the one to report.
            if let Some(r) = self.recorder.take() {
                let _ = r.finish();
            }
            return Err(e);
        }
        match self.recorder.take() {
            Some(r) => r.finish().map(Some).map_err(|e| e.to_string()),
            None => Ok(None),
        }
    }

    fn write(&mut self, batch: &Batch) {
        let mut shown = Vec::new();
        for item in &batch.items {
            match item {
                Item::Bus { at, topic, schema, payload } => {
                    let (topic, schema, payload) =
                        (batch.text(topic), batch.text(schema), batch.bytes(payload));
                    self.with(|r| r.record_bytes(topic, schema, *at, *at, payload));
                }
                Item::Seen { at, seen } => self.seen(seen, *at, &mut shown),
                Item::Json { at, topic, schema, schema_of, payload } => {
                    let schema_of = || Some(foxglove::Schema::new(*schema, "jsonschema", schema_of()));
                    let (topic, payload) = (batch.text(topic), batch.bytes(payload));
                    self.with(|r| r.record_encoded(topic, schema::JSON, schema_of, *at, payload));
                }
                Item::Metadata(name, pairs) => self.with(|r| r.write_metadata(name, pairs.clone())),
                Item::World { at } => {
                    let outs = self.scene.as_ref().map(|s| s.lock().world(*at)).unwrap_or_default();
                    self.write_outs(&outs, *at);
                    shown.extend(outs);
                }
                Item::Barrier(done) => {
                    self.show(&mut shown);
                    let _ = done.send(());
                }
            }
        }
        self.show(&mut shown);
    }

    /// Hands the scene's output to the loop for its observers.
    fn show(&self, outs: &mut Vec<Out>) {
        if !outs.is_empty() {
            self.shown.lock().unwrap_or_else(std::sync::PoisonError::into_inner).append(outs);
        }
    }

    /// Feeds the scene a pose, a gate event or an agent report as the
    /// launch core was handed or published it (decoded by the codec every
    /// reader of the file decodes the recorded bytes with, `record::decode`).
    fn seen(&mut self, seen: &Seen, now: u64, shown: &mut Vec<Out>) {
        let Some(scene) = self.scene.as_ref() else { return };
        let outs = match seen {
            Seen::Pose(pose) => scene.lock().pose(pose, now),
            Seen::Gate(event) => scene.lock().gate(event, now),
            Seen::Report(report) => scene.lock().report(report, now),
            Seen::Beacon(BeaconAt { robot, at }) => scene.lock().beacon(*robot, *at, now),
            Seen::State(StateChange { robot, state }) => scene.lock().state(*robot, *state, now),
        };
        self.write_outs(&outs, now);
        shown.extend(outs);
    }

    fn write_outs(&mut self, outs: &[Out], now: u64) {
        if self.recorder.is_none() {
            return;
        }
        for out in outs {
            let bytes = match out.message.encode() {
                Ok(bytes) => bytes,
                Err(e) => {
                    tracing::warn!(topic = out.topic, "scene message not recorded: {e}");
                    continue;
                }
            };
            let encoding = out.message.encoding();
            self.with(|r| r.record_encoded(&out.topic, &encoding, || out.message.schema(), now, &bytes));
        }
    }

    fn with(&mut self, f: impl FnOnce(&mut Recorder) -> Result<(), RecordError>) {
        if self.error.is_some() {
            return;
        }
        if let Some(r) = self.recorder.as_mut() {
            if let Err(e) = f(r) {
                tracing::error!("recording failed, recording stops here: {e}");
                self.error = Some(e.to_string());
                self.failed.store(true, Ordering::Relaxed);
            }
        }
    }
}
