//! One simulated robot as its own process: the `sim-agent` binary.
//!
//! Why a process per robot: the architecture (`ARCHITECTURE.md`) makes every robot, simulated or
//! real, an independent agent that is given only its goal bearing and a
//! local field sample, so the orchestrator cannot tell a simulated robot
//! from a real one. A `sim-agent` is the simulated robot *and* its
//! simulated sensors: it listens to the other robots' poses (the sources of
//! its field), simulates its own body in the terrain, and publishes its pose
//! as motion capture would.
//!
//! * [`core`] — the robot as a sans-IO state machine around
//!   [`bycoms_sim::robot::SimRobot`], the same step the in-process runner takes;
//! * [`rules`] — the agent's message rules as a sans-IO state machine
//!   ([`SimAgentCore`]: registration, heartbeats, deploy, ticks, beacons, real-time
//!   periods), which the launch harness drives too;
//! * [`run`] — the single-threaded bus loop (lockstep or real time) that
//!   carries out what [`SimAgentCore`] says;
//! * [`settings`] — the run's settings, their encoding and fingerprint, and
//!   how an agent over zenoh gets the launch's;
//! * [`options`] / [`cli`] — the command line and `main`.
//!
//! What every swarm process shares (the lifeline, the failsafe, instance
//! ids, bad-traffic counting, the bus flags and sizing) is not here but in
//! `bycoms_runtime`, so that the real robot's `gateway` shares it
//! without depending on the simulator.
//!
//! Why a crate of its own: the simulated world (`bycoms_sim`) is what the
//! in-process runner, the sweeps and the fuzzers need, without a bus; this
//! crate adds the bus, the command line and the lab as a subcommand
//! (`sim-agent lab`, `bycoms_lab::process`), so the graph runs one way:
//! world ← lab ← sim-agent.

pub mod cli;
pub mod core;
pub mod options;
pub mod rules;
pub mod run;
pub mod settings;

pub use self::core::{Reject, RobotCore, RobotPhase};
pub use cli::{main_with, run_on, timing, AgentError};
pub use options::{AgentArgs, Clock, DEFAULT_SETTINGS_TIMEOUT_S};
pub use rules::{Counts, Leave, Rules, Said, SimAgentCore};
pub use settings::RunSettings;
