//! The swarm as Foxglove shows it: world, poses, agent reports and gate
//! decisions in, Foxglove messages out. Pure (no I/O, no clock): the MCAP
//! recording (`launch::recording`) and a live view feed it the same bus
//! messages and write what it returns wherever they write.
//!
//! Why Foxglove's well-known schemas: Foxglove's 3D panel draws
//! `foxglove.SceneUpdate` and `foxglove.FrameTransforms`, its Log panel reads
//! `foxglove.Log`, with no plugin and no schema of ours to install. The
//! messages are the Foxglove SDK's own types (`foxglove::messages`, protobuf,
//! each with its schema through [`foxglove::Encode`]), so they match what
//! Foxglove expects by construction. Per-robot data goes out as JSON with
//! JSON schemas ([`json`]) for plots and tables.
//!
//! # Channels (all under `bycoms/<swarm>/`, see [`Topics`])
//!
//! | topic | schema | what |
//! |---|---|---|
//! | `scene` | `foxglove.SceneUpdate` | arena floor, impassable cells, start, goal; each robot (ball, or a box for a robot with a real body; heading arrow, number; colour = its state, as the launch core said it); trajectories; beacons with their ε circles |
//! | `tf` | `foxglove.FrameTransforms` | `arena` → `robot/<k>`: each robot's pose as a frame |
//! | `log` | `foxglove.Log` | gate decisions in words |
//! | `gate/json` | `bycoms.GateDecision` (JSON) | gate decisions as data |
//! | `beacon/json` | `bycoms.BeaconAt` (JSON) | each beacon where it stands, when it appears or creeps on |
//! | `robot/<k>/state` | `bycoms.RobotSlot` (JSON) | its state (the launch core's slot state), each change the core said |
//! | `robot/<k>/pose/json` | `bycoms.RobotPose` (JSON) | every pose of robot k that moved or turned it |
//! | `robot/<k>/mode` | `bycoms.RobotMode` (JSON) | its controller mode (1 goal, 2 bypass), when it changes |
//! | `robot/<k>/telemetry` | `bycoms.Telemetry` (JSON) | its agent's reports (register, heartbeat, status, link; not lockstep's tick acknowledgements) |
//!
//! # Entities
//!
//! Frame `arena`, one grid cell = 1 m, z up. Entity ids: `arena`,
//! `terrain`, `start`, `goal`, `robot/<k>`, `robot/<k>/path/<n>` (a
//! trajectory in pieces of [`PATH_PIECE`] points, so a pose re-sends only
//! the open piece, at most [`PATH_PIECE`] points, not the whole path) and
//! `robot/<k>/beacon`. Nothing expires: every entity stays until replaced
//! by id or deleted.
//!
//! # What changed, not the whole scene
//!
//! Foxglove's `SceneUpdate` keeps every entity until an update replaces it
//! (same id) or deletes it, so every message here carries only what changed
//! since the last one, and a viewer that applies them in order holds the
//! whole scene:
//!
//! * the world once, at the start ([`Scene::world`]);
//! * a pose that moves or turns a robot: its marker, the open piece of its
//!   trajectory, its frame (`tf`) and its pose JSON; a pose that changes
//!   nothing (a beacon republishes its frozen pose every period) sends
//!   nothing at all;
//! * a change of a robot's state, as the launch core said it
//!   ([`Scene::state`]): its JSON and the robot's new colour. The colour is
//!   the run's view's state ([`RunView`]), not one derived from the gate's
//!   decisions (issue 53), so a robot revoked or lost before its deployment
//!   is shown lost like one lost while moving;
//! * a gate decision: its JSON and log line, and the robot's marker;
//! * a change of the launch core's beacon table ([`Scene::beacon`]): the
//!   beacon's ε circle where it now stands (new, or crept on) and its JSON.
//!   The beacons are the run's view's ([`RunView`], one fold of the core's
//!   outputs that every renderer reads): the scene used to place a beacon
//!   where the gate judged it and never moved it, while the core's beacon
//!   crept on with a creeping robot (issue 53). The core's table never
//!   removes a beacon, so neither does the scene;
//! * an agent report: its telemetry JSON, and its mode only when the mode
//!   changed; lockstep's tick acknowledgements (one per live robot per tick,
//!   whose one field, the step, is in the poses) send nothing.
//!
//! A viewer that was not there from the start gets [`Scene::snapshot`]: the
//! whole scene as one update (the live view sends it to a late subscriber).
//! `the_updates_applied_in_order_give_the_full_scene_after_every_input`
//! (tests) proves the two agree after every input of seeded streams. Where
//! this matters: a crowd of beacons, which used to send a pose JSON and a
//! tick telemetry per beacon per tick, and trajectories re-sent up to 100
//! points per pose (see `orchestrator/benches/record_throughput.rs`).
//! A viewer that seeks in a recording instead of playing it holds the whole
//! scene only if it applies the updates before the seek point (the channel
//! was incremental before too: the world is sent once); how the Foxglove
//! app backfills after a seek was not checked here.
//! `orchestrator draw` and `replay` read the raw bus bytes, not this channel.
//!
//! A robot appears with its first pose (its start pose).

pub mod json;
mod shapes;

use bycoms_gate::view::SlotState;
use bycoms_gate::view::{self, RunView, Shown, StateChange};
use bycoms_protocol::msg::{FromAgent, GateEvent, Pose};
use bycoms_sim::terrain::Terrain;
use bycoms_sim::Vec2;
use foxglove::messages::{
    log, Color, FrameTransform, FrameTransforms, Log, SceneEntity, SceneUpdate, Timestamp, Vector3,
};
use foxglove::Encode;
use json::{BeaconAt, Decision, GateDecision, RobotMode, RobotPose, RobotSlot, Telemetry};
use shapes::{arrow, ball, circle, cuboid, disc, label, polyline, rgba, yaw};
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, MutexGuard};

/// The frame every entity is drawn in.
pub const ARENA_FRAME: &str = "arena";

/// Poses per trajectory piece (entity `robot/<k>/path/<n>`).
pub const PATH_PIECE: usize = 20;

const FLOOR: u32 = 0xf4f4f4;
const BORDER: u32 = 0x555555;
const BLOCKED: u32 = 0xa6d8f0;
const START: u32 = 0x2ca02c;
const GOAL: u32 = 0xffbf00;
const BEACON: u32 = 0x7b2fbe;
const STUCK: u32 = 0xd62728;
const ARRIVED: u32 = 0x2ca02c;
const DIED: u32 = 0x7f7f7f;
const INK: u32 = 0x202020;
const PALETTE: [u32; 8] = [0x1f77b4, 0xd62728, 0x2ca02c, 0x9467bd, 0xff7f0e, 0x8c564b, 0xe377c2, 0x17becf];
/// The drawn size of a robot (it is a point to the controller).
const ROBOT_SIZE: f64 = 0.6;

/// What the scene is drawn on: the terrain (with its start and goal), ε and
/// the goal radius.
#[derive(Debug, Clone)]
pub struct SceneWorld {
    /// The arena; its start and goal are the run's.
    pub terrain: Terrain,
    /// Circumferential radius ε: a beacon's circle (g = 1/ε² with c = 1).
    pub eps: f64,
    /// Arrival radius around the goal.
    pub goal_radius: f64,
    /// The robots with a real body (a lab's; in a mixed swarm its real
    /// members): drawn as boxes, the simulated ones as balls.
    pub real: Vec<u32>,
}

impl SceneWorld {
    /// Whether robot `k` has a real body.
    pub fn is_real(&self, k: u32) -> bool {
        self.real.contains(&k)
    }
}

/// The topic names of one swarm's decoded channels (the recording's own
/// topics, defined once in `crate::schema`).
pub use crate::schema::Topics;

/// One message of the scene, typed.
#[derive(Debug, Clone, PartialEq)]
pub enum Message {
    /// Entities to add or replace.
    Scene(SceneUpdate),
    /// Robot frames.
    Transforms(FrameTransforms),
    /// A line for the log panel.
    Log(Log),
    /// A robot's pose.
    Pose(RobotPose),
    /// A robot's controller mode.
    Mode(RobotMode),
    /// An agent report.
    Telemetry(Telemetry),
    /// A gate decision.
    Gate(GateDecision),
    /// A beacon where it stands.
    Beacon(BeaconAt),
    /// A robot's state changed.
    State(RobotSlot),
}

/// A message and the topic it goes on.
#[derive(Debug, Clone, PartialEq)]
pub struct Out {
    /// The channel's topic (one schema per topic).
    pub topic: String,
    /// The message.
    pub message: Message,
}

/// A message could not be encoded (cannot happen for these types short of a
/// bug, but is reported, not unwrapped).
#[derive(Debug, thiserror::Error)]
#[error("cannot encode a {schema} message: {reason}")]
pub struct EncodeError {
    /// The schema name.
    pub schema: String,
    /// The encoder's complaint.
    pub reason: String,
}

macro_rules! each_message {
    ($self:expr, $m:ident => $body:expr) => {
        match $self {
            Message::Scene($m) => $body,
            Message::Transforms($m) => $body,
            Message::Log($m) => $body,
            Message::Pose($m) => $body,
            Message::Mode($m) => $body,
            Message::Telemetry($m) => $body,
            Message::Gate($m) => $body,
            Message::Beacon($m) => $body,
            Message::State($m) => $body,
        }
    };
}

fn schema_of<T: Encode>(_: &T) -> Option<foxglove::Schema> {
    T::get_schema()
}

fn encoding_of<T: Encode>(_: &T) -> String {
    T::get_message_encoding()
}

fn bytes_of<T: Encode>(m: &T) -> Result<Vec<u8>, EncodeError> {
    let mut buf = Vec::with_capacity(m.encoded_len().unwrap_or(128));
    m.encode(&mut buf).map_err(|e| EncodeError {
        schema: T::get_schema().map(|s| s.name).unwrap_or_default(),
        reason: e.to_string(),
    })?;
    Ok(buf)
}

impl Message {
    /// The channel's schema (name, encoding `protobuf` or `jsonschema`, data).
    pub fn schema(&self) -> Option<foxglove::Schema> {
        each_message!(self, m => schema_of(m))
    }

    /// The channel's message encoding: `protobuf` or `json`.
    pub fn encoding(&self) -> String {
        each_message!(self, m => encoding_of(m))
    }

    /// The message's bytes.
    pub fn encode(&self) -> Result<Vec<u8>, EncodeError> {
        each_message!(self, m => bytes_of(m))
    }
}

/// One robot as the scene knows it.
#[derive(Debug, Clone)]
struct Track {
    last: Pose,
    path: Vec<Vec2>,
}

/// The scene of one run: feed it messages, write what it returns.
#[derive(Debug, Clone)]
pub struct Scene {
    world: SceneWorld,
    topics: Topics,
    robots: BTreeMap<u32, Track>,
    /// Each robot's last controller mode (the `mode` channel sends changes).
    modes: BTreeMap<u32, u8>,
    /// The run as the views show it: where each beacon stands, each
    /// robot's state.
    view: RunView,
}

/// The one scene of a run, shared by whoever shows it.
///
/// Why shared and not one per viewer: the recording and the live view must
/// show the same thing, and a scene keeps state (trajectories, beacons), so
/// one scene is fed once per message (by the launch's recording side,
/// `launch::recording`) and its output goes both to the file and to every
/// observer; a viewer that subscribes late asks the same scene for a
/// [`Scene::snapshot`] from its own thread, hence the lock.
#[derive(Debug, Clone)]
pub struct SharedScene(Arc<Mutex<Scene>>);

impl SharedScene {
    /// Shares `scene`.
    pub fn new(scene: Scene) -> Self {
        Self(Arc::new(Mutex::new(scene)))
    }

    /// The scene, for feeding or reading.
    pub fn lock(&self) -> MutexGuard<'_, Scene> {
        // A panic while holding the lock leaves plain data: keep using it.
        self.0.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

/// Nanoseconds as a Foxglove timestamp.
pub fn stamp(ns: u64) -> Timestamp {
    let sec = u32::try_from(ns / 1_000_000_000).unwrap_or(u32::MAX);
    Timestamp::new(sec, (ns % 1_000_000_000) as u32)
}

impl Scene {
    /// A scene of swarm `swarm` on `world`, no robot yet.
    pub fn new(swarm: &str, world: SceneWorld) -> Self {
        Self {
            world,
            topics: Topics::new(swarm),
            robots: BTreeMap::new(),
            modes: BTreeMap::new(),
            view: RunView::new(),
        }
    }

    /// The topic names.
    pub fn topics(&self) -> &Topics {
        &self.topics
    }

    /// The static world (arena, terrain, start, goal) at time `ns`: write it
    /// once at the start.
    pub fn world(&self, ns: u64) -> Vec<Out> {
        let t = stamp(ns);
        let terrain = &self.world.terrain;
        let (w, h) = (terrain.width() as f64, terrain.height() as f64);
        let mut arena = entity(&t, "arena");
        arena.cubes.push(cuboid(0.0, 0.0, w, h, -0.05, 0.05, rgba(FLOOR, 1.0)));
        let corners = [Vec2::new(0.0, 0.0), Vec2::new(w, 0.0), Vec2::new(w, h), Vec2::new(0.0, h)];
        arena.lines.push(polyline(&corners, 0.01, 0.1, true, rgba(BORDER, 1.0)));
        let mut cells = entity(&t, "terrain");
        // One box per horizontal run of impassable cells: a few hundred
        // boxes instead of thousands.
        for iy in 0..terrain.height() {
            let mut ix = 0;
            while ix < terrain.width() {
                if !terrain.cell_blocked(ix, iy) {
                    ix += 1;
                    continue;
                }
                let from = ix;
                while ix < terrain.width() && terrain.cell_blocked(ix, iy) {
                    ix += 1;
                }
                let (x0, y0) = (from as f64, iy as f64);
                cells.cubes.push(cuboid(x0, y0, ix as f64, y0 + 1.0, 0.0, 0.5, rgba(BLOCKED, 1.0)));
            }
        }
        let (s, g) = (terrain.start(), terrain.goal());
        let mut start = entity(&t, "start");
        start.spheres.push(ball(s, 0.5, 0.25, rgba(START, 1.0)));
        start.texts.push(label(s, 1.2, 1.0, "start", rgba(INK, 1.0)));
        let mut goal = entity(&t, "goal");
        goal.cylinders.push(disc(g, self.world.goal_radius, 0.02, rgba(GOAL, 0.8)));
        goal.lines.push(circle(g, self.world.goal_radius, 0.04, 0.06, rgba(GOAL, 1.0)));
        goal.texts.push(label(g, 1.2, 1.0, "goal", rgba(INK, 1.0)));
        vec![self.scene_out(vec![arena, cells, start, goal])]
    }

    /// A pose from motion capture at time `ns`: the pose as JSON, and, when
    /// the robot moved (or is new), its marker, the open piece of its
    /// trajectory and its frame.
    pub fn pose(&mut self, pose: &Pose, ns: u64) -> Vec<Out> {
        let k = pose.robot.0;
        let at = Vec2::new(pose.x, pose.y);
        let track = self.robots.entry(k).or_insert_with(|| Track { last: *pose, path: Vec::new() });
        let moved = track.path.last().is_none_or(|p| p.x != at.x || p.y != at.y);
        let turned = track.last.heading != pose.heading;
        if !moved && !turned && !track.path.is_empty() {
            return Vec::new();
        }
        let mut out = vec![Out { topic: self.topics.pose_json(k), message: Message::Pose(pose.into()) }];
        track.last = *pose;
        if moved {
            track.path.push(at);
        }
        let t = stamp(ns);
        let newest = track.path.len().saturating_sub(2) / PATH_PIECE;
        let mut entities = vec![robot_entity(&t, k, track, self.world.is_real(k), self.view.state(k))];
        entities.extend(path_entity(&t, k, &track.path, newest));
        out.push(self.scene_out(entities));
        let frame = FrameTransform {
            timestamp: Some(t),
            parent_frame_id: ARENA_FRAME.into(),
            child_frame_id: format!("robot/{k}"),
            translation: Some(Vector3 { x: pose.x, y: pose.y, z: 0.0 }),
            rotation: Some(yaw(pose.heading)),
        };
        out.push(Out {
            topic: self.topics.tf(),
            message: Message::Transforms(FrameTransforms { transforms: vec![frame] }),
        });
        out
    }

    /// A gate decision at time `ns`: the decision as JSON, a log line and
    /// the robot's new colour (its beacon, if it becomes one, comes as the
    /// core says it: [`Scene::beacon`]).
    pub fn gate(&mut self, event: &GateEvent, ns: u64) -> Vec<Out> {
        self.view.take(&Shown::Gate(*event));
        let decision = GateDecision::from(event);
        let k = decision.robot;
        let t = stamp(ns);
        let mut out = vec![
            Out { topic: self.topics.gate_json(), message: Message::Gate(decision) },
            Out { topic: self.topics.log(), message: Message::Log(log_line(&t, &decision)) },
        ];
        out.extend(self.robot_out(&t, k));
        out
    }

    /// Robot `robot`'s state became `state` at time `ns` (the launch core
    /// said so): its JSON, and its marker in its new colour.
    pub fn state(&mut self, robot: u32, state: SlotState, ns: u64) -> Vec<Out> {
        self.view.take(&Shown::State(StateChange { robot, state }));
        let t = stamp(ns);
        let json = RobotSlot { robot, state };
        let mut out = vec![Out { topic: self.topics.slot(robot), message: Message::State(json) }];
        out.extend(self.robot_out(&t, robot));
        out
    }

    /// Robot `k`'s marker as it is now, if it was seen.
    fn robot_out(&self, t: &Timestamp, k: u32) -> Option<Out> {
        let track = self.robots.get(&k)?;
        let entity = robot_entity(t, k, track, self.world.is_real(k), self.view.state(k));
        Some(self.scene_out(vec![entity]))
    }

    /// Robot `robot`'s beacon stands at `at` from time `ns` (the launch
    /// core's beacon table changed): its ε circle there, and its JSON;
    /// nothing if it already stood there.
    pub fn beacon(&mut self, robot: u32, at: Vec2, ns: u64) -> Vec<Out> {
        if !self.view.take(&Shown::Beacon(view::BeaconAt { robot, at })) {
            return Vec::new();
        }
        let t = stamp(ns);
        let json = BeaconAt { robot, x: at.x, y: at.y };
        vec![
            Out { topic: self.topics.beacon_json(), message: Message::Beacon(json) },
            self.scene_out(vec![beacon_entity(&t, robot, at, self.world.eps)]),
        ]
    }

    /// An agent report at time `ns`: its telemetry, and its mode when it
    /// reports one.
    pub fn report(&mut self, report: &FromAgent, ns: u64) -> Vec<Out> {
        let _ = ns;
        if matches!(report, FromAgent::TickDone(_)) {
            // Lockstep's acknowledgement, one per live robot per tick: its
            // one field, the step, is in the robot's poses.
            return Vec::new();
        }
        let telemetry = Telemetry::from(report);
        let k = telemetry.robot;
        let mut out = Vec::with_capacity(2);
        if let FromAgent::Status(s) = report {
            if self.modes.insert(k, s.mode) != Some(s.mode) {
                let mode =
                    RobotMode { robot: k, mode: s.mode, name: RobotMode::name_of(s.mode), step: s.step };
                out.push(Out { topic: self.topics.mode(k), message: Message::Mode(mode) });
            }
        }
        out.push(Out { topic: self.topics.telemetry(k), message: Message::Telemetry(telemetry) });
        out
    }

    /// Everything known at time `ns` in one update: the world, every robot,
    /// every trajectory piece and beacon (for a viewer that joins late).
    pub fn snapshot(&self, ns: u64) -> Vec<Out> {
        let t = stamp(ns);
        let mut out = self.world(ns);
        let mut entities = Vec::new();
        for (&k, track) in &self.robots {
            entities.push(robot_entity(&t, k, track, self.world.is_real(k), self.view.state(k)));
            for piece in 0..=track.path.len().saturating_sub(2) / PATH_PIECE {
                entities.extend(path_entity(&t, k, &track.path, piece));
            }
        }
        for (k, at) in self.view.beacons() {
            entities.push(beacon_entity(&t, k, at, self.world.eps));
        }
        if !entities.is_empty() {
            out.push(self.scene_out(entities));
        }
        out
    }

    fn scene_out(&self, entities: Vec<SceneEntity>) -> Out {
        Out {
            topic: self.topics.scene(),
            message: Message::Scene(SceneUpdate { deletions: Vec::new(), entities }),
        }
    }
}

fn entity(t: &Timestamp, id: &str) -> SceneEntity {
    SceneEntity { timestamp: Some(*t), frame_id: ARENA_FRAME.into(), id: id.into(), ..Default::default() }
}

fn palette(k: u32) -> Color {
    rgba(PALETTE[(k as usize).saturating_sub(1) % PALETTE.len()], 1.0)
}

/// Robot `k`'s marker: a ball, or a box when it has a `real` body; its
/// colour says its `state` (stuck, arrived, lost), else its own.
fn robot_entity(t: &Timestamp, k: u32, track: &Track, real: bool, state: Option<SlotState>) -> SceneEntity {
    let colour = match state {
        Some(SlotState::Stuck) => rgba(STUCK, 1.0),
        Some(SlotState::Arrived) => rgba(ARRIVED, 1.0),
        Some(SlotState::Died | SlotState::Lost) => rgba(DIED, 1.0),
        _ => palette(k),
    };
    let at = Vec2::new(track.last.x, track.last.y);
    let mut e = entity(t, &format!("robot/{k}"));
    if real {
        let half = ROBOT_SIZE / 2.0;
        e.cubes.push(cuboid(at.x - half, at.y - half, at.x + half, at.y + half, 0.0, ROBOT_SIZE, colour));
    } else {
        e.spheres.push(ball(at, ROBOT_SIZE, ROBOT_SIZE / 2.0, colour));
    }
    e.arrows.push(arrow(at, track.last.heading, 1.0, ROBOT_SIZE / 2.0, colour));
    e.texts.push(label(at, ROBOT_SIZE + 0.6, 0.9, k.to_string(), rgba(INK, 1.0)));
    e
}

/// Piece `n` of a trajectory: points `n·PATH_PIECE ..= (n+1)·PATH_PIECE`
/// (pieces share their end points), or nothing below two points.
fn path_entity(t: &Timestamp, k: u32, path: &[Vec2], n: usize) -> Option<SceneEntity> {
    let from = n * PATH_PIECE;
    let to = ((n + 1) * PATH_PIECE).min(path.len().checked_sub(1)?);
    let points = path.get(from..=to).filter(|p| p.len() >= 2)?;
    let mut e = entity(t, &format!("robot/{k}/path/{n}"));
    e.lines.push(polyline(points, 0.03, 0.08, false, palette(k)));
    Some(e)
}

fn beacon_entity(t: &Timestamp, k: u32, at: Vec2, eps: f64) -> SceneEntity {
    let mut e = entity(t, &beacon_id(k));
    e.cylinders.push(disc(at, eps, 0.01, rgba(BEACON, 0.12)));
    e.lines.push(circle(at, eps, 0.05, 0.08, rgba(BEACON, 1.0)));
    e
}

fn beacon_id(k: u32) -> String {
    format!("robot/{k}/beacon")
}

fn log_line(t: &Timestamp, d: &GateDecision) -> Log {
    let (words, level) = match d.decision {
        Decision::Deployed => ("deployed", log::Level::Info),
        Decision::Stuck => ("stuck: a beacon", log::Level::Info),
        Decision::Arrived => ("arrived at the goal", log::Level::Info),
        Decision::Died => ("lost while moving: a beacon where last seen", log::Level::Warning),
        Decision::Timeout => ("still moving when the time ran out", log::Level::Warning),
    };
    Log {
        timestamp: Some(*t),
        level: level as i32,
        message: format!("robot {} {words} at ({:.2}, {:.2}), step {}", d.robot, d.x, d.y, d.step),
        name: "gate".into(),
        file: String::new(),
        line: 0,
    }
}

#[cfg(test)]
mod tests;
