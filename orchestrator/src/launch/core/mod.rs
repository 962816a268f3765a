//! The launch core: one deterministic state machine, no IO.
//!
//! Why sans-IO: `orchestrator launch` is the heart of the product, and its
//! rules (registration, duplicate refusal, settling, placement, the gate,
//! the time budget, partitions and re-sends, the dead-robot policy, the
//! order of verdicts) must be testable without processes, sockets or wall
//! clocks. So, as quinn-proto and smoltcp do, the core takes typed
//! [`Input`]s, each with the time it happened (µs of launch time), and
//! produces typed [`Output`]s (send this to that robot, start or kill that
//! agent, publish this gate event, note this line) plus the time of its
//! next deadline. It reads no clock, owns no bus, never blocks. Where the
//! launch "is" is data ([`Phase`]), not a call stack.
//!
//! The shells: `launch/driver.rs` feeds it from the bus, the pose source
//! and the agent source and carries out its outputs on the real ones
//! (wall clock); `orchestrator/tests/launch_sim.rs` runs it with simulated
//! agents over a seeded simulated network in virtual time. Lockstep and real
//! time differ only in which inputs arrive when, and in two rules: in
//! lockstep the core is the clock (it sends `Tick`s and waits for every
//! answer), in real time it answers each pose of the moving robot with a
//! bearing and republishes dead robots' poses once a period.
//!
//! Driving it: [`Core::handle`] takes in one input (state only, no
//! decision), [`Core::advance`] then takes every decision due at `now`,
//! [`Core::poll_output`] hands out what to do, [`Core::deadline`] says when
//! to call `advance` again if nothing comes in. Deciding only in `advance`
//! lets a shell hand in everything that arrived together (a tick's answers
//! and its poses) before the core acts on it.

pub mod log;
mod plausible;
pub mod referee;
mod slot;
mod wait;

pub use plausible::Implausible;
pub use referee::{Closed, Referee};
pub use slot::{FrameCount, Slot, SlotState};
pub use wait::{AnswerWait, RESEND_US};

use super::agents::{Gone, Reach};
use super::config::{Missing, OnDeath};
use super::events::{EventKind, LaunchEvent};
use super::gate::{GateParams, Verdict};
use super::summary::{Death, Outage, Outcome};
use crate::mocap::{PlacementConfig, PlacementWatch};
use bycoms_protocol::msg::{
    Deploy, FromAgent, GateEvent, GateKind, GoalBearing, Pose, Refused, Tick, ToAgent,
};
use bycoms_protocol::{RobotId, PROTOCOL_VERSION};
use bycoms_sim::agent_process::BadKind;
use bycoms_sim::Vec2;
use plausible::Anchors;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeSet, VecDeque};

/// How often an operator is reminded to place a robot, µs.
const REMIND_EVERY_US: u64 = 2_000_000;

/// What the agent seam reports about its kind, as properties (the core
/// knows no kind by name).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AgentTraits {
    /// The source's name, for the events channel and messages.
    pub kind: String,
    /// The agents exist on their own (remote agents, robots): all are
    /// started (or expected) at the beginning, not each at its turn.
    pub all_at_once: bool,
    /// A stuck robot is told to `Stop` (a real robot would keep pushing).
    pub stop_when_stuck: bool,
    /// Told how to start a missing agent, appended to the error naming
    /// robots that never registered.
    pub start_hint: String,
    /// Robots are put at the start by an operator, confirmed by motion
    /// capture, before they are enabled.
    pub placement: Option<PlacementConfig>,
    /// Poses that do not come over the bus are passed on to the agents
    /// (gateways turn bearings into the robot's frame with them).
    pub forward_poses: bool,
}

/// Everything the core needs to know before the launch starts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Setup {
    /// Robots available.
    pub robots: u32,
    /// The lockstep clock (else real time).
    pub lockstep: bool,
    /// The gate's motion test.
    pub params: GateParams,
    /// The time budget, active steps.
    pub step_limit: u64,
    /// Real time: one control period in wall µs (dt / speed).
    pub wall_period_us: u64,
    /// Real time: simulated seconds per wall second.
    pub speed: f64,
    /// Every live agent must answer a lockstep tick (a start pose) within
    /// this long, µs.
    pub tick_timeout_us: u64,
    /// What a dead agent means.
    pub on_death: OnDeath,
    /// What a robot whose agent never registers means.
    pub missing: Missing,
    /// Start the next agent while the current robot moves.
    pub prespawn: bool,
    /// Where robots start.
    pub start: Vec2,
    /// The goal.
    pub goal: Vec2,
    /// A pose that moved faster than this from the last one is refused
    /// (units per simulated second).
    pub max_speed: f64,
    /// The link grace, s (for messages).
    pub link_grace_s: f64,
    /// The registration timeout, s (for messages).
    pub register_timeout_s: f64,
    /// The agent seam's properties.
    pub agents: AgentTraits,
    /// Launch time 0 in ms since the Unix epoch (the summary's times).
    pub unix_base_ms: u64,
}

/// Something that happened, handed to [`Core::handle`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Input {
    /// Robot `robot`'s agent was started (`Output::Start` carried out).
    Started {
        /// The robot.
        robot: u32,
        /// Its pid, when it is a process on this host.
        pid: Option<u32>,
        /// What was done, in words.
        how: String,
    },
    /// A shell failed to carry something out; the launch ends with it.
    Failed(String),
    /// A report from an agent.
    Report(FromAgent),
    /// A pose, as the pose source saw it for robot `topic`.
    Pose {
        /// The robot the source saw it for.
        topic: u32,
        /// The pose.
        pose: Pose,
    },
    /// Robot `.0`'s agent is gone.
    Gone(u32, Gone),
    /// Robot `.0`'s agent became unreachable or came back.
    Reach(u32, Reach),
    /// Ctrl-C.
    Interrupt,
}

/// Something to do, from [`Core::poll_output`].
#[derive(Clone, Debug, PartialEq)]
pub enum Output {
    /// Open robot `.0`'s ports and poses, start its agent, and answer with
    /// [`Input::Started`] (or [`Input::Failed`]).
    Start(u32),
    /// Send a command to robot `.0`'s agent.
    Send(u32, ToAgent),
    /// Republish a dead robot's last pose (motion capture still sees it).
    Relay(Pose),
    /// Pass a pose from off the bus on to the agents.
    Forward(Pose),
    /// Publish a gate event.
    Gate(GateEvent),
    /// Record an event of a robot's agent.
    Event(LaunchEvent),
    /// A line for the terminal.
    Note(String),
    /// Count (and log) bad traffic.
    Bad(BadKind, String),
    /// End robot `.0`'s agent now.
    Kill(u32),
    /// Robot `.0`'s agent was heard from (its watchdog restarts).
    Heard(u32),
    /// What robot `.0`'s gateway says about its robot's link.
    RobotLink(u32, bool),
    /// What is sent from now on belongs to this simulated time, ns.
    SimTime(u64),
    /// Ask the operator to place a robot at the start.
    AskOperator(Deploy),
    /// Robot `.0` is being carried by hand (`true`) or was placed (`false`).
    Carried(u32, bool),
}

/// How a launch ended.
#[derive(Clone, Debug, PartialEq)]
pub struct Ending {
    /// The outcome.
    pub outcome: Outcome,
    /// The error, for [`Outcome::Error`].
    pub error: Option<String>,
}

/// A verdict or a death the core must act on.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Pending {
    Verdict(u32, Verdict),
    Died(u32),
}

/// Where the launch is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    /// Nothing started yet.
    Begin,
    /// Agents that exist on their own, and every robot is needed
    /// (`Missing::Fail`): awaiting every registration.
    AwaitingEveryone,
    /// Choosing the next robot to deploy.
    Choosing,
    /// Awaiting robot `.0`'s registration.
    AwaitingRegistration(u32),
    /// Robot `.0` hears every beacon (lockstep: one tick; real time: until `.1`).
    Settling(u32, Option<u64>),
    /// The operator places robot `.0` at the start.
    Placing(u32, Placing),
    /// Robot `.0` was told to deploy; its start pose is awaited.
    AwaitingStartPose(u32, AnswerWait),
    /// A robot is moving under the gate's watch.
    Watching,
    /// Over.
    Finished,
}

/// An operator's placement in progress.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placing {
    since: u64,
    reminded: u64,
    seen_us: Option<u64>,
}

/// The lockstep tick in flight.
#[derive(Clone, Debug)]
struct TickWait {
    step: u64,
    awaiting: BTreeSet<u32>,
    wait: AnswerWait,
}

/// The launch, as data.
pub struct Core {
    setup: Setup,
    slots: Vec<Slot>,
    referee: Referee,
    anchors: Anchors,
    phase: Phase,
    placement: Option<PlacementWatch>,
    tick: Option<TickWait>,
    ticks: u64,
    ticks_started: u64,
    next: u32,
    pending_deploy: Option<Deploy>,
    /// Robots that registered after their turn was skipped, in the order
    /// they came: each takes the next turn.
    late: VecDeque<u32>,
    last_bearing: Option<GoalBearing>,
    resends: u64,
    queue: VecDeque<Pending>,
    fatal: Option<String>,
    interrupted: bool,
    outputs: VecDeque<Output>,
    decided_at: Option<u64>,
    first_moving_us: Option<u64>,
    relay_at: u64,
    relay_frame: u64,
    ending: Option<Ending>,
}

impl Core {
    /// A launch about to start (nothing started until the first `advance`).
    pub fn new(setup: Setup) -> Self {
        let lockstep = setup.lockstep;
        let slots = (1..=setup.robots).map(Slot::new).collect();
        Self {
            referee: Referee::new(setup.params, setup.step_limit, lockstep),
            anchors: Anchors::new(setup.robots, setup.params.period_us, setup.max_speed),
            slots,
            phase: Phase::Begin,
            placement: None,
            tick: None,
            ticks: 0,
            ticks_started: 0,
            next: 1,
            pending_deploy: None,
            late: VecDeque::new(),
            last_bearing: None,
            resends: 0,
            queue: VecDeque::new(),
            fatal: None,
            interrupted: false,
            outputs: VecDeque::new(),
            decided_at: None,
            first_moving_us: None,
            relay_at: 0,
            relay_frame: 0,
            ending: None,
            setup,
        }
    }

    // ---- what the shells read -------------------------------------------

    /// Every robot's bookkeeping, in id order.
    pub fn slots(&self) -> &[Slot] {
        &self.slots
    }
    /// Where the launch is.
    pub fn phase(&self) -> Phase {
        self.phase
    }
    /// How it ended, once it has.
    pub fn ending(&self) -> Option<&Ending> {
        self.ending.as_ref()
    }
    /// Completed lockstep ticks.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }
    /// Active steps charged to the budget.
    pub fn spent(&self) -> u64 {
        self.referee.spent()
    }
    /// Commands sent again (partitions, lost messages).
    pub fn resends(&self) -> u64 {
        self.resends
    }
    /// Launch time of the first robot's start pose, µs.
    pub fn first_moving_us(&self) -> Option<u64> {
        self.first_moving_us
    }
    /// Whether robot `id`'s agent is started and not gone.
    pub fn is_running(&self, id: u32) -> bool {
        self.slot_ref(id).is_some_and(|s| s.alive)
    }

    /// The next thing to do.
    pub fn poll_output(&mut self) -> Option<Output> {
        self.outputs.pop_front()
    }

    /// When `advance` must run again if no input comes, µs of launch time.
    pub fn deadline(&self) -> Option<u64> {
        if self.ending.is_some() {
            return None;
        }
        let mut due: Option<u64> = None;
        let mut at = |t: u64| due = Some(due.map_or(t, |d| d.min(t)));
        if let Some(tick) = self.tick.as_ref().filter(|t| !t.awaiting.is_empty()) {
            at(tick.wait.next_due());
        }
        match self.phase {
            Phase::Settling(_, Some(until)) => at(until),
            Phase::AwaitingStartPose(_, wait) => at(wait.next_due()),
            Phase::Placing(_, p) => {
                let timeout = self.placement_timeout_us();
                at(p.since.saturating_add(timeout));
                at(p.reminded.saturating_add(REMIND_EVERY_US));
            }
            _ => {}
        }
        if !self.setup.lockstep && self.phase != Phase::Begin {
            at(self.relay_at);
        }
        due
    }

    // ---- inputs ---------------------------------------------------------

    /// Takes in one input that happened at `now` (µs of launch time). No
    /// decision is taken here beyond bookkeeping: see [`Core::advance`].
    pub fn handle(&mut self, now: u64, input: Input) {
        if self.ending.is_some() {
            return;
        }
        match input {
            Input::Started { robot, pid, how } => self.on_started(robot, pid, &how),
            Input::Failed(e) => {
                self.fatal.get_or_insert(e);
            }
            Input::Report(msg) => self.on_report(now, msg),
            Input::Pose { topic, pose } => self.on_pose(now, topic, pose),
            Input::Gone(id, gone) => self.on_death(now, id, gone),
            Input::Reach(id, change) => self.on_reach(now, id, change),
            Input::Interrupt => self.interrupted = true,
        }
    }

    fn slot(&mut self, id: u32) -> Option<&mut Slot> {
        id.checked_sub(1).and_then(|i| self.slots.get_mut(i as usize))
    }

    fn slot_ref(&self, id: u32) -> Option<&Slot> {
        id.checked_sub(1).and_then(|i| self.slots.get(i as usize))
    }

    fn note(&mut self, text: String) {
        self.outputs.push_back(Output::Note(text));
    }

    fn event(&mut self, robot: u32, event: EventKind, pid: Option<u32>, reason: Option<String>) {
        let state = self.slot_ref(robot).map(|s| format!("{:?}", s.state));
        let source = (event == EventKind::Spawned).then(|| self.setup.agents.kind.clone());
        let state = if event == EventKind::Spawned { None } else { state };
        self.outputs.push_back(Output::Event(LaunchEvent { robot, event, pid, source, reason, state }));
    }

    fn unix_ms(&self, now: u64) -> u64 {
        self.setup.unix_base_ms + now / 1000
    }

    fn on_started(&mut self, id: u32, pid: Option<u32>, how: &str) {
        if let Some(slot) = self.slot(id) {
            slot.pid = pid;
            slot.alive = true;
            // A late joiner is expected again after it registered.
            slot.state = if slot.registered_before_tick.is_some() {
                SlotState::Registered
            } else {
                SlotState::Spawned
            };
        }
        self.note(format!("robot {id}: {how}"));
        self.event(id, EventKind::Spawned, pid, None);
    }

    fn on_report(&mut self, now: u64, msg: FromAgent) {
        let id = msg.robot().0;
        let ticks_started = self.ticks_started;
        let all_at_once = self.setup.agents.all_at_once;
        let known = self.slot_ref(id).is_some_and(|s| s.state != SlotState::Waiting);
        if !known {
            self.outputs
                .push_back(Output::Bad(BadKind::UnknownRobot, format!("{msg:?} from an unknown robot")));
            return;
        }
        let Some(slot) = self.slot(id) else { return };
        let registered = slot.registered_before_tick.is_some();
        let kept = slot.instance;
        // Until its `Register` arrives an agent is not heard from: a
        // registration that was lost must not be hidden by heartbeats (the
        // agent repeats it with every heartbeat until it is answered, and
        // the registration timeout still applies).
        if !registered && !matches!(msg, FromAgent::Register(_)) {
            return;
        }
        if let FromAgent::Register(r) = &msg {
            if r.protocol_version != PROTOCOL_VERSION {
                // Anyone may send anything on a bus: counted, never fatal.
                // The robot is still awaited (its registration timeout
                // applies) and, should its own agent never register, its
                // death says why.
                let v = r.protocol_version;
                if !registered {
                    slot.foreign_version = Some(v);
                }
                let text = format!("robot {id} registers with protocol {v}");
                self.outputs.push_back(Output::Bad(BadKind::WrongVersion, text));
                return;
            }
            if registered && kept != Some(r.instance) {
                self.refuse_duplicate(id, r.instance);
                return;
            }
        }
        if !registered && matches!(msg, FromAgent::Register(_)) && !self.may_register(id) {
            return;
        }
        self.outputs.push_back(Output::Heard(id));
        let current = self.tick.as_ref().map(|t| t.step);
        let Some(slot) = self.slot(id) else { return };
        match msg {
            // A repeat: the agent had not heard from us yet when it sent it.
            FromAgent::Register(_) if registered => {}
            FromAgent::Register(r) => {
                slot.instance = Some(r.instance);
                slot.registered_before_tick = Some(ticks_started);
                slot.registered_at = Some(now);
                if slot.state == SlotState::Spawned {
                    slot.state = SlotState::Registered;
                }
                if slot.state == SlotState::Absent {
                    slot.state = SlotState::Registered;
                    slot.late = true;
                    slot.death = None;
                    self.late.push_back(id);
                    // Expected again: its source supervises it from now on.
                    self.outputs.push_back(Output::Start(id));
                    self.note(format!("robot {id}: registered late; it takes the next turn"));
                    self.event(id, EventKind::JoinedLate, None, None);
                } else if all_at_once {
                    let instance = r.instance;
                    self.note(format!("robot {id}: agent registered (instance {instance:016x})"));
                }
            }
            FromAgent::Heartbeat(_) => {}
            FromAgent::Status(s) => slot.mode = s.mode,
            FromAgent::TickDone(t) => {
                if let Some(tick) = self.tick.as_mut().filter(|_| Some(t.step) == current) {
                    tick.awaiting.remove(&id);
                }
            }
            // A real robot's telemetry is for recorders and monitors.
            FromAgent::Telemetry(_) => {}
            FromAgent::Link(l) => {
                if !l.up {
                    tracing::warn!(robot = id, silent_ms = l.silent_ms, "robot {id}'s link is lost");
                }
                self.outputs.push_back(Output::RobotLink(id, l.up));
            }
        }
    }

    /// A second agent (another instance) registers for robot `id`, which
    /// already has one: counted and told to leave; the first agent stays.
    fn refuse_duplicate(&mut self, id: u32, instance: u64) {
        let kept = self.slot_ref(id).and_then(|s| s.instance).unwrap_or_default();
        let text = format!(
            "robot {id} registered again by another agent (instance {instance:016x}, kept {kept:016x})"
        );
        self.outputs.push_back(Output::Bad(BadKind::Duplicate, text));
        tracing::warn!(
            robot = id,
            instance = format_args!("{instance:016x}"),
            "a second agent for robot {id} refused"
        );
        self.outputs.push_back(Output::Send(id, ToAgent::Refused(Refused { robot: RobotId(id), instance })));
    }

    fn on_pose(&mut self, now: u64, topic: u32, pose: Pose) {
        if pose.robot.0 != topic {
            let got = pose.robot;
            self.outputs.push_back(Output::Bad(
                BadKind::UnknownRobot,
                format!("pose of {got} on robot {topic}'s topic"),
            ));
            return;
        }
        let lockstep = self.setup.lockstep;
        let Some(slot) = self.slot_ref(topic) else { return };
        if !slot.alive || matches!(slot.state, SlotState::Waiting | SlotState::Spawned | SlotState::Lost) {
            // Our own relay of a dead robot, or a stray sample.
            return;
        }
        let state = slot.state;
        let clock = if lockstep {
            let newest_step = self.tick.as_ref().map_or(self.ticks, |t| t.step);
            plausible::Clock::Lockstep { newest_step }
        } else {
            plausible::Clock::Realtime { now_us: now, speed: self.setup.speed }
        };
        let carried = matches!(self.phase, Phase::Placing(id, _) if id == topic);
        match self.anchors.accept(topic, &pose, clock, carried) {
            Ok(true) => {}
            // A repeat or a late sample: nothing new (the gate has seen it).
            Ok(false) => return,
            Err(why) => {
                let text = format!("pose of robot {topic} at step {} refused: {why}", pose.step);
                self.outputs.push_back(Output::Bad(BadKind::Refused, text));
                return;
            }
        }
        if self.setup.agents.forward_poses {
            self.outputs.push_back(Output::Forward(pose));
        }
        let Some(slot) = self.slot(topic) else { return };
        slot.last_pose = Some(pose);
        if !lockstep && state != SlotState::Deploying {
            slot.frames.observe(pose.step);
        }
        if state == SlotState::Deploying && self.referee.watched().is_none() {
            // The start pose: the robot is deployed and under watch.
            let start = self.referee.open(topic, pose, self.ticks);
            let reaction = self.decided_at.map(|d| now.saturating_sub(d));
            let Some(slot) = self.slot(topic) else { return };
            slot.state = SlotState::Moving;
            slot.deployed_tick = Some(start.step + 1);
            slot.reaction_us = reaction;
            self.first_moving_us.get_or_insert(now);
            let event = GateEvent {
                robot: pose.robot,
                kind: GateKind::Deployed,
                x: pose.x,
                y: pose.y,
                step: start.step,
            };
            self.outputs.push_back(Output::Gate(event));
            self.note(format!("robot {topic}: deployed at ({:.2}, {:.2})", pose.x, pose.y));
        } else if self.referee.watched() == Some(topic) {
            if let Some(v) = self.referee.observe(topic, pose) {
                self.queue.push_back(Pending::Verdict(topic, v));
            }
        } else {
            return;
        }
        if !lockstep && self.queue.is_empty() {
            self.send_bearing(topic, &pose, pose.step + 1);
        }
    }

    /// Sends robot `id` its goal bearing from `pose` (the runner's function).
    fn send_bearing(&mut self, id: u32, pose: &Pose, step: u64) {
        let bearing = Vec2::new(pose.x, pose.y).bearing_to(self.setup.goal);
        let msg = GoalBearing { robot: RobotId(id), bearing, step };
        self.last_bearing = Some(msg);
        self.outputs.push_back(Output::Send(id, ToAgent::GoalBearing(msg)));
    }

    /// Robot `id`'s agent is gone: the dead-robot policy.
    fn on_death(&mut self, now: u64, id: u32, gone: Gone) {
        if let Some(tick) = self.tick.as_mut() {
            tick.awaiting.remove(&id);
        }
        let abort = self.setup.on_death == OnDeath::Abort;
        let noticed_unix_ms = self.unix_ms(now);
        let Some(slot) = self.slot(id) else { return };
        if !slot.alive && slot.death.is_some() {
            return;
        }
        let mut reason = gone.to_string();
        if let Some(v) = slot.foreign_version.filter(|_| slot.state == SlotState::Spawned) {
            reason.push_str(&format!(
                " (a registration with protocol version {v} was seen for it; this orchestrator speaks {PROTOCOL_VERSION})"
            ));
        }
        slot.alive = false;
        slot.death = Some(Death { reason: reason.clone(), noticed_unix_ms });
        let state = slot.state;
        let seen = slot.last_pose.is_some();
        self.note(format!("robot {id}: agent lost — {reason}"));
        self.event(id, EventKind::AgentLost, None, Some(reason.clone()));
        let fatal = match state {
            SlotState::Spawned => self.never_registered(id, gone, reason),
            SlotState::Registered | SlotState::Deploying => {
                if let Some(s) = self.slot(id) {
                    s.state = SlotState::Lost;
                }
                abort.then(|| format!("robot {id}'s agent was lost before its deployment: {reason}"))
            }
            SlotState::Moving => {
                self.queue.push_back(Pending::Died(id));
                abort.then(|| format!("robot {id}'s agent died while moving: {reason}"))
            }
            _ => (abort && seen).then(|| format!("robot {id}'s agent died: {reason}")),
        };
        if let Some(f) = fatal {
            self.fatal.get_or_insert(f);
        }
    }

    /// Robot `id`'s agent is gone without ever registering: with
    /// `Missing::Fail` the launch ends (the error, naming it); otherwise a
    /// process started here that ended is started once more, and a robot
    /// that still has no agent is absent: skipped at its turn.
    fn never_registered(&mut self, id: u32, gone: Gone, reason: String) -> Option<String> {
        if self.setup.missing == Missing::Fail {
            return Some(format!("robot {id}'s agent never registered: {reason}"));
        }
        let slot = self.slot(id)?;
        // A process that ended may have met a passing trouble; one that hung
        // for a whole registration timeout is not started again.
        if slot.pid.is_some() && slot.restarts == 0 && matches!(gone, Gone::Exited(_)) {
            slot.restarts += 1;
            slot.state = SlotState::Waiting;
            slot.death = None;
            self.note(format!("robot {id}: its agent is gone before it registered; starting it once more"));
            return None;
        }
        slot.state = SlotState::Absent;
        self.note(format!("robot {id}: absent — its agent never registered: {reason}"));
        self.event(id, EventKind::Absent, None, Some(reason));
        None
    }

    /// Whether a first `Register` for robot `id` is taken: an absent
    /// robot's agent that exists on its own (a remote agent, not a process
    /// started here) may join late; otherwise the robot's agent must be
    /// started and not gone.
    fn may_register(&self, id: u32) -> bool {
        self.slot_ref(id).is_some_and(|s| match s.state {
            SlotState::Absent => s.pid.is_none() && self.setup.agents.all_at_once,
            _ => true,
        })
    }

    fn on_reach(&mut self, now: u64, id: u32, change: Reach) {
        let grace = self.setup.link_grace_s;
        let at = self.unix_ms(now);
        let Some(slot) = self.slot(id) else { return };
        let (kind, text) = match change {
            Reach::Lost => {
                slot.outages.push(Outage { lost_unix_ms: at, back_unix_ms: None });
                tracing::warn!(robot = id, grace_s = grace, "robot {id}'s agent is unreachable");
                (
                    EventKind::LinkLost,
                    format!("robot {id}: link lost — waiting up to {grace} s for it to return"),
                )
            }
            Reach::Back => {
                let Some(outage) = slot.outages.last_mut().filter(|o| o.back_unix_ms.is_none()) else {
                    return;
                };
                outage.back_unix_ms = Some(at);
                let after = at.saturating_sub(outage.lost_unix_ms);
                tracing::info!(robot = id, after_ms = after, "robot {id}'s agent is back");
                (EventKind::LinkBack, format!("robot {id}: link back after {after} ms"))
            }
        };
        self.note(text);
        self.event(id, kind, None, None);
        if change == Reach::Back {
            self.resend(&[id]);
        }
    }

    /// Whether robot `id`'s agent is alive but unreachable now.
    fn unreachable(&self, id: u32) -> bool {
        self.slot_ref(id)
            .filter(|s| s.alive)
            .and_then(|s| s.outages.last())
            .is_some_and(|o| o.back_unix_ms.is_none())
    }

    /// Sends robots `ids` again what they may have missed: the pending
    /// `Deploy`; for a robot whose answer to the tick in flight is awaited,
    /// that tick's bearing (to the moving robot), the relays and the `Tick`.
    /// Agents answer a repeated `Tick` without stepping and a repeated
    /// `Deploy` with their pose, and the gate ignores poses it has seen.
    fn resend(&mut self, ids: &[u32]) {
        let mut relayed = false;
        for &id in ids {
            if let Some(deploy) = self.pending_deploy.filter(|d| d.robot.0 == id) {
                self.outputs.push_back(Output::Send(id, ToAgent::Deploy(deploy)));
                self.resends += 1;
            }
            let Some(t) = self.tick.as_ref().filter(|t| t.awaiting.contains(&id)).map(|t| t.step) else {
                continue;
            };
            if let Some(bearing) = self.last_bearing.filter(|b| b.robot.0 == id && b.step == t) {
                self.outputs.push_back(Output::Send(id, ToAgent::GoalBearing(bearing)));
            }
            if !relayed {
                self.relay_dead(t, t * self.setup.params.period_us);
                relayed = true;
            }
            self.outputs.push_back(Output::Send(id, ToAgent::Tick(Tick { step: t })));
            self.resends += 1;
        }
    }

    /// Republishes the last pose of every dead beacon.
    fn relay_dead(&mut self, step: u64, time_us: u64) {
        let dead: Vec<Pose> = self
            .slots
            .iter()
            .filter(|s| !s.alive && matches!(s.state, SlotState::Stuck | SlotState::Died))
            .filter_map(|s| s.last_pose)
            .collect();
        for mut pose in dead {
            pose.step = step;
            pose.time_us = time_us;
            self.outputs.push_back(Output::Relay(pose));
        }
    }

    // ---- decisions ------------------------------------------------------

    /// Takes every decision due at `now`.
    pub fn advance(&mut self, now: u64) {
        loop {
            if self.ending.is_some() {
                return;
            }
            if let Some(e) = self.fatal.clone() {
                self.name_the_missing();
                let error = self.fatal.take().unwrap_or(e);
                return self.end(Outcome::Error, Some(error));
            }
            if self.interrupted {
                return self.end(Outcome::Interrupted, None);
            }
            if !self.setup.lockstep && self.phase != Phase::Begin && now >= self.relay_at {
                self.relay_frame += 1;
                let sim_us = (now as f64 * self.setup.speed) as u64;
                self.relay_dead(self.relay_frame, sim_us);
                self.relay_at = now + self.setup.wall_period_us.max(1);
            }
            if let Some(tick) = self.tick.as_mut() {
                if !tick.awaiting.is_empty() {
                    let held = tick.awaiting.iter().any(|&id| {
                        let s = &self.slots[id as usize - 1];
                        s.alive && s.outages.last().is_some_and(|o| o.back_unix_ms.is_none())
                    });
                    let resend = tick.wait.resend_due(now, held);
                    let expired = tick.wait.expired(now);
                    let awaiting: Vec<u32> = tick.awaiting.iter().copied().collect();
                    if resend {
                        self.resend(&awaiting);
                    }
                    if !expired {
                        return;
                    }
                    for id in awaiting {
                        self.outputs.push_back(Output::Kill(id));
                        self.on_death(now, id, Gone::NoTickReply);
                    }
                    continue;
                }
                self.ticks = tick.step;
                self.tick = None;
            }
            if !self.step_phase(now) {
                return;
            }
        }
    }

    /// One step of the phase machine; false when it must wait.
    fn step_phase(&mut self, now: u64) -> bool {
        match self.phase {
            Phase::Begin => {
                if !self.setup.agents.all_at_once {
                    self.phase = Phase::Choosing;
                    return true;
                }
                for id in 1..=self.setup.robots {
                    self.outputs.push_back(Output::Start(id));
                }
                // Robots are needed when their turn comes, unless every one is.
                self.phase = if self.setup.missing == Missing::Fail {
                    Phase::AwaitingEveryone
                } else {
                    Phase::Choosing
                };
                // Starting is carried out by the shell before the core goes on.
                false
            }
            Phase::AwaitingEveryone => {
                let waiting =
                    self.slots.iter().any(|s| matches!(s.state, SlotState::Spawned | SlotState::Waiting));
                if !waiting {
                    self.phase = Phase::Choosing;
                }
                !waiting
            }
            Phase::Choosing | Phase::Watching => self.step_watching(now),
            Phase::AwaitingRegistration(id) => match self.slot_ref(id).map(|s| s.state) {
                Some(SlotState::Registered) => {
                    self.settle(id, now);
                    true
                }
                Some(SlotState::Spawned) => false,
                Some(SlotState::Waiting) => {
                    // Started once more (it died before it registered).
                    self.outputs.push_back(Output::Start(id));
                    false
                }
                _ => {
                    self.next = self.next.max(id + 1);
                    self.phase = Phase::Choosing;
                    true
                }
            },
            Phase::Settling(id, until) => {
                if until.is_some_and(|u| now < u) {
                    return false;
                }
                self.settled(id, now);
                true
            }
            Phase::Placing(id, placing) => self.step_placing(id, placing, now),
            Phase::AwaitingStartPose(id, mut wait) => match self.slot_ref(id).map(|s| s.state) {
                Some(SlotState::Deploying) => {
                    if wait.resend_due(now, self.unreachable(id)) {
                        self.resend(&[id]);
                    }
                    if wait.expired(now) {
                        self.pending_deploy = None;
                        self.outputs.push_back(Output::Kill(id));
                        self.on_death(now, id, Gone::NoStartPose);
                        self.phase = Phase::Choosing;
                        return true;
                    }
                    self.phase = Phase::AwaitingStartPose(id, wait);
                    false
                }
                Some(SlotState::Moving) => {
                    self.pending_deploy = None;
                    self.next = self.next.max(id + 1);
                    let next = self.next;
                    let prespawn = self.setup.prespawn
                        && self
                            .slot_ref(next)
                            .is_some_and(|s| s.state == SlotState::Waiting && s.restarts == 0);
                    if prespawn {
                        self.outputs.push_back(Output::Start(next));
                    }
                    self.phase = Phase::Watching;
                    true
                }
                _ => {
                    self.pending_deploy = None;
                    self.phase = Phase::Choosing;
                    true
                }
            },
            Phase::Finished => false,
        }
    }

    /// A robot under watch, or none: verdicts, the budget, the next tick or
    /// the next deployment.
    fn step_watching(&mut self, now: u64) -> bool {
        if let Some(outcome) = self.settle_verdicts(now) {
            self.end(outcome, None);
            return false;
        }
        let lockstep = self.setup.lockstep;
        if self.referee.watched().is_some() {
            if self.budget_spent() {
                self.end(Outcome::TimeLimit, None);
                return false;
            }
            if lockstep {
                self.start_tick(now);
                return true;
            }
            return false;
        }
        self.phase = Phase::Choosing;
        // A robot that joined late goes before the next one in order.
        let late = self.late.front().copied();
        let id = late.unwrap_or(self.next);
        if self.slot_ref(id).is_none() {
            match self.none_registered() {
                Some(error) => self.end(Outcome::Error, Some(error)),
                None => self.end(Outcome::RobotsExhausted, None),
            }
            return false;
        }
        if self.budget_spent() {
            self.end(Outcome::TimeLimit, None);
            return false;
        }
        if late.is_some() {
            self.late.pop_front();
        }
        match self.slot_ref(id).map(|s| s.state) {
            Some(SlotState::Lost | SlotState::Absent) => {
                if late.is_none() {
                    self.next += 1;
                }
                return true;
            }
            Some(SlotState::Waiting) => {
                self.outputs.push_back(Output::Start(id));
                self.phase = Phase::AwaitingRegistration(id);
                // The shell starts it before the core goes on.
                return false;
            }
            _ => {}
        }
        self.phase = Phase::AwaitingRegistration(id);
        true
    }

    /// Makes sure robot `id` hears every beacon before it moves: an agent's
    /// field comes from the other robots' poses and the bus keeps no
    /// history, so one full period must run after it registered. In
    /// lockstep always exactly one tick (so tick numbers do not depend on
    /// how fast an agent starts; the tick moves no robot); in real time two
    /// periods of wall time after its registration.
    fn settle(&mut self, id: u32, now: u64) {
        if self.setup.lockstep {
            self.phase = Phase::Settling(id, None);
            self.start_tick(now);
        } else {
            let registered = self.slot_ref(id).and_then(|s| s.registered_at).unwrap_or(now);
            self.phase = Phase::Settling(id, Some(registered + 2 * self.setup.wall_period_us));
        }
    }

    /// Robot `id` has settled: placed by the operator if it must be, then
    /// told to deploy.
    fn settled(&mut self, id: u32, now: u64) {
        // Lost while it settled: the next robot.
        if !self.slot_ref(id).is_some_and(|s| s.alive) {
            self.phase = Phase::Choosing;
            return;
        }
        let Some(config) = self.setup.agents.placement else {
            return self.open_gate(id, now);
        };
        let start = self.setup.start;
        self.outputs.push_back(Output::Carried(id, true));
        self.note(format!(
            "OPERATOR: place robot {id} at the start ({:.2}, {:.2}) — it is enabled once motion capture sees it there",
            start.x, start.y
        ));
        tracing::info!(
            robot = id,
            x = start.x,
            y = start.y,
            "operator asked to place the robot at the start"
        );
        self.outputs.push_back(Output::AskOperator(self.deploy_of(id)));
        self.placement = Some(PlacementWatch::new(RobotId(id), start, config));
        self.phase = Phase::Placing(id, Placing { since: now, reminded: now, seen_us: None });
    }

    fn placement_timeout_us(&self) -> u64 {
        self.setup.agents.placement.map_or(u64::MAX, |c| (c.timeout * 1e6) as u64)
    }

    fn step_placing(&mut self, id: u32, mut placing: Placing, now: u64) -> bool {
        if self.slot_ref(id).is_none_or(|s| s.state != SlotState::Registered) {
            self.outputs.push_back(Output::Carried(id, false));
            self.phase = Phase::Choosing;
            return true;
        }
        let pose = self.slot_ref(id).and_then(|s| s.last_pose);
        if let Some(p) = pose.filter(|p| placing.seen_us != Some(p.time_us)) {
            placing.seen_us = Some(p.time_us);
            if self.placement.as_mut().is_some_and(|w| w.observe(&p)) {
                self.outputs.push_back(Output::Carried(id, false));
                self.note(format!("robot {id}: at the start ({:.2}, {:.2}), enabling it", p.x, p.y));
                self.open_gate(id, now);
                return true;
            }
        }
        if now >= placing.since.saturating_add(self.placement_timeout_us()) {
            let start = self.setup.start;
            let last = self
                .placement
                .as_ref()
                .and_then(|w| w.last())
                .map_or("never".into(), |p| format!("at ({:.2}, {:.2})", p.x, p.y));
            let timeout = self.setup.agents.placement.map_or(0.0, |c| c.timeout);
            self.outputs.push_back(Output::Carried(id, false));
            self.fatal.get_or_insert(format!(
                "robot {id} was not seen at the start ({:.2}, {:.2}) within {timeout} s (last seen: {last})",
                start.x, start.y
            ));
            return true;
        }
        if now >= placing.reminded.saturating_add(REMIND_EVERY_US) {
            placing.reminded = now;
            self.outputs.push_back(Output::AskOperator(self.deploy_of(id)));
            tracing::info!(robot = id, "still waiting for the robot at the start");
        }
        self.phase = Phase::Placing(id, placing);
        false
    }

    fn deploy_of(&self, id: u32) -> Deploy {
        let (start, goal) = (self.setup.start, self.setup.goal);
        Deploy { robot: RobotId(id), x: start.x, y: start.y, heading: start.bearing_to(goal) }
    }

    /// Sends `Deploy` to robot `id`; its start pose is awaited next.
    fn open_gate(&mut self, id: u32, now: u64) {
        // A robot whose agent is gone is never deployed.
        if !self.slot_ref(id).is_some_and(|s| s.alive) {
            self.phase = Phase::Choosing;
            return;
        }
        let deploy = self.deploy_of(id);
        self.outputs.push_back(Output::Send(id, ToAgent::Deploy(deploy)));
        if let Some(slot) = self.slot(id) {
            slot.state = SlotState::Deploying;
        }
        // Deploying puts the robot at the start: its next pose may jump.
        self.anchors.release(id);
        self.pending_deploy = Some(deploy);
        self.phase = Phase::AwaitingStartPose(id, AnswerWait::new(now, self.setup.tick_timeout_us));
    }

    /// One lockstep tick: the moving robot's bearing, the relays, `Tick` to
    /// every live agent; its answers are awaited in `advance`.
    fn start_tick(&mut self, now: u64) {
        let t = self.ticks + 1;
        let period = self.setup.params.period_us;
        // Everything of tick t is logged at its simulated time t × dt.
        self.outputs.push_back(Output::SimTime(t * period * 1000));
        if let Some((id, pose)) = self.referee.last() {
            self.send_bearing(id, &pose, t);
        }
        self.relay_dead(t, t * period);
        self.ticks_started += 1;
        let live: Vec<u32> = self
            .slots
            .iter()
            .filter(|s| s.alive && s.registered_before_tick.is_some() && s.state != SlotState::Lost)
            .map(|s| s.id)
            .collect();
        for &id in &live {
            self.outputs.push_back(Output::Send(id, ToAgent::Tick(Tick { step: t })));
        }
        let wait = AnswerWait::new(now, self.setup.tick_timeout_us);
        self.tick = Some(TickWait { step: t, awaiting: live.into_iter().collect(), wait });
    }

    /// Acts on every queued verdict; the outcome if the run is won.
    fn settle_verdicts(&mut self, now: u64) -> Option<Outcome> {
        while let Some(p) = self.queue.pop_front() {
            let (id, state, kind, pose) = match p {
                Pending::Verdict(id, Verdict::Arrived(pose)) => {
                    (id, SlotState::Arrived, GateKind::Stopped { arrived: true }, Some(pose))
                }
                Pending::Verdict(id, Verdict::Stuck(pose)) => {
                    (id, SlotState::Stuck, GateKind::Stopped { arrived: false }, Some(pose))
                }
                Pending::Died(id) => (id, SlotState::Died, GateKind::Died, None),
            };
            let Some(closed) = self.referee.close(id) else { continue };
            let pose = pose.unwrap_or(closed.pose);
            self.decided_at = Some(now);
            let running = self.is_running(id);
            if let Some(slot) = self.slot(id) {
                slot.state = state;
                slot.steps = closed.steps;
                slot.last_pose = Some(pose);
                slot.decided_tick = Some(pose.step);
            }
            self.announce(id, kind, &pose);
            // A stuck real robot would keep pushing against what holds it:
            // motors off; it stays a beacon.
            if state == SlotState::Stuck && self.setup.agents.stop_when_stuck && running {
                self.outputs.push_back(Output::Send(id, ToAgent::Stop));
            }
            if state == SlotState::Arrived {
                if running {
                    self.outputs.push_back(Output::Send(id, ToAgent::Stop));
                }
                return Some(Outcome::Arrived);
            }
        }
        None
    }

    /// Whether the budget is used up (a robot past it is unfinished).
    fn budget_spent(&mut self) -> bool {
        match self.referee.budget_spent() {
            Ok(spent) => spent,
            Err(closed) => {
                let id = closed.robot;
                if let Some(slot) = self.slot(id) {
                    slot.state = SlotState::Unfinished;
                    slot.steps = closed.steps;
                    slot.last_pose = Some(closed.pose);
                }
                self.announce(id, GateKind::Timeout, &closed.pose);
                true
            }
        }
    }

    /// Publishes a gate event and notes it.
    fn announce(&mut self, id: u32, kind: GateKind, pose: &Pose) {
        let event = GateEvent { robot: pose.robot, kind, x: pose.x, y: pose.y, step: pose.step };
        self.outputs.push_back(Output::Gate(event));
        let what = match kind {
            GateKind::Stopped { arrived: true } => "arrived at the goal",
            GateKind::Stopped { arrived: false } => "stopped short of the goal: stuck, now a beacon",
            GateKind::Died => "lost while moving: a beacon where it was last seen",
            GateKind::Timeout => "still moving at the time limit",
            GateKind::Deployed => "deployed",
        };
        self.note(format!("robot {id}: {what} at ({:.2}, {:.2}), step {}", pose.x, pose.y, pose.step));
    }

    /// When every robot was tried and no agent ever registered, the launch
    /// did not run at all (a broken agent executable, a wrong protocol):
    /// an error naming the first robot and why, not "robots exhausted".
    fn none_registered(&self) -> Option<String> {
        if self.slots.iter().any(|s| s.registered_before_tick.is_some()) {
            return None;
        }
        let first = self.slots.iter().find_map(|s| s.death.as_ref().map(|d| (s.id, d)))?;
        Some(format!(
            "no agent ever registered: robot {}'s agent never registered: {}",
            first.0, first.1.reason
        ))
    }

    /// While every agent is awaited at the start, one error names every
    /// robot whose agent never came.
    fn name_the_missing(&mut self) {
        if self.phase != Phase::AwaitingEveryone {
            return;
        }
        let never: Vec<String> = self
            .slots
            .iter()
            .filter(|s| s.state == SlotState::Spawned && s.death.is_some())
            .map(|s| s.id.to_string())
            .collect();
        if !never.is_empty() {
            let noun = if never.len() == 1 { "robot" } else { "robots" };
            self.fatal = Some(format!(
                "the {} agents of {noun} {} never registered within {} s{}",
                self.setup.agents.kind,
                never.join(", "),
                self.setup.register_timeout_s,
                self.setup.agents.start_hint
            ));
        }
    }

    /// The launch is over: a robot still under watch is unfinished.
    fn end(&mut self, outcome: Outcome, error: Option<String>) {
        if let Some(closed) = self.referee.watched().and_then(|id| self.referee.close(id)) {
            if let Some(slot) = self.slot(closed.robot) {
                slot.state = SlotState::Unfinished;
                slot.steps = closed.steps;
                slot.last_pose = Some(closed.pose);
            }
        }
        self.tick = None;
        self.phase = Phase::Finished;
        self.ending = Some(Ending { outcome, error });
    }
}
