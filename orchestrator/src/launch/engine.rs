//! The launch's state and its message handling, shared by both clocks.
//!
//! Why one state machine for both clocks: lockstep and real time differ only
//! in *when* periods happen (the orchestrator's tick vs. each agent's wall
//! clock); what a registration, a pose, a death or a verdict means is the
//! same. [`Launch::pump`] takes in everything the bus and the supervisor
//! have, updates the robots' slots and queues the gate's verdicts; the
//! drivers (`lockstep`, `realtime`) decide when to tick, deploy and settle
//! verdicts.

use super::config::{Clock, LaunchConfig, OnDeath};
use super::gate::{GateParams, Verdict, Watch};
use super::ports::Ports;
use super::progress::Progress;
use super::summary::Death;
use super::supervise::{Gone, Supervisor};
use anyhow::anyhow;
use bycoms_protocol::msg::{FromAgent, GateEvent, GateKind, GoalBearing, Pose, ToAgent};
use bycoms_protocol::{RobotId, PROTOCOL_VERSION};
use bycoms_sim::agent_process::{AgentArgs, BadKind};
use bycoms_sim::Vec2;
use serde_json::json;
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
    pub sup: Supervisor,
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
    pub decided_at: Option<Instant>,
    /// The next robot to deploy.
    pub next: u32,
    poses: Vec<(u32, Pose)>,
}

fn unix_ms() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_millis() as u64).unwrap_or(0)
}

impl Launch {
    /// A launch ready to start, nothing spawned yet.
    pub fn new(
        cfg: LaunchConfig,
        world: World,
        ports: Ports,
        sup: Supervisor,
        template: AgentArgs,
        stop: Arc<AtomicBool>,
    ) -> Self {
        let params = GateParams {
            goal: world.goal,
            goal_radius: cfg.goal_radius,
            stop_speed: cfg.gate.stop_speed,
            stop_turn_rate: cfg.gate.stop_turn_rate,
            dwell_us: (cfg.gate.dwell * 1e6).round() as u64,
        };
        let slots = (1..=cfg.robots)
            .map(|id| Slot {
                id,
                state: SlotState::Waiting,
                pid: None,
                alive: false,
                registered_before_tick: None,
                registered_at: None,
                mode: 1,
                last_pose: None,
                deployed_tick: None,
                decided_tick: None,
                steps: 0,
                reaction: None,
                death: None,
                frames: FrameCount::default(),
            })
            .collect();
        Self {
            progress: Progress::new(cfg.robots),
            cfg,
            world,
            ports,
            sup,
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
            decided_at: None,
            next: 1,
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
        self.ports.drain_poses(|robot, pose| poses.push((robot, pose)))?;
        for (robot, pose) in poses.drain(..) {
            self.on_pose(robot, pose)?;
        }
        self.poses = poses;
        for (robot, gone) in self.sup.poll(false) {
            self.on_death(robot, gone);
        }
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
        self.sup.heard(id);
        let Some(slot) = self.slot(id) else { return };
        match msg {
            FromAgent::Register(r) if r.protocol_version != PROTOCOL_VERSION => {
                let v = r.protocol_version;
                self.ports
                    .count(BadKind::WrongVersion, &format_args!("robot {id} registers with protocol {v}"));
                self.fatal = Some(anyhow!(
                    "robot {id}'s agent speaks protocol version {v}, this orchestrator speaks {PROTOCOL_VERSION}"
                ));
            }
            FromAgent::Register(_) if slot.registered_before_tick.is_some() => {
                self.ports.count(BadKind::Duplicate, &format_args!("second registration of robot {id}"));
            }
            FromAgent::Register(_) => {
                slot.registered_before_tick = Some(ticks_started);
                slot.registered_at = Some(Instant::now());
                if slot.state == SlotState::Spawned {
                    slot.state = SlotState::Registered;
                }
            }
            FromAgent::Heartbeat(_) => {}
            FromAgent::Status(s) => slot.mode = s.mode,
            FromAgent::TickDone(t) => {
                if t.step == current_tick {
                    self.awaiting.remove(&id);
                }
            }
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
            }
            slot.state = SlotState::Moving;
            slot.deployed_tick = Some(start.step + 1);
            slot.reaction = self.decided_at.map(|d| d.elapsed());
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
        self.ports.send(id, &ToAgent::GoalBearing(GoalBearing { robot: RobotId(id), bearing, step }))?;
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
        let event = json!({ "robot": id, "event": "agent_lost", "reason": death.reason, "state": format!("{state:?}") });
        let topic = format!("bycoms/{}/events", self.template.swarm);
        self.ports.recording.json(&topic, "bycoms.LaunchEvent", &event);
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
