//! The launch's state and its message handling, shared by both clocks.
//!
//! Why one state machine for both clocks: lockstep and real time differ only
//! in *when* periods happen (the orchestrator's tick vs. each agent's wall
//! clock); what a registration, a pose, a death or a verdict means is the
//! same. [`Launch::pump`] takes in everything the bus, the pose source and
//! the agent source have, updates the robots' slots and queues the gate's
//! verdicts; the drivers (`lockstep`, `realtime`) decide when to tick,
//! deploy and settle verdicts.
//!
//! The engine knows none of the concrete kinds behind its three seams: the
//! transport ([`Ports`] on any bus backend), where agents come from
//! ([`AgentSource`]) and where poses come from ([`PoseSource`]).

use super::agents::{AgentSource, Gone};
use super::config::{Clock, LaunchConfig, OnDeath};
use super::events::{EventKind, LaunchEvent, EVENT_SCHEMA};
use super::gate::{GateParams, Verdict, Watch};
use super::ports::Ports;
use super::poses::{PoseSink, PoseSource};
use super::progress::Progress;
use super::summary::{Death, Outage};
use anyhow::anyhow;
use bycoms_protocol::msg::{Deploy, FromAgent, GateEvent, GateKind, GoalBearing, Pose, Refused, ToAgent};
use bycoms_protocol::{RobotId, PROTOCOL_VERSION};
use bycoms_sim::agent_process::{AgentArgs, BadKind};
use bycoms_sim::Vec2;
use std::collections::{BTreeSet, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// Longest single wait of a loop before it looks at its timers and flags.
pub const SLICE: Duration = Duration::from_millis(10);

/// The world as the orchestrator knows it: where robots start and the goal.
/// The terrain text is only handed on to the simulated agents.
#[derive(Clone, Debug)]
pub struct World {
    /// Where the terrain came from.
    pub name: String,
    /// The terrain in the text format, for the agents' simulated bodies.
    pub terrain_text: String,
    /// Start position.
    pub start: Vec2,
    /// Goal position.
    pub goal: Vec2,
}

/// Where a robot is in the launch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotState {
    /// Its agent has not been started.
    Waiting,
    /// Started, not registered.
    Spawned,
    /// Registered, idle.
    Registered,
    /// Told to deploy, first pose not seen yet.
    Deploying,
    /// Moving under the gate's watch.
    Moving,
    /// Stopped away from the goal: a beacon.
    Stuck,
    /// At the goal.
    Arrived,
    /// Died while moving: a beacon where last seen.
    Died,
    /// Still moving when the run ended.
    Unfinished,
    /// Its agent was lost before it was deployed.
    Lost,
}

impl SlotState {
    /// The state in words, for the live lines.
    pub fn words(self) -> &'static str {
        match self {
            Self::Waiting => "waiting",
            Self::Spawned => "starting",
            Self::Registered => "ready",
            Self::Deploying => "deploying",
            Self::Moving => "moving",
            Self::Stuck => "stuck",
            Self::Arrived => "arrived",
            Self::Died => "lost while moving",
            Self::Unfinished => "still moving",
            Self::Lost => "lost",
        }
    }
}

/// One robot's bookkeeping.
#[derive(Clone, Debug)]
pub struct Slot {
    pub id: u32,
    pub state: SlotState,
    pub pid: Option<u32>,
    pub alive: bool,
    /// Lockstep ticks started when its registration was handled.
    pub registered_before_tick: Option<u64>,
    /// The instance of the agent that registered it (the one kept).
    pub instance: Option<u64>,
    pub registered_at: Option<Instant>,
    pub mode: u8,
    pub last_pose: Option<Pose>,
    pub deployed_tick: Option<u64>,
    pub decided_tick: Option<u64>,
    pub steps: u64,
    pub reaction: Option<Duration>,
    pub death: Option<Death>,
    /// Real time: periods this robot's agent stepped since its deployment
    /// (poses seen) and periods it skipped (gaps in the frame numbers).
    pub frames: FrameCount,
    /// Times its agent was unreachable; the last is open while it is.
    pub outages: Vec<Outage>,
}

/// Real-time periods of one agent as its poses show them.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameCount {
    /// Poses seen (periods stepped).
    pub seen: u64,
    /// Frame numbers skipped between them (periods missed).
    pub missed: u64,
    last: Option<u64>,
}

impl FrameCount {
    /// Counts the pose of frame `step`.
    pub fn observe(&mut self, step: u64) {
        if let Some(last) = self.last {
            if step <= last {
                return;
            }
            self.missed += step - last - 1;
        }
        self.seen += 1;
        self.last = Some(step);
    }
}

/// Something the drivers must act on after a pump.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pending {
    /// The gate's verdict on the moving robot.
    Verdict(u32, Verdict),
    /// The moving robot's agent died.
    Died(u32),
}

/// One launch in progress.
pub struct Launch {
    pub cfg: LaunchConfig,
    pub world: World,
    pub ports: Ports,
    /// Where the agents come from.
    pub agents: Box<dyn AgentSource>,
    /// Where the gate's poses come from.
    pub pose_source: Box<dyn PoseSource>,
    pub template: AgentArgs,
    pub slots: Vec<Slot>,
    pub watch: Option<(u32, Watch)>,
    pub params: GateParams,
    /// Completed lockstep ticks.
    pub ticks: u64,
    /// Lockstep ticks started.
    pub ticks_started: u64,
    /// The tick whose answers are awaited.
    pub current_tick: u64,
    /// Agents whose `TickDone(current_tick)` is awaited.
    pub awaiting: BTreeSet<u32>,
    /// Active steps of the robots already done.
    pub spent: u64,
    pub queue: VecDeque<Pending>,
    pub fatal: Option<anyhow::Error>,
    pub progress: Progress,
    pub stop: Arc<AtomicBool>,
    pub started: Instant,
    /// When `launch::run` was called (before the bus was opened).
    pub begun: Instant,
    /// From `begun` to the first robot's start pose (deployed, moving).
    pub first_moving: Option<Duration>,
    /// zenoh: where the orchestrator listens (empty over ipc).
    pub endpoints: Vec<String>,
    pub decided_at: Option<Instant>,
    /// The next robot to deploy.
    pub next: u32,
    /// The `Deploy` whose start pose is awaited (re-sent if it was lost).
    pub pending_deploy: Option<Deploy>,
    /// The last goal bearing sent (re-sent with its tick).
    pub last_bearing: Option<GoalBearing>,
    /// Commands sent again (`partition`).
    pub resends: u64,
    poses: Vec<(u32, Pose)>,
}

/// The instance that registered robot `id`, if any.
fn slot_instance(slots: &[Slot], id: u32) -> Option<u64> {
    id.checked_sub(1).and_then(|i| slots.get(i as usize)).and_then(|s| s.instance)
}

/// Now, in ms since the Unix epoch (0 if the clock is before it).
pub(super) fn unix_ms() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_millis() as u64).unwrap_or(0)
}

impl Launch {
    /// A launch ready to start, nothing spawned yet.
    pub fn new(
        cfg: LaunchConfig,
        world: World,
        ports: Ports,
        sources: (Box<dyn AgentSource>, Box<dyn PoseSource>),
        template: AgentArgs,
        stop: Arc<AtomicBool>,
    ) -> Self {
        let (agents, pose_source) = sources;
        let params = GateParams {
            goal: world.goal,
            goal_radius: cfg.goal_radius,
            stop_speed: cfg.gate.stop_speed,
            stop_turn_rate: cfg.gate.stop_turn_rate,
            dwell_us: (cfg.gate.dwell * 1e6).round() as u64,
            period_us: cfg.dt_us(),
        };
        let slots = (1..=cfg.robots)
            .map(|id| Slot {
                id,
                state: SlotState::Waiting,
                pid: None,
                alive: false,
                registered_before_tick: None,
                instance: None,
                registered_at: None,
                mode: 1,
                last_pose: None,
                deployed_tick: None,
                decided_tick: None,
                steps: 0,
                reaction: None,
                death: None,
                frames: FrameCount::default(),
                outages: Vec::new(),
            })
            .collect();
        Self {
            progress: Progress::new(cfg.robots),
            cfg,
            world,
            ports,
            agents,
            pose_source,
            template,
            slots,
            watch: None,
            params,
            ticks: 0,
            ticks_started: 0,
            current_tick: 0,
            awaiting: BTreeSet::new(),
            spent: 0,
            queue: VecDeque::new(),
            fatal: None,
            stop,
            started: Instant::now(),
            begun: Instant::now(),
            first_moving: None,
            endpoints: Vec::new(),
            decided_at: None,
            next: 1,
            pending_deploy: None,
            last_bearing: None,
            resends: 0,
            poses: Vec::new(),
        }
    }

    /// Whether the loops must end now (Ctrl-C or a fatal error).
    pub fn must_end(&self) -> bool {
        self.fatal.is_some() || self.stop.load(Ordering::SeqCst)
    }

    pub fn slot(&mut self, id: u32) -> Option<&mut Slot> {
        id.checked_sub(1).and_then(|i| self.slots.get_mut(i as usize))
    }

    /// Takes in everything pending, waiting up to `timeout` for the first
    /// agent report: reports, poses, deaths. Verdicts go to `queue`.
    pub fn pump(&mut self, timeout: Duration) -> anyhow::Result<()> {
        let mut wait = timeout;
        while let Some(got) = self.ports.recv_report(wait)? {
            wait = Duration::ZERO;
            if let Some(msg) = got {
                self.on_report(msg);
            }
        }
        let mut poses = std::mem::take(&mut self.poses);
        let record_decoded = !self.pose_source.on_the_bus();
        let (recording, traffic, swarm) = self.ports.intake();
        let mut sink = PoseSink::new(recording, traffic, swarm, &mut poses, record_decoded);
        self.pose_source.drain(&mut sink)?;
        // Real robots' gateways turn bearings into the robot's frame with
        // its mocap heading: a source off the bus is passed on to them.
        let forward = record_decoded && self.cfg.agents.source == super::config::AgentsKind::Real;
        for (robot, pose) in poses.drain(..) {
            self.ports.observe_pose(robot, &pose);
            if forward && pose.robot.0 == robot {
                self.ports.forward_pose(&pose)?;
            }
            self.on_pose(robot, pose)?;
        }
        self.poses = poses;
        for (robot, gone) in self.agents.poll(false) {
            self.on_death(robot, gone);
        }
        self.take_reach()?;
        self.ports.recording.tick();
        if self.progress.due() {
            self.redraw();
        }
        Ok(())
    }

    fn on_report(&mut self, msg: FromAgent) {
        let id = msg.robot().0;
        let ticks_started = self.ticks_started;
        let current_tick = self.current_tick;
        let known = self.slot(id).is_some_and(|s| s.state != SlotState::Waiting);
        if !known {
            self.ports.count(BadKind::UnknownRobot, &format_args!("{msg:?} from an unknown robot"));
            return;
        }
        let Some(slot) = self.slot(id) else { return };
        let registered = slot.registered_before_tick.is_some();
        // Until its `Register` arrives an agent is not heard from: a
        // registration that was lost must not be hidden by heartbeats (the
        // agent repeats it with every heartbeat until it is answered, and
        // the registration timeout still applies).
        if !registered && !matches!(msg, FromAgent::Register(_)) {
            tracing::debug!(robot = id, "a report before the agent's registration, ignored");
            return;
        }
        if let FromAgent::Register(r) = &msg {
            if r.protocol_version != PROTOCOL_VERSION {
                let v = r.protocol_version;
                self.ports
                    .count(BadKind::WrongVersion, &format_args!("robot {id} registers with protocol {v}"));
                // An agent spawned here is ours: a mismatch is a broken
                // install. Agents that exist on their own (remote, robots)
                // may be anyone's: refused and counted, the robot still
                // awaited (its registration timeout applies).
                if !self.agents.all_at_once() {
                    self.fatal = Some(anyhow!(
                        "robot {id}'s agent speaks protocol version {v}, this orchestrator speaks {PROTOCOL_VERSION}"
                    ));
                }
                return;
            }
            if registered && slot_instance(&self.slots, id) != Some(r.instance) {
                self.refuse_duplicate(id, r.instance);
                return;
            }
        }
        self.agents.heard(id);
        let Some(slot) = self.slot(id) else { return };
        match msg {
            // A repeat: the agent had not heard from us yet when it sent it.
            FromAgent::Register(_) if registered => {}
            FromAgent::Register(r) => {
                slot.instance = Some(r.instance);
                slot.registered_before_tick = Some(ticks_started);
                slot.registered_at = Some(Instant::now());
                if slot.state == SlotState::Spawned {
                    slot.state = SlotState::Registered;
                }
                // Agents that come on their own: say who came, and which one.
                if self.agents.all_at_once() {
                    let instance = r.instance;
                    self.progress.event(&format!("robot {id}: agent registered (instance {instance:016x})"));
                }
            }
            FromAgent::Heartbeat(_) => {}
            FromAgent::Status(s) => slot.mode = s.mode,
            FromAgent::TickDone(t) => {
                if t.step == current_tick {
                    self.awaiting.remove(&id);
                }
            }
            // A real robot's telemetry is for recorders and monitors.
            FromAgent::Telemetry(_) => {}
            FromAgent::Link(l) => {
                if !l.up {
                    tracing::warn!(robot = id, silent_ms = l.silent_ms, "robot {id}'s link is lost");
                }
                self.agents.robot_link(id, l.up);
            }
        }
    }

    /// A second agent (another instance) registers for robot `id`, which
    /// already has one: counted, logged and told to leave; the first agent
    /// stays. Its later reports cannot be told from the first's (only
    /// `Register` carries the instance): the refused agent exits on the
    /// `Refused`, one round trip later.
    fn refuse_duplicate(&mut self, id: u32, instance: u64) {
        let kept = slot_instance(&self.slots, id).unwrap_or_default();
        self.ports.count(
            BadKind::Duplicate,
            &format_args!(
                "robot {id} registered again by another agent (instance {instance:016x}, kept {kept:016x})"
            ),
        );
        tracing::warn!(
            robot = id,
            instance = format_args!("{instance:016x}"),
            "a second agent for robot {id} refused"
        );
        let refused = ToAgent::Refused(Refused { robot: RobotId(id), instance });
        if let Err(e) = self.ports.send(id, &refused) {
            tracing::warn!(robot = id, "cannot tell the refused agent: {e:#}");
        }
    }

    fn on_pose(&mut self, topic: u32, pose: Pose) -> anyhow::Result<()> {
        if pose.robot.0 != topic {
            let got = pose.robot;
            self.ports.count(BadKind::UnknownRobot, &format_args!("pose of {got} on robot {topic}'s topic"));
            return Ok(());
        }
        let lockstep = self.cfg.clock == Clock::Lockstep;
        let ticks = self.ticks;
        let dt_us = self.cfg.dt_us();
        let index = topic.checked_sub(1).map_or(usize::MAX, |i| i as usize);
        // Borrow the slot through its field, not `self`, so the watch and
        // the ports stay usable below.
        let Some(slot) = self.slots.get_mut(index) else { return Ok(()) };
        if !slot.alive || matches!(slot.state, SlotState::Waiting | SlotState::Spawned | SlotState::Lost) {
            // Our own relay of a dead robot, or a stray sample.
            return Ok(());
        }
        slot.last_pose = Some(pose);
        if !lockstep && slot.state != SlotState::Deploying {
            slot.frames.observe(pose.step);
        }
        if slot.state == SlotState::Deploying && self.watch.is_none() {
            // The start pose: the robot is deployed and under watch. In
            // lockstep its periods are counted from the last completed tick.
            let mut start = pose;
            if lockstep {
                start.step = ticks;
                start.time_us = ticks * dt_us;
            }
            slot.state = SlotState::Moving;
            slot.deployed_tick = Some(start.step + 1);
            slot.reaction = self.decided_at.map(|d| d.elapsed());
            self.first_moving.get_or_insert_with(|| self.begun.elapsed());
            self.watch = Some((topic, Watch::new(self.params, start)));
            let event = GateEvent {
                robot: pose.robot,
                kind: GateKind::Deployed,
                x: pose.x,
                y: pose.y,
                step: start.step,
            };
            self.ports.publish_gate(&event)?;
            self.progress.event(&format!("robot {topic}: deployed at ({:.2}, {:.2})", pose.x, pose.y));
        } else if let Some((id, watch)) = self.watch.as_mut().filter(|(id, _)| *id == topic) {
            if let Some(v) = watch.observe(pose) {
                self.queue.push_back(Pending::Verdict(*id, v));
            }
        } else {
            return Ok(());
        }
        if !lockstep && self.queue.is_empty() {
            self.send_bearing(topic, &pose, pose.step + 1)?;
        }
        Ok(())
    }

    /// Sends robot `id` its goal bearing from `pose` (the runner's function).
    pub fn send_bearing(&mut self, id: u32, pose: &Pose, step: u64) -> anyhow::Result<()> {
        let bearing = Vec2::new(pose.x, pose.y).bearing_to(self.world.goal);
        let msg = GoalBearing { robot: RobotId(id), bearing, step };
        self.last_bearing = Some(msg);
        self.ports.send(id, &ToAgent::GoalBearing(msg))?;
        Ok(())
    }

    /// Handles the death of robot `id`'s agent.
    pub fn on_death(&mut self, id: u32, gone: Gone) {
        self.awaiting.remove(&id);
        let abort = self.cfg.gate.on_agent_death == OnDeath::Abort;
        let death = Death { reason: gone.to_string(), noticed_unix_ms: unix_ms() };
        let Some(slot) = self.slot(id) else { return };
        slot.alive = false;
        slot.death = Some(death.clone());
        let state = slot.state;
        let pose = slot.last_pose;
        let text = format!("robot {id}: agent lost — {}", death.reason);
        self.progress.event(&text);
        let event = LaunchEvent {
            robot: id,
            event: EventKind::AgentLost,
            pid: None,
            source: None,
            reason: Some(death.reason.clone()),
            state: Some(format!("{state:?}")),
        };
        let topic = format!("bycoms/{}/events", self.template.swarm);
        self.ports.recording.json(&topic, EVENT_SCHEMA, &event);
        match state {
            SlotState::Spawned => {
                self.fatal = Some(anyhow!("robot {id}'s agent never registered: {}", death.reason));
            }
            SlotState::Registered | SlotState::Deploying => {
                if let Some(s) = self.slot(id) {
                    s.state = SlotState::Lost;
                }
                if state == SlotState::Deploying || abort {
                    self.fatal =
                        Some(anyhow!("robot {id}'s agent was lost before its deployment: {}", death.reason));
                }
            }
            SlotState::Moving => {
                self.queue.push_back(Pending::Died(id));
                if abort {
                    self.fatal = Some(anyhow!("robot {id}'s agent died while moving: {}", death.reason));
                }
            }
            _ if abort && pose.is_some() => {
                self.fatal = Some(anyhow!("robot {id}'s agent died: {}", death.reason));
            }
            _ => {}
        }
    }

    /// Publishes the last pose of every dead robot that is in the arena.
    pub fn relay_dead(&mut self, step: u64, time_us: u64) -> anyhow::Result<()> {
        let dead: Vec<Pose> = self
            .slots
            .iter()
            .filter(|s| !s.alive && matches!(s.state, SlotState::Stuck | SlotState::Died))
            .filter_map(|s| s.last_pose)
            .collect();
        for mut pose in dead {
            pose.step = step;
            pose.time_us = time_us;
            self.ports.relay(&pose)?;
        }
        Ok(())
    }

    /// Redraws every robot's live line.
    pub fn redraw(&self) {
        for s in &self.slots {
            let at = s.last_pose.map(|p| format!("({:6.2}, {:6.2})", p.x, p.y)).unwrap_or_default();
            let mode = if s.state == SlotState::Moving { format!(" mode {}", s.mode) } else { String::new() };
            self.progress.robot(s.id, format!("{}{mode} {at}", s.state.words()));
        }
    }
}
