//! The `[supervision]` table of a launch config: how long agents get to
//! register, beat, answer and exit, and how far their clocks may be off.
//!
//! Why a file of its own: the supervision's timeouts and the shutdown
//! grace's measured per-agent margin are one subject, apart from the
//! config's reading and validation (`orchestrator/launch/src/config.rs`).

use super::Missing;
use serde::{Deserialize, Serialize};
use std::time::Duration;

/// Timeouts of agent supervision (wall-clock seconds).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default, expecting = "a [supervision] table")]
pub struct SupervisionConfig {
    /// An agent must register within this long after it was spawned.
    pub register_timeout: f64,
    /// Agents send a heartbeat this often.
    pub heartbeat_interval: f64,
    /// A registered agent silent for this long is killed and treated as dead.
    pub heartbeat_timeout: f64,
    /// Every live agent must answer a lockstep tick within this long.
    pub tick_timeout: f64,
    /// Agents get this long to exit after `Shutdown` before being killed,
    /// plus [`SHUTDOWN_GRACE_PER_AGENT`] for every agent still running
    /// ([`SupervisionConfig::shutdown_grace_for`]).
    pub shutdown_grace: f64,
    /// Remote agents (zenoh): how long one may be unreachable (its zenoh
    /// connection cut, or silent) before it is treated as dead; the launch
    /// holds it meanwhile and resumes when it is back. 0: dead at once.
    /// Agents the launch starts get an `--orchestrator-grace` no shorter
    /// than this (`setup::joining`); agents started by hand need one as
    /// long. Was `link_grace` (still read, in files and recordings: "link"
    /// is the robot link).
    #[serde(alias = "link_grace")]
    pub unreachable_grace: f64,
    /// Agents over zenoh: a host whose clock is off the orchestrator's by
    /// more than this (as the agent measured it) is warned about.
    pub clock_warn: f64,
    /// Agents over zenoh: a host whose clock is off by more than this is
    /// refused at registration. 0: not checked.
    pub clock_limit: f64,
    /// What a robot whose agent never registers means.
    pub missing: Missing,
}

/// The shutdown grace added per agent still running at the end of a launch.
///
/// Why: after `Shutdown` every agent exits at once, on the machine's few
/// cores, each closing its ports on the shared bus, so the last one is done
/// only after all the others; with the fixed 1 s, about 240 of a 300-robot
/// launch's agents were killed. Measured on the 2-core machine (release,
/// other builds running, all-stuck terrain, every agent alive, a grace of
/// 120 s so none was killed): all 100 agents had exited 0.92 s after
/// `Shutdown` (9 ms each), all 300 after 6.9 and 7.9 s (23 and 26 ms each;
/// the time per agent grows with the swarm). 40 ms each gives a 300-robot
/// launch 13 s, 1.6 times the slowest measured; a wind-down ends as soon as
/// the last agent has exited, so the margin costs only when one hangs.
pub const SHUTDOWN_GRACE_PER_AGENT: Duration = Duration::from_millis(40);

impl SupervisionConfig {
    /// How long the agents of a launch get to exit after `Shutdown` when
    /// `live` of them are running: the configured grace (the least) plus
    /// [`SHUTDOWN_GRACE_PER_AGENT`] each.
    pub fn shutdown_grace_for(&self, live: usize) -> Duration {
        let configured = Duration::try_from_secs_f64(self.shutdown_grace).unwrap_or(Duration::ZERO);
        configured + SHUTDOWN_GRACE_PER_AGENT * u32::try_from(live).unwrap_or(u32::MAX)
    }
}

impl Default for SupervisionConfig {
    fn default() -> Self {
        Self {
            register_timeout: 10.0,
            heartbeat_interval: bycoms_protocol::msg::HEARTBEAT_MS as f64 / 1000.0,
            heartbeat_timeout: 2.0,
            tick_timeout: 5.0,
            shutdown_grace: 1.0,
            unreachable_grace: 2.0,
            clock_warn: 0.1,
            clock_limit: 0.5,
            missing: Missing::Skip,
        }
    }
}
