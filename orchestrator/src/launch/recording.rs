//! The launch's side of the MCAP recording (`crate::record`), and of the
//! picture `launch --svg` draws.
//!
//! Why a wrapper: recording must never stop the robots. A write error is
//! reported once, recording stops there (what was flushed stays readable)
//! and the launch goes on; the error is in the summary and makes the exit
//! code 1. The 1 s flush timer lives here: `record_*` flushes on its own
//! only when messages keep coming, so the launch loop calls
//! [`Recording::tick`] from its own loop to bound the loss on a crash to
//! the last second even when the bus is quiet.
//!
//! Decoded channels: every bus message is recorded as its raw postcard
//! bytes first (exact replay needs them); poses, gate events and agent
//! reports are then decoded and handed to [`crate::scene::Scene`], whose
//! Foxglove messages (scene, frames, log, per-robot JSON) are recorded too.
//!
//! Log times: in lockstep every message is logged at the *simulated* time
//! of the tick it belongs to (ns since the run's start: tick × dt, 0 before
//! the first tick), so a timeline shows the run as it unfolded, not the
//! fraction of a second it took to compute; in real time, at the wall clock
//! (ns since the Unix epoch). The file says which in its `bycoms.clock`
//! metadata record.

use super::config::{Clock, LaunchConfig};
use super::events::{RunMeta, RUN_SCHEMA};
use super::ports::schema;
use super::World;
use crate::draw::trace::Trace;
use crate::record::{RecordError, Recorder, Summary, FLUSH_INTERVAL};
use crate::scene::json::json_schema;
use crate::scene::{Out, Scene, SceneWorld};
use anyhow::Context;
use bycoms_protocol::decode;
use bycoms_protocol::msg::{FromAgent, GateEvent, Pose};
use schemars::JsonSchema;
use serde::Serialize;
use std::collections::BTreeMap;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// Nanoseconds since the Unix epoch, now.
pub fn now_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_nanos() as u64).unwrap_or(0)
}

/// Name of the metadata record that says what the log times mean.
pub const CLOCK_METADATA: &str = "bycoms.clock";

/// The recording of one launch (or nothing), and the trace of its picture.
pub struct Recording {
    recorder: Option<Recorder>,
    error: Option<String>,
    last_flush: Instant,
    /// Lockstep: the simulated time messages are logged at, ns.
    simulated_ns: Option<u64>,
    scene: Option<Scene>,
    trace: Option<Trace>,
}

impl Recording {
    /// No recording, no picture.
    pub fn off() -> Self {
        Self {
            recorder: None,
            error: None,
            last_flush: Instant::now(),
            simulated_ns: None,
            scene: None,
            trace: None,
        }
    }

    /// The recording of a launch of `swarm` on `world` with `cfg`: a file
    /// when `cfg.record` is set (its metadata, run description and the
    /// scene's world written at once), a trace when `cfg.svg` is set.
    pub fn start(swarm: &str, world: &World, cfg: &LaunchConfig) -> anyhow::Result<Self> {
        let mut rec = Self::off();
        rec.trace = cfg.svg.is_some().then(Trace::new);
        let Some(path) = &cfg.record else { return Ok(rec) };
        rec.recorder = Some(Recorder::create(path)?);
        let lockstep = cfg.clock == Clock::Lockstep;
        rec.simulated_ns = lockstep.then_some(0);
        let mut terrain = bycoms_sim::terrain::parse(&world.terrain_text).context("the launch's terrain")?;
        terrain.set_start(world.start);
        terrain.set_goal(world.goal);
        let scene = Scene::new(swarm, SceneWorld { terrain, eps: cfg.eps, goal_radius: cfg.goal_radius });
        let dt = bycoms_sim::RunConfig::paper(cfg.eps).kinematics.dt;
        let clock = BTreeMap::from([
            ("clock".to_string(), if lockstep { "lockstep" } else { "realtime" }.to_string()),
            (
                "log_time".to_string(),
                if lockstep {
                    "simulated: ns since the run started (tick × dt; 0 before the first tick)"
                } else {
                    "wall clock: ns since the Unix epoch"
                }
                .to_string(),
            ),
            ("dt_s".to_string(), dt.to_string()),
        ]);
        rec.with(|r| r.write_metadata(CLOCK_METADATA, clock));
        let meta = RunMeta {
            swarm,
            terrain: &world.name,
            terrain_text: &world.terrain_text,
            start: world.start,
            goal: world.goal,
            config: cfg,
        };
        rec.json(&format!("bycoms/{swarm}/run"), RUN_SCHEMA, &meta);
        let now = rec.now();
        let outs = scene.world(now);
        rec.write_outs(&outs, now);
        rec.scene = Some(scene);
        Ok(rec)
    }

    /// Records to `path` (created or truncated), wall-clock times, no decoded channels.
    pub fn create(path: &std::path::Path) -> Result<Self, RecordError> {
        Ok(Self { recorder: Some(Recorder::create(path)?), ..Self::off() })
    }

    /// Whether anything is being recorded.
    pub fn is_on(&self) -> bool {
        self.recorder.is_some()
    }

    /// Lockstep: messages from now on belong to simulated time `ns` (no
    /// effect on a real-time recording).
    pub fn set_simulated_time(&mut self, ns: u64) {
        if let Some(t) = self.simulated_ns.as_mut() {
            *t = ns;
        }
    }

    /// The log time of a message recorded now.
    pub fn now(&self) -> u64 {
        self.simulated_ns.unwrap_or_else(now_ns)
    }

    /// Records one bus message, byte for byte, then its decoded form.
    pub fn bytes(&mut self, topic: &str, schema: &str, payload: &[u8]) {
        if self.recorder.is_none() && self.trace.is_none() {
            return;
        }
        let now = self.now();
        self.with(|r| r.record_bytes(topic, schema, now, now, payload));
        self.decoded(schema, payload, now);
    }

    /// Records one JSON message on a channel whose schema is `T`'s JSON
    /// schema, named `schema`.
    pub fn json<T: Serialize + JsonSchema>(&mut self, topic: &str, schema: &str, value: &T) {
        if self.recorder.is_none() {
            return;
        }
        let bytes = match serde_json::to_vec(value) {
            Ok(bytes) => bytes,
            Err(e) => {
                tracing::warn!(topic, "JSON message not recorded: {e}");
                return;
            }
        };
        let now = self.now();
        let schema = || Some(foxglove::Schema::new(schema, "jsonschema", json_schema::<T>()));
        self.with(|r| r.record_encoded(topic, "json", schema, now, &bytes));
    }

    /// The picture's trace (`launch --svg`), taken once.
    pub fn take_trace(&mut self) -> Option<Trace> {
        self.trace.take()
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

    /// Decodes poses, gate events and agent reports (garbage was recorded
    /// as bytes and is skipped here) into the scene and the trace.
    fn decoded(&mut self, schema: &str, payload: &[u8], now: u64) {
        let outs = match schema {
            schema::POSE => {
                let Ok(pose) = decode::<Pose>(payload) else { return };
                if let Some(trace) = self.trace.as_mut() {
                    trace.pose(&pose);
                }
                self.scene.as_mut().map(|s| s.pose(&pose, now))
            }
            schema::GATE => {
                let Ok(event) = decode::<GateEvent>(payload) else { return };
                if let Some(trace) = self.trace.as_mut() {
                    trace.gate(&event);
                }
                self.scene.as_mut().map(|s| s.gate(&event, now))
            }
            schema::FROM_AGENT => {
                let Ok(report) = decode::<FromAgent>(payload) else { return };
                self.scene.as_mut().map(|s| s.report(&report, now))
            }
            _ => None,
        };
        if let Some(outs) = outs {
            self.write_outs(&outs, now);
        }
    }

    fn write_outs(&mut self, outs: &[Out], now: u64) {
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
            }
        }
    }
}
