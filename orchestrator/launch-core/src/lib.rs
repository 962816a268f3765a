//! The launch core: one deterministic state machine, no IO.
//!
//! Why a crate of its own (`bycoms-launch-core`, beside `bycoms-launch`, as
//! quinn-proto beside quinn): Cargo then proves it sans-IO. Its
//! dependencies are the protocol's messages, the simulated world's plain
//! types, serde and postcard, with no bus backend, process, socket or async
//! runtime among them (`orchestrator/tests/layers.rs` holds them to an
//! allow-list), and the types it owns live here with it (`Gone`, the
//! policies, its events and records, the gate, placement), re-exported at
//! their old paths. `bycoms-launch` re-exports this crate as its `core`.
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
//! The shells: `orchestrator/launch/src/driver.rs` feeds it from the bus, the pose source
//! and the agent source and carries out its outputs on the real ones
//! (wall clock); `orchestrator/launch/tests/launch_sim.rs` runs it with simulated
//! agents over a seeded simulated network in virtual time. Lockstep and real
//! time differ only in which inputs arrive when, and in two rules: in
//! lockstep the core is the clock (it sends `Tick`s and waits for every
//! answer), in real time it answers each pose of the moving robot with a
//! bearing and republishes dead robots' poses once a period.
//!
//! Driving it: [`LaunchCore::handle`] takes in one input, [`LaunchCore::advance`]
//! then takes every decision due at `now`, [`LaunchCore::poll`] hands out
//! what to do, [`LaunchCore::deadline`] says when to call `advance` again if
//! nothing comes in. Deciding in `advance` lets a shell hand in everything
//! that arrived together (a tick's answers and its poses) before the core
//! acts on it.
//!
//! Which decisions each takes. `handle` takes only those that follow from
//! the one input alone, whatever else arrives with it: a registration
//! refused (duplicate, other settings, short failsafe grace, another
//! protocol) or taken (a late joiner expected again); a pose refused as
//! implausible, a start pose accepted (the robot deployed), the gate's
//! judgement of a pose queued; a reported death's dead-robot policy
//! (`on_death`: absent, lost, died, started once more, or the launch's
//! fault queued); a withdrawn token without an unreachable grace (gone at once);
//! reachability lost or back (noted, what was missed re-sent). `advance`
//! takes every decision that depends on time or on everything that arrived
//! together: the supervision timers (`timers.rs`: registration, heartbeat,
//! quiet, unreachable grace, robot-link grace), motion capture gone, the ending
//! (a fault, Ctrl-C, the budget, robots exhausted), the real-time relays
//! and beacons, the lockstep tick (re-sends, answers overdue, the next
//! tick), the queued verdicts in deployment order, and the phase machine
//! (choosing, registration awaited, settling, placement, deployment).
//!
//! Files: this one holds the types (setup, inputs, outputs, phase) and
//! what the shells read; `inputs.rs` the bookkeeping of each input;
//! `steps.rs` the decisions (the phase machine); `timers.rs` the
//! supervision timers; `ending.rs` why a launch ended in error, typed;
//! `referee.rs` the gate and the budget; `plausible.rs` which poses can be
//! believed; `wait.rs` the re-send timer; `silence.rs` motion capture gone
//! (real robots);
//! `stop.rs` a stop asked from outside; `revoke.rs` a robot's voice taken
//! away while the launch runs;
//! `moved.rs` what the views show (applied poses, beacon and state
//! changes, as outputs); `slot.rs` one robot's record; `clocks.rs` the agents' clock offsets; `log.rs` the record of
//! every call, which `orchestrator replay` plays back; `beacons.rs` the
//! beacons the simulated agents are told; `ahead.rs` creeping robots
//! stepped several periods per message, what they sent held (`held.rs`)
//! until its tick.

mod ahead;
mod beacon_table;
mod beacons;
mod clock_reading;
mod clocks;
mod ending;
pub mod events;
pub use bycoms_gate::gate;
mod gone;
mod held;
mod inputs;
pub mod log;
mod moved;
mod outputs;
pub use bycoms_gate::placement;
pub use bycoms_gate::view;
mod plausible;
mod policy;
pub mod records;
pub mod referee;
mod revoke;
mod silence;
mod slot;
mod steps;
mod stop;
mod stopping;
mod timers;
mod wait;
mod watch;
mod wind_down;

pub use clock_reading::{ClockLimits, ClockReading, ClockVerdict};
pub use ending::{DiedWhen, Fault};
pub use gone::Gone;
use gone::Reach;
pub use outputs::Output;
pub use plausible::Implausible;
pub use policy::{Missing, OnDeath};
pub use referee::{Closed, Referee};
pub use silence::LINK_TIMEOUT;
pub use slot::{FrameCount, Slot, SlotState};
pub use stop::{shown, MAX_WHY_CHARS};
pub use stopping::STOP_WAIT_US;
pub use wait::{AnswerTime, AnswerWait, MIN_RESEND_US, RESEND_US};
pub use watch::{least_failsafe_grace_ms, Supervision};
pub use wind_down::{WindDown, WindStep};

use bycoms_protocol::msg::{
    ClockOffset, Deploy, FromAgent, GateEvent, GateKind, GoalBearing, Pose, Refusal, Refused, Register, Tick,
    Ticks, ToAgent,
};
use bycoms_protocol::{RobotId, PROTOCOL_VERSION};
use bycoms_runtime::BadKind;
use bycoms_sim::Vec2;
use events::{EventKind, LaunchEvent};
use gate::{GateParams, Verdict};
use placement::{PlacementConfig, PlacementWatch};
use plausible::Anchors;
use records::{Death, Outage, Outcome, RevokedSummary, StopSummary};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeSet, VecDeque};

/// How often an operator is reminded to place a robot, µs.
const REMIND_EVERY_US: u64 = 2_000_000;

/// While a robot is placed and no pose of any robot has come this long, µs
/// (said with the first reminder), the launch says that no
/// motion capture reaches it.
const NO_POSE_AFTER_US: u64 = REMIND_EVERY_US;

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
    /// The agents sense the beacons they are sent ([`ToAgent::Beacon`]):
    /// simulated robots (real ones hear each other).
    pub beacons: bool,
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
    /// (`gate.max_speed`: world units per simulated second; `plausible.rs`).
    pub max_speed: f64,
    /// The registration timeout, s (for messages).
    pub register_timeout_s: f64,
    /// The agent seam's properties.
    pub agents: AgentTraits,
    /// Launch time 0 in ms since the Unix epoch (the summary's times).
    pub unix_base_ms: u64,
    /// The fingerprint of the run's settings: an agent that registers with
    /// another (non-zero) one is refused.
    pub settings: u64,
    /// The supervision timers' settings (`timers.rs`), the unreachable
    /// grace among them.
    pub supervision: Supervision,
    /// The limits of the agents' clock offsets (`clocks.rs`).
    pub clocks: ClockLimits,
    /// How the agents take commands.
    pub commands: Commands,
    /// How far ahead agents are started.
    pub starts: Starts,
    /// The simulated members of a swarm of real robots (a mixed swarm).
    pub members: Members,
}

/// Which robots of a launch of real robots are simulated ([`Setup::members`]):
/// a mixed swarm's `sim-agent`s, which `Deploy` puts at the start (no
/// operator places them) and which see their own poses (none is forwarded
/// to them). Every other rule (the gate, the field, the order) is the same
/// for both kinds.
///
/// Their speed-up (`--sim-speed`) is the one rule that differs: their
/// agents step that many times faster than the launch's speed, so their
/// poses' time runs ahead of the launch's clock by as much, and the core
/// judges each pose against its own robot's clock.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Members {
    /// The simulated robots' ids, in order (none: every robot is of the
    /// source's kind).
    pub simulated: Vec<u32>,
    /// How many times faster than [`Setup::speed`] they run.
    pub sim_speed: f64,
}

impl Default for Members {
    fn default() -> Self {
        Self { simulated: Vec::new(), sim_speed: 1.0 }
    }
}

impl Members {
    /// Whether robot `id` is simulated.
    pub fn is_simulated(&self, id: u32) -> bool {
        self.simulated.binary_search(&id).is_ok()
    }

    /// Robot `id`'s speed-up over the launch's: `sim_speed` for a
    /// simulated member, 1 for every other robot.
    pub fn speed_up(&self, id: u32) -> f64 {
        if self.is_simulated(id) {
            self.sim_speed
        } else {
            1.0
        }
    }
}

/// How far ahead of the robots' turns their agents are started (with
/// [`Setup::prespawn`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Starts {
    /// Agents kept started ahead of the robot that moves: robots `n + 1`
    /// to `n + ahead` once robot `n` moves (0 means 1). Why more than one: in lockstep a
    /// robot may be judged within a few milliseconds of wall time, less
    /// than an agent process takes to start here (3 to 6 ms: exec, its
    /// iceoryx2 node and ports), and the launch then waited for the next
    /// agent to register, more than half of a 300-robot crowd's wall time.
    pub ahead: u32,
}

/// How the agent seam's agents take commands (its properties, as
/// [`AgentTraits`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Commands {
    /// Lockstep: a robot judged stuck that still creeps is stepped this
    /// many periods per message ([`ToAgent::Ticks`], `ahead.rs`); 0 or 1:
    /// one `Tick` a period. Only for agents of the launch's own build
    /// (those it starts).
    pub ticks_at_once: u32,
    /// Nothing sent to or from a live agent is lost or repeated (a bus on
    /// this host, no injected `[faults]`): a tick is never re-sent, as an
    /// answer that has not come is only late. Why: re-sends to an agent
    /// that is only slow (a loaded machine) piled up in its command topic's
    /// buffer (64 messages) with the beacons and goal bearing sent again
    /// and pushed out the oldest, the beacons it had not read yet, so it
    /// stepped with a field short of them (`bench crowd --robots 1000` at
    /// load 11 to 59 ended after 12 882 to 13 263 ticks, with beacon gaps in
    /// the agents' logs); and an answer to a re-sent tick could be taken for
    /// the answer to the next batch of a settling agent's beacons (sent with
    /// the same tick again), which then outran the buffer.
    pub kept: bool,
}

/// Something that happened, handed to [`LaunchCore::handle`].
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
    /// Ctrl-C.
    Interrupt,
    /// Robot `.0`'s agent's last error before it was reported gone (its
    /// process's last error line: the reason it gives for an absent or
    /// lost robot).
    Said(u32, String),
    /// A stop asked from outside the launch (`orchestrator stop`, the ROS 2
    /// stop service): graceful ends the launch as Ctrl-C does; `now` first
    /// tells every running robot `Stop` (`stop.rs`).
    Stop(Stop),
    /// Robot `.0`'s agent's liveliness token came back (`true`) or went
    /// (`false`): a fact; the core's timers decide what it means
    /// (`timers.rs`).
    Token(u32, bool),
    /// Robot `.robot`'s voice taken away (`orchestrator revoke`, `certs
    /// --revoke` picked up by a running launch): it is told `Stop`, its
    /// agent is refused and its reports dropped from then on
    /// (`revoke.rs`).
    Revoke(Revoke),
}

/// A robot revoked while the launch runs, and by whom (see [`Input::Revoke`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Revoke {
    /// The robot.
    pub robot: u32,
    /// Who asked, e.g. `orchestrator revoke (uid 1000 on lab-3, pid 4242)`.
    pub who: String,
    /// Why, as the asker said it (may be empty).
    pub why: String,
}

/// A stop asked of the launch, and by whom (see [`Input::Stop`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Stop {
    /// Every running robot is told `Stop` at once before the launch ends.
    pub now: bool,
    /// Who asked, e.g. `orchestrator stop (pid 4242 on lab-3)`.
    pub who: String,
    /// Why, as the asker said it (may be empty).
    pub why: String,
}

/// What the launch waits for, in words (see [`LaunchCore::waiting`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Waiting {
    /// What, e.g. "robot 2's answer to tick 345".
    pub what: String,
    /// Times it was sent again.
    pub resent: u32,
}

/// How a launch ended.
#[derive(Clone, Debug, PartialEq)]
pub struct Ending {
    /// The outcome.
    pub outcome: Outcome,
    /// What went wrong, for [`Outcome::Error`] (typed; its words are its
    /// `Display`, rendered at the edge).
    pub error: Option<Fault>,
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
    /// Whether "no pose of any robot has arrived" was said.
    said_no_pose: bool,
}

/// The lockstep tick in flight.
#[derive(Clone, Debug)]
struct TickWait {
    step: u64,
    /// The agents whose `TickDone` has not come.
    awaiting: BTreeSet<u32>,
    /// The robot under watch, until its pose of this step has come: the
    /// next tick's bearing and the gate's judgement are made from it, so a
    /// tick whose pose was lost on the way is not over (its `TickDone` may
    /// have come).
    pose_of: Option<u32>,
    wait: AnswerWait,
    /// The agents that step in it: those it ticked and those whose run
    /// ahead covers it (`ahead.rs`).
    agents: u32,
    /// Whether no agent was starting when it began (see
    /// [`LaunchCore::quiet_us_per_agent`]).
    quiet: bool,
}

impl TickWait {
    /// Whether something of this tick is still awaited.
    fn open(&self) -> bool {
        !self.awaiting.is_empty() || self.pose_of.is_some()
    }

    /// The agents that still owe this tick something, in id order.
    fn owing(&self) -> Vec<u32> {
        let mut ids: BTreeSet<u32> = self.awaiting.clone();
        ids.extend(self.pose_of);
        ids.into_iter().collect()
    }
}

/// `total / count` (0 when nothing was counted).
fn per((total, count): (u64, u64)) -> f64 {
    if count == 0 {
        0.0
    } else {
        total as f64 / count as f64
    }
}

/// The launch, as data.
pub struct LaunchCore {
    setup: Setup,
    slots: Vec<Slot>,
    referee: Referee,
    anchors: Anchors,
    phase: Phase,
    placement: Option<PlacementWatch>,
    /// Whether a pose of any robot has come (a lab's motion capture runs).
    pose_heard: bool,
    tick: Option<TickWait>,
    ticks: u64,
    ticks_started: u64,
    /// Agents stepped over all ticks: `Tick`s sent (first sends only) and
    /// ticks covered by a run ahead (`ahead.rs`).
    ticked_agents: u64,
    /// Wall time inside the ticks answered without a re-send, µs, and
    /// their number: what a tick costs, without the waits for agents to
    /// start or for lost messages.
    tick_time: (u64, u64),
    /// Over the ticks of `tick_time` begun and ended while no agent was
    /// starting: their wall time, µs, and the agents they ticked.
    quiet_tick_time: (u64, u64),
    next: u32,
    pending_deploy: Option<Deploy>,
    /// Robots that registered after their turn was skipped, in the order
    /// they came: each takes the next turn.
    late: VecDeque<u32>,
    last_bearing: Option<GoalBearing>,
    resends: u64,
    /// How long answers take (when waits re-send first).
    answer_time: AnswerTime,
    queue: VecDeque<Pending>,
    fatal: Option<Fault>,
    interrupted: bool,
    outputs: VecDeque<Output>,
    decided_at: Option<u64>,
    first_moving_us: Option<u64>,
    relay_at: u64,
    relay_frame: u64,
    ending: Option<Ending>,
    beacons: beacon_table::BeaconTable,
    /// When motion capture last handed over each robot's pose, µs
    /// (`silence.rs`).
    mocap_heard: Vec<Option<u64>>,
    /// The stop asked from outside, once asked (`stop.rs`).
    stop: Option<StopSummary>,
    /// A stop `now` awaiting its answers (`stop.rs`).
    stopping: Option<stopping::Stopping>,
    /// Each robot's supervision timers (`timers.rs`).
    watches: Vec<watch::Watch>,
    /// The robots revoked, in the order they were (`revoke.rs`).
    revoked: Vec<RevokedSummary>,
    /// What agents that ran ahead sent for later steps, by step
    /// (`ahead.rs`).
    held: held::HeldBack,
}

impl LaunchCore {
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
            pose_heard: false,
            tick: None,
            ticks: 0,
            ticks_started: 0,
            ticked_agents: 0,
            tick_time: (0, 0),
            quiet_tick_time: (0, 0),
            next: 1,
            pending_deploy: None,
            late: VecDeque::new(),
            last_bearing: None,
            resends: 0,
            answer_time: AnswerTime::default(),
            queue: VecDeque::new(),
            fatal: None,
            interrupted: false,
            outputs: VecDeque::new(),
            decided_at: None,
            first_moving_us: None,
            relay_at: 0,
            relay_frame: 0,
            ending: None,
            beacons: beacon_table::BeaconTable::default(),
            mocap_heard: vec![None; setup.robots as usize],
            stop: None,
            stopping: None,
            watches: vec![watch::Watch::default(); setup.robots as usize],
            revoked: Vec::new(),
            held: held::HeldBack::default(),
            setup,
        }
    }

    // ---- what the shells read -------------------------------------------

    /// Whether robot `id` is a simulated member of a mixed swarm.
    pub fn is_simulated(&self, id: u32) -> bool {
        self.setup.members.is_simulated(id)
    }

    /// Every robot's bookkeeping, in id order.
    pub fn slots(&self) -> &[Slot] {
        &self.slots
    }
    /// Tests only (`testing`): robot `id`'s state set by hand (a rule test
    /// that needs a deployed robot without playing its deployment).
    #[cfg(feature = "testing")]
    pub fn set_state_by_hand(&mut self, id: u32, state: SlotState) {
        self.slots[id as usize - 1].state = state;
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
    /// `Tick`s sent (each agent once a tick, re-sends not counted): over
    /// [`Self::ticks`], the agents a tick wakes.
    pub fn ticked_agents(&self) -> u64 {
        self.ticked_agents
    }
    /// Mean wall time of a tick from its `Tick`s to its last answer, µs,
    /// over the ticks answered without a re-send (0: none).
    pub fn tick_us(&self) -> f64 {
        per(self.tick_time)
    }
    /// Wall time of a tick per agent that steps in it (ticked, or covered
    /// by a run of ticks), µs, over the ticks of
    /// [`Self::tick_us`] begun and ended while no agent was starting (0:
    /// none): what each agent that steps adds to a tick. Why apart: an
    /// agent process starting (its robot's turn is next) takes a core from
    /// the ticks around it for milliseconds, a cost of each robot, not of
    /// each tick.
    pub fn quiet_us_per_agent(&self) -> f64 {
        per(self.quiet_tick_time)
    }

    /// Whether an agent was started and has not registered yet.
    fn agent_starting(&self) -> bool {
        self.slots.iter().any(|s| s.state == SlotState::Spawned)
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
    /// When motion capture last handed over robot `id`'s pose, µs.
    pub fn pose_heard(&self, id: u32) -> Option<u64> {
        id.checked_sub(1).and_then(|i| self.mocap_heard.get(i as usize).copied().flatten())
    }
    /// Every beacon of the core's table and where it stands, in robot
    /// order (what the views' [`view::RunView`] must agree with).
    pub fn beacons(&self) -> Vec<(u32, Vec2)> {
        self.beacons.all()
    }
    /// Whether robot `id`'s agent is started and not gone.
    pub fn is_running(&self, id: u32) -> bool {
        self.slot_ref(id).is_some_and(|s| s.alive)
    }

    /// What the launch waits for now, if it waits for an agent: its
    /// registration, its answer to the tick in flight (or its pose of that
    /// tick), its start pose. The terminal says it when a wait lasts, so a
    /// launch that waits is never silent.
    pub fn waiting(&self) -> Option<Waiting> {
        let robots = |ids: &[u32]| {
            let list: Vec<String> = ids.iter().map(u32::to_string).collect();
            let noun = if ids.len() == 1 { "robot" } else { "robots" };
            format!("{noun} {}", list.join(", "))
        };
        if let Some(t) = self.tick.as_ref().filter(|t| t.open()) {
            let answers: Vec<u32> = t.awaiting.iter().copied().collect();
            let what = match t.pose_of.filter(|id| !t.awaiting.contains(id)) {
                Some(id) if answers.is_empty() => format!("robot {id}'s pose of tick {}", t.step),
                Some(id) => {
                    format!("{}'s answers to tick {} and robot {id}'s pose of it", robots(&answers), t.step)
                }
                None if answers.len() == 1 => format!("{}'s answer to tick {}", robots(&answers), t.step),
                None => format!("{}'s answers to tick {}", robots(&answers), t.step),
            };
            return Some(Waiting { what, resent: t.wait.resent() });
        }
        let what = match self.phase {
            Phase::AwaitingEveryone => {
                let ids: Vec<u32> =
                    self.slots.iter().filter(|s| s.state == SlotState::Spawned).map(|s| s.id).collect();
                format!("the agents of {} to register", robots(&ids))
            }
            Phase::AwaitingRegistration(id) => format!("robot {id}'s agent to register"),
            Phase::AwaitingStartPose(id, wait) => {
                return Some(Waiting { what: format!("robot {id}'s start pose"), resent: wait.resent() });
            }
            _ => return None,
        };
        Some(Waiting { what, resent: 0 })
    }

    /// The next thing to do.
    pub fn poll(&mut self) -> Option<Output> {
        self.outputs.pop_front()
    }

    /// The next output [`Self::poll`] would hand out, left in place.
    pub fn peek_output(&self) -> Option<&Output> {
        self.outputs.front()
    }

    /// When `advance` must run again if no input comes, µs of launch time.
    pub fn deadline(&self) -> Option<u64> {
        if self.ending.is_some() {
            return None;
        }
        // A stop `now` under way decides nothing else but the robots'
        // supervision and motion capture gone (`stop.rs`).
        if let Some(t) = self.stop_due_at() {
            let others = [self.supervision_due(), self.mocap_due()];
            return Some(others.into_iter().flatten().fold(t, u64::min));
        }
        let mut due: Option<u64> = None;
        let mut at = |t: u64| due = Some(due.map_or(t, |d| d.min(t)));
        if let Some(tick) = self.tick.as_ref().filter(|t| t.open()) {
            at(tick.wait.next_due());
        }
        match self.phase {
            Phase::Settling(id, Some(until)) => at(until.max(self.beacons_ready_at(id))),
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
        if let Some(t) = self.mocap_due() {
            at(t);
        }
        if let Some(t) = self.supervision_due() {
            at(t);
        }
        due
    }

    // ---- inputs ---------------------------------------------------------

    /// Takes in one input that happened at `now` (µs of launch time): its
    /// bookkeeping, and only the decisions that follow from it alone (see
    /// the module docs); the rest is [`LaunchCore::advance`]'s.
    pub fn handle(&mut self, now: u64, input: Input) {
        if self.ending.is_some() || self.revoked_drops(&input) {
            return;
        }
        match input {
            Input::Started { robot, pid, how } => self.on_started(now, robot, pid, &how),
            Input::Failed(e) => {
                self.fatal.get_or_insert(Fault::Failed(e));
            }
            Input::Report(msg) => self.on_report(now, msg),
            Input::Pose { topic, pose } => {
                self.mocap_heard(now, topic);
                self.on_pose(now, topic, pose);
            }
            Input::Gone(id, gone) => self.gone(now, id, gone),
            Input::Interrupt => self.interrupted = true,
            Input::Said(id, words) => {
                if let Some(slot) = self.slot(id) {
                    slot.last_error = Some(words);
                }
            }
            Input::Stop(stop) => self.on_stop(now, stop),
            Input::Token(id, present) => self.watch_token(now, id, present),
            Input::Revoke(revoke) => self.on_revoke(now, revoke),
        }
    }

    /// Robot `id`'s agent is gone (reported, or by a timer). A robot lost
    /// with the room is not judged dead for it: the launch ends saying the
    /// room is gone (`silence.rs`).
    fn gone(&mut self, now: u64, id: u32, gone: Gone) {
        let lost_link = matches!(gone, Gone::RobotLinkLost).then_some(id);
        match self.mocap_gone(now, lost_link) {
            Some(error) => self.fatal = Some(error),
            None => self.on_death(now, id, gone),
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

    /// Launch time `now` (µs) in ms since the Unix epoch.
    pub fn unix_ms(&self, now: u64) -> u64 {
        self.setup.unix_base_ms + now / 1000
    }
}

/// The launch core in the shape of every sans-IO core
/// ([`bycoms_protocol::sans_io`]): its own methods of the same names.
impl bycoms_protocol::SansIo for LaunchCore {
    type Input<'a> = Input;
    type Handled = ();
    type Output<'a> = Output;

    fn handle(&mut self, now: u64, input: Input) {
        LaunchCore::handle(self, now, input);
    }

    fn advance(&mut self, now: u64) {
        LaunchCore::advance(self, now);
    }

    fn poll(&mut self) -> Option<Output> {
        LaunchCore::poll(self)
    }

    fn deadline(&self) -> Option<u64> {
        LaunchCore::deadline(self)
    }
}
