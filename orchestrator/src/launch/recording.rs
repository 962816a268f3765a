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
//! reports are then decoded and handed to the run's one
//! [`crate::scene::Scene`] (shared: [`SharedScene`]), whose Foxglove
//! messages (scene, frames, log, per-robot JSON) are recorded too and kept
//! for the observers (the live view), so the file and a viewer are fed by
//! the same scene, once per message ([`Recording::take_scene`]).
//!
//! Log times: in lockstep every message is logged at the *simulated* time
//! of the tick it belongs to (ns since the run's start: tick × dt, 0 before
//! the first tick), so a timeline shows the run as it unfolded, not the
//! fraction of a second it took to compute; in real time, at the wall clock
//! (ns since the Unix epoch). The file says which in its `bycoms.clock`
//! metadata record.

use super::config::{Clock, LaunchConfig};
use super::events::RunMeta;
use super::World;
use crate::draw::trace::Trace;
use crate::record::decode::{decode, Content};
use crate::record::schema::{self, Topics, CLOCK_METADATA};
use crate::record::{RecordError, Recorder, Summary};
use crate::scene::json::json_schema;
use crate::scene::{Out, Scene, SceneWorld, SharedScene};
use schemars::JsonSchema;
use serde::Serialize;
use std::collections::BTreeMap;
use std::time::{SystemTime, UNIX_EPOCH};

/// Nanoseconds since the Unix epoch, now.
pub fn now_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_nanos() as u64).unwrap_or(0)
}

/// The recording of one launch (or nothing), and the trace of its picture.
pub struct Recording {
    recorder: Option<Recorder>,
    error: Option<String>,
    /// Lockstep: the simulated time messages are logged at, ns.
    simulated_ns: Option<u64>,
    scene: Option<SharedScene>,
    /// The scene's output not yet handed to the observers.
    shown: Vec<Out>,
    trace: Option<Trace>,
}

impl Recording {
    /// No recording, no picture.
    pub fn off() -> Self {
        Self { recorder: None, error: None, simulated_ns: None, scene: None, shown: Vec::new(), trace: None }
    }

    /// The run's scene for `swarm` on `world` with `cfg`, when anyone shows
    /// it (a recording or a live view): the one scene of the run.
    pub fn scene_for(swarm: &str, world: &World, cfg: &LaunchConfig) -> Option<SharedScene> {
        (cfg.record.is_some() || cfg.serve.is_some()).then(|| {
            let terrain = world.terrain.clone();
            SharedScene::new(Scene::new(
                swarm,
                SceneWorld { terrain, eps: cfg.eps, goal_radius: cfg.goal_radius },
            ))
        })
    }

    /// The recording of a launch of `swarm` on `world` with `cfg`: a file
    /// when `cfg.record` is set (its metadata, run description and the
    /// scene's world written at once), a trace when `cfg.svg` is set, and
    /// the feeding of `scene` (see [`Recording::scene_for`]) in any case.
    pub fn start(
        swarm: &str,
        world: &World,
        cfg: &LaunchConfig,
        scene: Option<SharedScene>,
    ) -> anyhow::Result<Self> {
        let mut rec = Self::off();
        rec.trace = cfg.svg.is_some().then(Trace::new);
        let lockstep = cfg.clock == Clock::Lockstep;
        rec.simulated_ns = lockstep.then_some(0);
        rec.scene = scene;
        if let Some(path) = &cfg.record {
            rec.recorder = Some(Recorder::create(path)?);
            rec.describe(swarm, world, cfg);
        }
        let now = rec.now();
        let outs = rec.scene.as_ref().map(|s| s.lock().world(now)).unwrap_or_default();
        rec.write_outs(&outs, now);
        rec.shown.extend(outs);
        Ok(rec)
    }

    /// The file's metadata and run description.
    fn describe(&mut self, swarm: &str, world: &World, cfg: &LaunchConfig) {
        let lockstep = cfg.clock == Clock::Lockstep;
        let rec = self;
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
        rec.json(&Topics::new(swarm).run(), schema::RUN, &meta);
    }

    /// What the scene produced since the last call, for the observers.
    pub fn take_scene(&mut self) -> Vec<Out> {
        std::mem::take(&mut self.shown)
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
        if self.recorder.is_none() && self.trace.is_none() && self.scene.is_none() {
            return;
        }
        let now = self.now();
        self.with(|r| r.record_bytes(topic, schema, now, now, payload));
        self.decoded(topic, schema, payload, now);
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
        self.with(|r| r.record_encoded(topic, schema::JSON, schema, now, &bytes));
    }

    /// The picture's trace (`launch --svg`), taken once.
    pub fn take_trace(&mut self) -> Option<Trace> {
        self.trace.take()
    }

    /// Flushes when a second has passed since the last flush (the
    /// recorder's own clock, which its writes check too: one chunk a second).
    pub fn tick(&mut self) {
        self.with(Recorder::flush_if_due);
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
    /// as bytes and is skipped here) into the scene and the trace, by the
    /// rules every reader of the file decodes them by (`record::decode`).
    fn decoded(&mut self, topic: &str, schema: &str, payload: &[u8], now: u64) {
        // Only these feed the scene and the trace; the rest (commands are most of
        // the traffic) is not decoded here.
        if !matches!(schema, schema::POSE | schema::GATE | schema::FROM_AGENT) {
            return;
        }
        let outs = match decode(topic, schema, schema::POSTCARD, payload) {
            Content::Pose(pose) => {
                if let Some(trace) = self.trace.as_mut() {
                    trace.pose(&pose);
                }
                self.scene.as_ref().map(|s| s.lock().pose(&pose, now))
            }
            Content::Gate(event) => {
                if let Some(trace) = self.trace.as_mut() {
                    trace.gate(&event);
                }
                self.scene.as_ref().map(|s| s.lock().gate(&event, now))
            }
            Content::Report(report) => self.scene.as_ref().map(|s| s.lock().report(&report, now)),
            _ => None,
        };
        if let Some(outs) = outs {
            self.write_outs(&outs, now);
            self.shown.extend(outs);
        }
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
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::msg::{GateEvent, GateKind, Pose};
    use bycoms_protocol::{encode, RobotId, MAX_MESSAGE_LEN};

    fn world() -> World {
        World::tiny()
    }

    fn feed(rec: &mut Recording) {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        let pose = Pose { robot: RobotId(1), x: 0.5, y: 0.5, heading: 0.0, step: 0, time_us: 0 };
        rec.bytes("bycoms/t/robot/1/pose", schema::POSE, encode(&pose, &mut buf).unwrap());
        let moved = Pose { x: 1.5, step: 1, time_us: 100_000, ..pose };
        rec.bytes("bycoms/t/robot/1/pose", schema::POSE, encode(&moved, &mut buf).unwrap());
        let event = GateEvent { robot: RobotId(1), kind: GateKind::Deployed, x: 0.5, y: 0.5, step: 0 };
        rec.bytes("bycoms/t/gate", schema::GATE, encode(&event, &mut buf).unwrap());
    }

    /// The scene's output as (topic, bytes), for comparing.
    fn encoded(outs: &[Out]) -> Vec<(String, Vec<u8>)> {
        outs.iter().map(|o| (o.topic.clone(), o.message.encode().expect("encodes"))).collect()
    }

    #[test]
    fn one_scene_feeds_the_file_and_the_observers_with_the_same_messages() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("r.mcap");
        let cfg = LaunchConfig {
            record: Some(path.clone()),
            serve: Some("127.0.0.1:0".into()),
            ..Default::default()
        };
        let scene = Recording::scene_for("t", &world(), &cfg).expect("recorded and served: a scene");
        let mut rec = Recording::start("t", &world(), &cfg, Some(scene.clone())).expect("starts");
        feed(&mut rec);
        let shown = encoded(&rec.take_scene());
        assert!(rec.take_scene().is_empty(), "handed out once");
        assert!(shown.iter().any(|(t, _)| t == "bycoms/t/scene"), "the world and the robot: {shown:?}");
        assert!(shown.iter().any(|(t, _)| t == "bycoms/t/gate/json"));
        rec.finish().expect("finishes");
        // The file's decoded channels hold exactly what the observers got.
        let bytes = std::fs::read(&path).expect("read");
        let decoded = ["/scene", "/tf", "/log", "/gate/json", "/pose/json", "/mode", "/telemetry"];
        let in_file: Vec<(String, Vec<u8>)> = mcap::MessageStream::new(&bytes)
            .expect("mcap")
            .map(|m| m.expect("message"))
            .filter(|m| decoded.iter().any(|d| m.channel.topic.ends_with(d)))
            .map(|m| (m.channel.topic.clone(), m.data.into_owned()))
            .collect();
        assert_eq!(in_file, shown);
        // The scene the live view snapshots is the same one: it knows robot 1.
        let snapshot = scene.lock().snapshot(0);
        assert!(encoded(&snapshot).iter().any(|(t, _)| t == "bycoms/t/scene"));
    }

    #[test]
    fn a_served_run_without_a_file_still_feeds_its_scene_and_an_unshown_run_has_none() {
        let cfg = LaunchConfig { serve: Some("127.0.0.1:0".into()), ..Default::default() };
        let scene = Recording::scene_for("t", &world(), &cfg);
        let mut rec = Recording::start("t", &world(), &cfg, scene).expect("starts");
        feed(&mut rec);
        assert!(encoded(&rec.take_scene()).iter().any(|(t, _)| t == "bycoms/t/robot/1/pose/json"));
        assert!(Recording::scene_for("t", &world(), &LaunchConfig::default()).is_none());
    }
}
