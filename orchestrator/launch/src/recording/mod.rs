//! The launch's side of the MCAP recording (`bycoms_record`), and of the
//! picture `launch --svg` draws.
//!
//! Why a wrapper: recording must never stop the robots. The loop only
//! copies what it records into a batch; the recording's own thread
//! (`writer`) feeds the scene and writes the file. A write error is
//! reported once, recording stops there (what was flushed stays readable)
//! and the launch goes on; the error is in the summary and makes the exit
//! code 1. The loop hands its batch over every [`HAND_OVER_EVERY`]
//! ([`Recording::tick`]); the writer flushes once a second, on its own
//! when the bus is quiet, which bounds the loss on a crash to the last
//! second.
//!
//! Decoded channels: every bus message is recorded as its raw postcard
//! bytes first (exact replay needs them); the core's inputs and outputs
//! (the poses and reports it is handed, the gate events and relays it
//! publishes: [`Seen`], as the driver hands and carries them, so no
//! message is decoded twice) are handed to the run's one
//! [`bycoms_record::scene::Scene`] (shared: [`SharedScene`]), whose Foxglove
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

mod seen;
mod writer;

pub use seen::Seen;

use super::config::{Clock, LaunchConfig};
use super::events::RunMeta;
use super::World;
use crate::core::view::BeaconAt;
use bycoms_record::scene::json::json_schema;
use bycoms_record::scene::{Out, Scene, SceneWorld, SharedScene};
use bycoms_record::schema::{self, Topics, CLOCK_METADATA};
use bycoms_record::{Recorder, Summary};
use bycoms_study::draw::trace::Trace;
use schemars::JsonSchema;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use writer::{Batch, Item, Writer, BATCH_ITEMS, QUEUE_BATCHES};

/// The run's ROS 2 ground robots' `cmd_vel` topics, when the launch drives
/// them (`agents.source = "real"` with a robots file of `kind = "ros2"`);
/// empty otherwise, and when the robots file does not read (the launch says
/// why when it opens it).
fn ros2_robots(cfg: &LaunchConfig) -> Vec<schema::Ros2RobotTopic> {
    let path = match (&cfg.agents.source, &cfg.agents.robots_file) {
        (super::config::AgentSourceKind::Real, Some(path)) => path,
        _ => return Vec::new(),
    };
    let Ok(file) = bycoms_lab::robots::RobotsFile::read(path) else { return Vec::new() };
    let namespace = cfg.ros2.clone().unwrap_or_default().namespace;
    super::agents::ros2_robots::recorded_topics(&file, &namespace, cfg.robots)
}

/// Nanoseconds since the Unix epoch, now.
pub fn now_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_nanos() as u64).unwrap_or(0)
}

/// The longest [`Recording::sync`] waits for the writer.
const SYNC_TIMEOUT: Duration = Duration::from_secs(30);

/// How often the loop hands its batch to the writer ([`Recording::tick`]):
/// rarely enough that waking the writer does not compete, pass after pass,
/// with the agents a lockstep tick waits for (a 1000-robot launch makes
/// tens of thousands of passes), often enough for a live view.
pub const HAND_OVER_EVERY: Duration = Duration::from_millis(50);

/// The recording of one launch (or nothing), and the trace of its picture.
pub struct Recording {
    /// The writer thread and what goes to it (none: nothing is recorded or shown).
    queue: Option<Queue>,
    /// Whether a file is written.
    file: bool,
    /// Lockstep: the simulated time messages are logged at, ns.
    simulated_ns: Option<u64>,
    /// The scene's output, filled by the writer, taken by the loop.
    shown: Arc<Mutex<Vec<Out>>>,
    trace: Option<Trace>,
    /// Pose messages written to the file so far, per pose topic: the
    /// number the core's log names a recorded pose by.
    poses_on: BTreeMap<String, u32>,
}

/// The loop's end of the writer thread.
struct Queue {
    /// What was recorded since the last hand-over.
    batch: Batch,
    handed_over: Instant,
    to_writer: SyncSender<Batch>,
    spent: Receiver<Batch>,
    failed: Arc<AtomicBool>,
    thread: JoinHandle<Result<Option<Summary>, String>>,
}

impl Queue {
    fn start(writer: Writer) -> std::io::Result<Self> {
        let (to_writer, batches) = mpsc::sync_channel(QUEUE_BATCHES);
        let (give_back, spent) = mpsc::channel();
        let failed = writer.failed.clone();
        let thread = std::thread::Builder::new()
            .name("recorder".into())
            .spawn(move || writer.run(batches, give_back))?;
        Ok(Self { batch: Batch::default(), handed_over: Instant::now(), to_writer, spent, failed, thread })
    }

    /// Hands the batch to the writer (waiting when it is [`QUEUE_BATCHES`]
    /// behind) and takes a spent one to fill next.
    fn hand_over(&mut self) {
        self.handed_over = Instant::now();
        if self.batch.is_empty() {
            return;
        }
        let next = self.spent.try_recv().unwrap_or_default();
        let full = std::mem::replace(&mut self.batch, next);
        // The writer ends only when this end hangs up; a panic there is
        // reported by `finish`.
        let _ = self.to_writer.send(full);
    }

    /// Hands over what is left, waits for the writer to finish the file.
    fn finish(mut self) -> Result<Option<Summary>, String> {
        self.hand_over();
        let Queue { to_writer, thread, .. } = self;
        drop(to_writer);
        thread.join().unwrap_or_else(|_| Err("the recording's writer thread panicked".into()))
    }
}

impl Recording {
    /// No recording, no picture.
    pub fn off() -> Self {
        Self {
            queue: None,
            file: false,
            simulated_ns: None,
            shown: Arc::default(),
            trace: None,
            poses_on: BTreeMap::new(),
        }
    }

    /// The run's scene for `swarm` on `world` with `cfg`, when anyone shows
    /// it (a recording or a live view): the one scene of the run.
    pub fn scene_for(swarm: &str, world: &World, cfg: &LaunchConfig) -> Option<SharedScene> {
        (cfg.record.is_some() || cfg.serve.is_some()).then(|| {
            let terrain = world.terrain.clone();
            let real = crate::lab::real_robots(cfg, world);
            SharedScene::new(Scene::new(
                swarm,
                SceneWorld { terrain, eps: cfg.eps, goal_radius: cfg.goal_radius, real },
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
        rec.trace = cfg.svg.is_some().then(Trace::with_beacons_told);
        rec.simulated_ns = (cfg.clock == Clock::Lockstep).then_some(0);
        let recorder = cfg.record.as_deref().map(Recorder::create).transpose()?;
        rec.file = recorder.is_some();
        if recorder.is_some() || scene.is_some() {
            let failed = Arc::new(AtomicBool::new(false));
            let writer = Writer { recorder, scene, shown: rec.shown.clone(), failed, error: None };
            rec.queue = Some(Queue::start(writer)?);
        }
        if rec.file {
            rec.describe(swarm, world, cfg);
        }
        let at = rec.now();
        rec.push(Item::World { at });
        Ok(rec)
    }

    /// Records to `path` (created or truncated), wall-clock times, no decoded channels.
    pub fn create(path: &std::path::Path) -> Result<Self, bycoms_record::RecordError> {
        let writer = Writer {
            recorder: Some(Recorder::create(path)?),
            scene: None,
            shown: Arc::default(),
            failed: Arc::new(AtomicBool::new(false)),
            error: None,
        };
        let queue = Queue::start(writer)
            .map_err(|source| bycoms_record::RecordError::Create { path: path.to_path_buf(), source })?;
        let mut rec = Self::off();
        rec.queue = Some(queue);
        rec.file = true;
        Ok(rec)
    }

    /// The file's metadata and run description.
    fn describe(&mut self, swarm: &str, world: &World, cfg: &LaunchConfig) {
        let lockstep = cfg.clock == Clock::Lockstep;
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
        self.push(Item::Metadata(CLOCK_METADATA.to_string(), clock));
        let meta = RunMeta {
            swarm,
            terrain: &world.name,
            terrain_text: &world.terrain_text,
            start: world.start,
            goal: world.goal,
            config: cfg,
            applied_poses: true,
            beacons_told: true,
            states_told: true,
            ros2_robots: &ros2_robots(cfg),
            real: &crate::lab::real_robots(cfg, world),
        };
        self.json(&Topics::new(swarm).run(), schema::RUN, &meta);
    }

    /// The batch to add to, unless nothing is written (or writing failed).
    fn batch(&mut self) -> Option<&mut Batch> {
        let queue = self.queue.as_mut().filter(|q| !q.failed.load(Ordering::Relaxed))?;
        if queue.batch.len() >= BATCH_ITEMS {
            queue.hand_over();
        }
        Some(&mut queue.batch)
    }

    fn push(&mut self, item: Item) {
        if let Some(batch) = self.batch() {
            batch.push(item);
        }
    }

    /// What the scene produced since the last call, for the observers.
    pub fn take_scene(&mut self) -> Vec<Out> {
        std::mem::take(&mut *self.shown.lock().unwrap_or_else(PoisonError::into_inner))
    }

    /// Whether anything is being recorded.
    pub fn is_on(&self) -> bool {
        self.file
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

    /// Records one bus message, byte for byte (exact replay reads them).
    pub fn bytes(&mut self, topic: &str, schema: &str, payload: &[u8]) {
        self.message(topic, schema, payload);
    }

    /// Records one bus message, byte for byte; a pose message written to
    /// the file gets its number on its topic (from 0, in file order,
    /// whether it decodes or not): how the core's log names it
    /// (`core::log::Call::HandleRecordedPose`) instead of storing it again.
    pub fn message(&mut self, topic: &str, schema: &str, payload: &[u8]) -> Option<u32> {
        let now = self.now();
        let file = self.file;
        let batch = self.batch()?;
        batch.bus(now, topic, schema, payload);
        if !(file && schema == schema::POSE) {
            return None;
        }
        let count = match self.poses_on.get_mut(topic) {
            Some(count) => count,
            None => self.poses_on.entry(topic.to_owned()).or_default(),
        };
        *count += 1;
        Some(*count - 1)
    }

    /// One of the core's inputs or outputs, as the driver handed or carried
    /// it ([`Seen`]): the scene (on the writer's thread) and the picture's
    /// trace (here) are folded from these, the one stream of the run, never
    /// from the recorded bytes again.
    pub fn seen(&mut self, seen: Seen) {
        if let Some(trace) = self.trace.as_mut() {
            match &seen {
                Seen::Pose(pose) => trace.pose(pose),
                Seen::Gate(event) => trace.gate(event),
                Seen::Beacon(BeaconAt { robot, at }) => trace.beacon(*robot, *at),
                Seen::Report(_) | Seen::State(_) => {}
            }
        }
        let now = self.now();
        if let Some(batch) = self.batch() {
            batch.push(Item::Seen { at: now, seen });
        }
    }

    /// Records one JSON message on a channel whose schema is `T`'s JSON
    /// schema, named `schema`.
    pub fn json<T: Serialize + JsonSchema>(&mut self, topic: &str, schema: &'static str, value: &T) {
        if !self.file {
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
        if let Some(batch) = self.batch() {
            batch.json(now, topic, schema, json_schema::<T>, &bytes);
        }
    }

    /// The picture's trace (`launch --svg`), taken once.
    pub fn take_trace(&mut self) -> Option<Trace> {
        self.trace.take()
    }

    /// Hands what was recorded to the writer when [`HAND_OVER_EVERY`] has
    /// passed since the last time: the loop calls it on every pass, before
    /// it waits.
    pub fn tick(&mut self) {
        if let Some(queue) = self.queue.as_mut().filter(|q| q.handed_over.elapsed() >= HAND_OVER_EVERY) {
            queue.hand_over();
        }
    }

    /// Waits until the writer has written everything recorded so far and
    /// put the scene's output for it where [`Recording::take_scene`] takes
    /// it (at most [`SYNC_TIMEOUT`]): before the last picture is shown.
    pub fn sync(&mut self) {
        let (done, answer) = mpsc::channel();
        self.push(Item::Barrier(done));
        if let Some(queue) = self.queue.as_mut() {
            queue.hand_over();
        }
        // No answer (the writer failed, or nothing is written): nothing to wait for.
        let _ = answer.recv_timeout(SYNC_TIMEOUT);
    }

    /// Finishes the file. Returns its summary, or the first error.
    pub fn finish(mut self) -> Result<Option<Summary>, String> {
        match self.queue.take() {
            Some(queue) => queue.finish(),
            None => Ok(None),
        }
    }
}

impl Drop for Recording {
    /// A recording dropped unfinished (a launch that failed) still ends
    /// as a whole file.
    fn drop(&mut self) {
        if let Some(queue) = self.queue.take() {
            if let Err(e) = queue.finish() {
                tracing::error!("recording failed: {e}");
            }
        }
    }
}

#[cfg(test)]
mod tests;
