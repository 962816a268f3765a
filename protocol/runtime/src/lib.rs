//! What every BYCOMS swarm process shares, in one place that is not the
//! simulator: the binaries (`orchestrator`, `sim-agent`, `natnet-serve`,
//! the `gateway`) live in different crates, and a real robot's
//! gateway must not depend on the simulated world to behave like the rest.
//!
//! * [`stats`] — the one quantile and median of measured figures (always
//!   built: no dependencies);
//! * [`seconds`] — the one check of a number of seconds from a flag or a
//!   config key (always built);
//! * [`capped`] — the one reader of a user's file with a size cap
//!   (always built; `bycoms_protocol::capped`, so that the protocol's own
//!   readers of key files, zenoh configs and certificates use it too);
//! * [`words`] — counts ("1 robot"), signed figures and foreign text in
//!   the words a terminal shows (always built);
//! * [`epoch`] — the one conversion of a shell's wall clock into a
//!   sans-IO core's time, µs since an epoch it picks (always built);
//! * [`logging`] (feature `logging`) — one logging setup: `tracing` on
//!   stderr, `RUST_LOG`, `--log-format text|json`, status lines, the text
//!   of an error;
//! * [`exit`] and [`out`] (feature `commands`) — how a command of the
//!   orchestrator's crates ends (exit codes, the usage error) and what it
//!   puts out (stdout lines, the one overwrite rule, atomic writes);
//!
//! and behind `process` (the default) the pieces of a swarm process:
//!
//! * [`child`] — the one wait for a child process with a bound;
//! * [`lifeline`] — why an agent never outlives the orchestrator;
//! * [`interrupt`] — the one Ctrl-C / SIGTERM / SIGHUP handler of a process;
//! * [`inherited`] — the files a parent left open, closed first thing;
//! * [`instance`] — which process speaks for a robot (its `Register`);
//! * [`failsafe`] — a robot whose orchestrator is gone (zenoh liveliness) stops;
//! * [`traffic`] — bad messages are counted, never fatal;
//! * [`bus_args`] — the bus flags and the bus of every agent process
//!   (`sim-agent`, the `gateway`, `sim-agent lab`);
//! * [`bus_config`] — the iceoryx2 sizing ([`ipc_config`]) and the zenoh
//!   settings ([`zenoh_config`]) every process of a swarm must share;
//! * [`cli`] — what every swarm binary's command line and `main` share:
//!   the speed-up check, a command line with subcommands, the iceoryx2
//!   and zenoh set-up;
//!
//! and behind `ros2`:
//!
//! * [`ros2`] — a ROS 2 node and its publishers on a zenoh session, as
//!   rmw_zenoh puts them (the launch's `--ros2` output, a ground robot's
//!   agent's velocity commands);
//!
//! and behind `doctor` (with `process`):
//!
//! * [`doctor`] — the findings of every host's doctor and the checks they
//!   share (`orchestrator doctor`, `gateway doctor`, `sim-agent doctor`).
#![forbid(unsafe_code)]

pub mod bad;
pub use bad::BadKind;
pub use bycoms_protocol::capped;
pub mod epoch;
pub use epoch::Epoch;
#[cfg(feature = "logging")]
pub mod logging;
pub mod seconds;
pub mod stats;
pub mod words;

#[cfg(feature = "commands")]
pub mod exit;
#[cfg(feature = "commands")]
pub mod out;

#[cfg(feature = "process")]
pub mod bus_args;
#[cfg(feature = "process")]
pub mod bus_config;
#[cfg(feature = "process")]
pub mod child;
#[cfg(feature = "process")]
pub mod cli;
#[cfg(feature = "doctor")]
pub mod doctor;
#[cfg(feature = "process")]
pub mod failsafe;
#[cfg(feature = "process")]
pub mod inherited;
#[cfg(feature = "process")]
pub mod instance;
#[cfg(feature = "process")]
pub mod interrupt;
#[cfg(feature = "process")]
pub mod lifeline;
#[cfg(feature = "ros2")]
pub mod ros2;
#[cfg(feature = "process")]
pub mod traffic;

#[cfg(feature = "process")]
pub use bus_args::{BusArgs, BusOpenError, OnBus, Transport};
#[cfg(feature = "process")]
pub use bus_config::{ipc_config, zenoh_config, BUS_BUFFER, ROBOT_TOPIC_PORTS};
#[cfg(feature = "process")]
pub use cli::{check_speed, MAX_SPEED};
#[cfg(feature = "process")]
pub use instance::instance;
#[cfg(feature = "process")]
pub use lifeline::{ExitCause, Lifeline};
#[cfg(feature = "process")]
pub use traffic::Traffic;
