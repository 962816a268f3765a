//! The launch's side of the MCAP recording (`crate::record`).
//!
//! Why a wrapper: recording must never stop the robots. A write error is
//! reported once, recording stops there (what was flushed stays readable)
//! and the launch goes on; the error is in the summary and makes the exit
//! code 1. The 1 s flush timer lives here: `record_*` flushes on its own
//! only when messages keep coming, so the launch loop calls
//! [`Recording::tick`] from its own loop to bound the loss on a crash to
//! the last second even when the bus is quiet.

use crate::record::{RecordError, Recorder, Summary, FLUSH_INTERVAL};
use serde::Serialize;
use std::path::Path;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// Nanoseconds since the Unix epoch, now.
pub fn now_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_nanos() as u64).unwrap_or(0)
}

/// The recording of one launch, or nothing.
pub struct Recording {
    recorder: Option<Recorder>,
    error: Option<String>,
    last_flush: Instant,
}

impl Recording {
    /// No recording.
    pub fn off() -> Self {
        Self { recorder: None, error: None, last_flush: Instant::now() }
    }

    /// Records to `path` (created or truncated).
    pub fn create(path: &Path) -> Result<Self, RecordError> {
        Ok(Self { recorder: Some(Recorder::create(path)?), error: None, last_flush: Instant::now() })
    }

    /// Whether anything is being recorded.
    pub fn is_on(&self) -> bool {
        self.recorder.is_some()
    }

    /// Records one bus message, byte for byte.
    pub fn bytes(&mut self, topic: &str, schema: &str, payload: &[u8]) {
        let now = now_ns();
        self.with(|r| r.record_bytes(topic, schema, now, now, payload));
    }

    /// Records one JSON event.
    pub fn json<T: Serialize>(&mut self, topic: &str, schema: &str, value: &T) {
        let now = now_ns();
        self.with(|r| r.record_json(topic, schema, now, value));
    }

    /// Flushes when a second has passed since the last flush.
    pub fn tick(&mut self) {
        if self.last_flush.elapsed() >= FLUSH_INTERVAL {
            self.last_flush = Instant::now();
            self.with(Recorder::flush);
        }
    }

    /// Finishes the file. Returns its summary, or the first error.
    pub fn finish(mut self) -> Result<Option<Summary>, String> {
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

    fn with(&mut self, f: impl FnOnce(&mut Recorder) -> Result<(), RecordError>) {
        if self.error.is_some() {
            return;
        }
        if let Some(r) = self.recorder.as_mut() {
            if let Err(e) = f(r) {
                tracing::error!("recording failed, recording stops here: {e}");
                self.error = Some(e.to_string());
            }
        }
    }
}
