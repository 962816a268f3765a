//! The agents seam: where a launch's agents come from.
//!
//! Why a trait: the engine and the gate care that robot `k` has an agent
//! that registers, answers and may die — not whether that agent is a
//! process spawned here ([`spawned::Spawned`], today's default), a
//! `sim-agent` started by hand on another host (remote agents), or a real
//! robot behind a `gateway` process. Each kind implements
//! [`AgentSource`]; the engine holds a `Box<dyn AgentSource>` and nothing
//! else about them. Messages never go through a source: every agent,
//! whatever its kind, talks to the orchestrator over the launch's bus
//! (`orchestrator/launch/src/ports.rs`); a source only starts agents, watches their
//! liveness and ends them. The kinds: [`spawned::Spawned`] (default),
//! [`remote::Remote`] (`--agents remote`), [`gateways::Gateways`]
//! (`--agents real`, acoustic robots), [`ros2_robots::Ros2Robots`]
//! (`--agents real`, a robots file of ROS 2 robots), [`mixed::Mixed`]
//! (a robots file with simulated members beside them); [`choice`] picks one
//! from the config.
//!
//! Contract (checked for every implementation by the one conformance suite,
//! `orchestrator/tests/agent_source_suite.rs`): a source reports facts,
//! never a deadline, and reads no clock. Every supervision rule
//! (registration and heartbeat timeouts, the link grace, the quiet rule,
//! the robot-link grace) is a timer of the launch core
//! (`orchestrator/launch-core/src/timers.rs`), which ends an agent it judged gone with
//! [`AgentSource::kill`].
//!
//! * [`AgentSource::start`] makes robot `id`'s agent exist or expected;
//!   from then on [`AgentSource::is_running`] is true until the agent is
//!   reported gone by [`AgentSource::poll`], killed, or wound down;
//! * [`AgentSource::poll`] is the **single place** where an agent that
//!   ended is reported, each exactly once, with its [`Gone`] reason: its
//!   process exited (with its status), its thread ended. An agent the
//!   engine killed itself ([`AgentSource::kill`]) is not reported again;
//! * [`AgentSource::tokens`] reports liveliness tokens that went or came
//!   back (agents on zenoh), each change once;
//! * winding down (after the engine sent `Shutdown`):
//!   [`AgentSource::ask_to_end`], then [`AgentSource::reap`] until nothing
//!   runs or the grace is over (the driver's clock, `driver::wind_down`),
//!   then [`AgentSource::end_rest`] ends the rest and names them; after it
//!   nothing is running. Dropping a source ends whatever is still running.
//!
//! The trait is object-safe and not `Send` (the launch runs on one thread;
//! spawned children are started from one thread of their own that lives as
//! long as their source, see `spawner`).

/// The methods of an [`AgentSource`] that wraps another (reached by its
/// `inner()` and `inner_mut()`): whether agents run, end, are heard and
/// ended is the inner source's business; a wrapper (the gateways', the ROS 2
/// robots') says only what its agents are and how they start. Written once
/// here, used inside each wrapper's `impl AgentSource`.
macro_rules! forward_to_inner {
    () => {
        fn heard(&mut self, id: u32) {
            self.inner_mut().heard(id);
        }
        fn is_running(&self, id: u32) -> bool {
            self.inner().is_running(id)
        }
        fn pid(&self, id: u32) -> Option<u32> {
            self.inner().pid(id)
        }
        fn poll(&mut self) -> Vec<(u32, Gone)> {
            self.inner_mut().poll()
        }
        fn tokens(&mut self) -> Vec<(u32, bool)> {
            self.inner_mut().tokens()
        }
        fn last_error(&mut self, id: u32) -> Option<String> {
            self.inner_mut().last_error(id)
        }
        fn kill(&mut self, id: u32) -> bool {
            self.inner_mut().kill(id)
        }
        fn ask_to_end(&mut self) {
            self.inner_mut().ask_to_end();
        }
        fn reap(&mut self) -> bool {
            self.inner_mut().reap()
        }
        fn end_rest(&mut self) -> Vec<u32> {
            self.inner_mut().end_rest()
        }
    };
}

pub mod choice;
pub mod executable;
pub mod gateways;
pub mod mixed;
pub mod remote;
pub mod ros2_robots;
pub mod spawned;
pub mod spawner;
pub mod stderr_tap;
pub mod threads;

use bycoms_runtime::failsafe::FailsafeArgs;
use bycoms_runtime::BusArgs;
use bycoms_sim_agent::{AgentArgs, RunSettings};
use std::time::Duration;

/// Lockstep: periods a creeping robot of the launch's own agents is
/// stepped with one `ToAgent::Ticks`. Why 32: what its agent publishes
/// for them at once (32 poses, up to 32 statuses, a `TickDone`) stays
/// well within a topic's buffer of 64 unread messages per publisher
/// (`bycoms_protocol::bus::DEFAULT_BUFFER`), and a run costs its tick
/// about 32 steps of the robot (a few µs).
pub const TICKS_AT_ONCE: u32 = 32;

/// How an agent joins this launch, whatever its kind (a `sim-agent`, a
/// robot's gateway): the swarm, the bus (where the orchestrator listens,
/// the robot's own zenoh config), the failsafe grace, the orchestrator as
/// its parent. What it runs comes apart: the launch's [`RunSettings`].
#[derive(Clone, Debug, PartialEq)]
pub struct Joining {
    /// The swarm's name.
    pub swarm: String,
    /// The orchestrator's pid (none: an agent that outlives no parent).
    pub parent_pid: Option<i32>,
    /// The bus and where the orchestrator listens.
    pub bus: BusArgs,
    /// The failsafe when the orchestrator is lost.
    pub failsafe: FailsafeArgs,
    /// A simulated agent's heartbeat period once its robot is parked, ms.
    pub parked_heartbeat_ms: u64,
}

impl Joining {
    /// Robot `robot`'s `sim-agent` command line: how it joins, then the
    /// run's settings (the terrain on its stdin, `--terrain -`), by the
    /// sim-agent's own [`RunSettings::onto`].
    pub fn sim_agent(&self, robot: u32, settings: &RunSettings) -> AgentArgs {
        settings.onto(AgentArgs {
            parent_pid: self.parent_pid,
            parked_heartbeat_ms: Some(self.parked_heartbeat_ms),
            bus: self.bus.clone(),
            failsafe: self.failsafe,
            ..AgentArgs::new(self.swarm.clone(), robot)
        })
    }
}

/// What an agent needs to be started: how it joins and what it runs.
#[derive(Clone, Copy, Debug)]
pub struct AgentPlan<'a> {
    /// How it joins the launch (its robot's own zenoh config set).
    pub joining: &'a Joining,
    /// The run's settings, the terrain in the text format among them
    /// (simulated agents build their world from it; real robots have the
    /// real one).
    pub settings: &'a RunSettings,
}

/// What [`AgentSource::start`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Started {
    /// A process was started on this host.
    Process {
        /// Its pid.
        pid: u32,
    },
    /// Nothing was started here: the agent is expected to come and register
    /// (a remote agent, a robot's gateway started elsewhere).
    Awaited,
    /// A thread of this process was started (in-memory launches).
    Thread,
}

impl std::fmt::Display for Started {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Process { pid } => write!(f, "agent started (pid {pid})"),
            Self::Awaited => write!(f, "awaiting its agent"),
            Self::Thread => write!(f, "agent started (a thread of this process)"),
        }
    }
}

/// What the seam reports of an agent (the launch core's inputs, owned there).
pub use bycoms_launch_core::Gone;

/// Why an agent could not be started.
#[derive(Debug, thiserror::Error)]
pub enum AgentError {
    /// The agent executable could not be started.
    #[error("cannot start the agent {program}: {source}")]
    Spawn {
        /// The executable.
        program: String,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The terrain could not be handed to the agent.
    #[error("cannot hand the terrain to robot {robot}'s agent: {source}")]
    Handoff {
        /// The robot.
        robot: u32,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The robot is not one this source can provide.
    #[error("robot {robot} has no agent in this launch: {why}")]
    NoSuchRobot {
        /// The robot.
        robot: u32,
        /// Why not.
        why: String,
    },
    /// Any other failure of a source (its own typed error, boxed).
    #[error(transparent)]
    Other(Box<dyn std::error::Error + Send + Sync>),
}

/// What an agent source says of its agents: how the core starts, holds,
/// feeds and judges them. Each source writes its own once (its module's
/// `properties` function, e.g. [`spawned::properties`]); the launch's setup
/// reads them through [`AgentSource::properties`] and the launch harness
/// calls the same functions for the sources it plays, so a property
/// changed in a source changes what the 10 000 schedules test.
#[derive(Clone, Debug, PartialEq)]
pub struct AgentProperties {
    /// The kind of source (`spawned`, `remote`, `gateway`), for logs.
    pub kind: &'static str,
    /// Whether the agents exist independently of the launch (remote agents,
    /// robots): then the core starts (or expects) every robot's agent at
    /// the beginning, instead of each when (or just before) its robot is
    /// needed. Each robot is still needed only at its turn.
    pub all_at_once: bool,
    /// Whether an operator puts each robot at the start (confirmed by
    /// motion capture) before it is enabled: real robots (simulated agents
    /// are put there by `Deploy` itself).
    pub needs_placement: bool,
    /// Whether a robot judged stuck is told to `Stop`: a real robot would
    /// keep pushing against what holds it.
    pub stop_when_stuck: bool,
    /// Whether the agents want the poses the launch sees when those do not
    /// come over the bus (a gateway turns bearings into its robot's frame
    /// with them).
    pub wants_poses: bool,
    /// Whether the agents sense the beacons the launch sends them
    /// (`ToAgent::Beacon`): simulated robots and ROS 2 robots (a virtual
    /// field); the acoustic robots hear each other instead.
    pub senses_beacons: bool,
    /// Lockstep: how many periods a creeping robot judged stuck may be
    /// stepped with one message (`ToAgent::Ticks`; the core holds what its
    /// agent sends until each step's tick). Only agents of the launch's own
    /// build take more than 1 (one `Tick` a period).
    pub ticks_at_once: u32,
    /// Whether what is sent to or from a live agent always arrives, in
    /// order, once: a bus on this host (iceoryx2, memory), where nothing is
    /// lost but what overflows a topic's buffer. Unless the launch injects
    /// `[faults]`, such an agent's ticks are never re-sent (an answer that
    /// has not come is late, not lost). No for a link that can be cut.
    pub keeps_commands: bool,
    /// How to start an agent that never came, for the error that names the
    /// robots whose agents never registered (empty: nothing to say).
    pub start_hint: &'static str,
    /// What [`AgentSource::end_rest`] does to agents that do not exit, in
    /// words for the terminal.
    pub ended_by: &'static str,
    /// Whether an agent of this source that cannot be reached may come
    /// back (remote agents, gateways elsewhere): then the core holds it for
    /// the launch's link grace, and takes one silent for the quiet as
    /// unreachable (a lost agent is gone otherwise).
    pub held_when_unreachable: bool,
    /// How long a robot's own link reported down (`FromAgent::Link { up:
    /// false }`) must stay down before the core takes the robot as gone
    /// (sources of real robots); none: robot links are not watched.
    pub robot_link_grace: Option<Duration>,
    /// The robots whose agents simulate their bodies among a source of
    /// real robots (a mixed swarm's `kind = "sim"` members, in order):
    /// no operator places them and no pose is forwarded to them (the
    /// core's [`Members`](crate::core::Members)).
    pub simulated: Vec<u32>,
}

impl AgentProperties {
    /// A source of `kind` whose agents are started one at a time, killed
    /// when they do not end, gone when lost, sense the beacons and take one
    /// tick a message over a link that can lose them: what each source's
    /// `properties` starts from.
    pub const fn of_kind(kind: &'static str) -> Self {
        Self {
            kind,
            all_at_once: false,
            needs_placement: false,
            stop_when_stuck: false,
            wants_poses: false,
            senses_beacons: true,
            ticks_at_once: 1,
            keeps_commands: false,
            start_hint: "",
            ended_by: "killed",
            held_when_unreachable: false,
            robot_link_grace: None,
            simulated: Vec::new(),
        }
    }
}

/// Where agents come from; see the module docs for the contract.
pub trait AgentSource {
    /// What this source's agents are ([`AgentProperties`]): written once
    /// per source, by its module's `properties` function, which the launch
    /// harness calls too.
    fn properties(&self) -> AgentProperties;

    /// Starts robot `id`'s agent, or starts expecting it. The engine opens
    /// the robot's ports first, so nothing the agent sends is missed.
    fn start(&mut self, id: u32, plan: &AgentPlan<'_>) -> Result<Started, AgentError>;

    /// Notes that robot `id`'s agent registered and was heard from (a
    /// fact, no clock: the core keeps the heartbeat timer). Default:
    /// nothing to note.
    fn heard(&mut self, _id: u32) {}

    /// Whether robot `id`'s agent is started and not yet gone.
    fn is_running(&self, id: u32) -> bool;

    /// The pid of robot `id`'s agent when it is a process on this host.
    fn pid(&self, id: u32) -> Option<u32>;

    /// The agents that ended since the last poll (a process exited, a
    /// thread ended), each reported once (the only place where endings are
    /// reported).
    fn poll(&mut self) -> Vec<(u32, Gone)>;

    /// The liveliness tokens of running agents that went (`false`) or came
    /// back (`true`) since the last call. Default: none (no tokens).
    fn tokens(&mut self) -> Vec<(u32, bool)> {
        Vec::new()
    }

    /// Ends robot `id`'s agent now (kill a process, drop a remote agent);
    /// whether it was running. It is not reported by `poll` afterwards.
    fn kill(&mut self, id: u32) -> bool;

    /// The last error robot `id`'s agent said before [`AgentSource::poll`]
    /// reported it gone (a process's last error line), taken once.
    fn last_error(&mut self, _id: u32) -> Option<String> {
        None
    }

    /// After `Shutdown` was sent, before the grace: asks agents that may
    /// not have heard it to end. Default: nothing.
    fn ask_to_end(&mut self) {}

    /// During the grace: takes in the agents that ended; whether some still
    /// run (that can be seen: an agent on another host whose leaving cannot
    /// be seen counts as ended).
    fn reap(&mut self) -> bool;

    /// After the grace: ends every agent still running; returns those that
    /// had to be ended.
    fn end_rest(&mut self) -> Vec<u32>;
}
