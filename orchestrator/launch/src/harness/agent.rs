//! A simulated robot's agent in virtual time: the `sim-agent` process's own
//! message rules ([`SimAgentCore`]) with the virtual clock and the simulated
//! network around them.
//!
//! Why the same core: the harness must test what runs, and reproduce
//! `simulate` bit for bit without faults. The rules (register until heard
//! from, heartbeats every 100 ms and slower once parked, `Deploy`, ticks,
//! real-time periods, beacons) are the process's [`SimAgentCore`], built from
//! how the launch's agents join and its run settings, as a spawned agent builds
//! them (`bycoms_sim_agent::timing`). What this file adds is only what
//! a process is: it starts at a time (or never registers), and it is
//! alive until it leaves, crashes or is killed. Like the process's loop it
//! drives the core as every sans-IO core is driven ([`SansIo`]), then
//! polls everything it said into the world's list.

use bycoms_protocol::SansIo;
use bycoms_sim_agent::{Said, SimAgentCore};

/// One simulated agent: the process around a [`SimAgentCore`].
pub struct Agent {
    core: SimAgentCore,
    /// Alive (not crashed, killed or shut down).
    pub alive: bool,
    /// When it registers (none: never), until it has.
    register_at: Option<u64>,
    started: bool,
    /// The latest virtual time it was given (a command comes without one;
    /// its rules do not depend on it).
    at: u64,
}

impl Agent {
    /// An agent around `core`, registering first at `register_at` (never
    /// if none).
    pub fn new(core: SimAgentCore, register_at: Option<u64>) -> Self {
        Self { core, alive: true, register_at, started: false, at: 0 }
    }

    /// The robot.
    pub fn id(&self) -> u32 {
        self.core.id().0
    }

    /// Control periods its robot stepped.
    pub fn stepped(&self) -> u64 {
        self.core.robot().steps()
    }

    /// Whether its robot is not deployed yet.
    pub fn idle(&self) -> bool {
        self.core.robot().phase() == bycoms_sim_agent::RobotPhase::Idle
    }

    /// When it next does something on its own (none: never).
    pub fn deadline(&self) -> Option<u64> {
        match (self.alive, self.started) {
            (false, _) => None,
            (true, false) => self.register_at,
            (true, true) => self.core.deadline(),
        }
    }

    /// What is due at `now`: its start (registration), a heartbeat, a
    /// real-time period.
    pub fn advance(&mut self, now: u64, out: &mut Vec<Said>) {
        if !self.alive {
            return;
        }
        self.at = self.at.max(now);
        if !self.started {
            if self.register_at.is_some_and(|t| t <= now) {
                self.started = true;
                self.core.start(now);
                self.said(out);
            }
            return;
        }
        self.core.advance(now);
        self.said(out);
    }

    /// A command from the orchestrator; it leaves on `Shutdown` and when
    /// its instance is refused.
    pub fn command(&mut self, cmd: &bycoms_protocol::msg::ToAgent, out: &mut Vec<Said>) {
        if !self.alive {
            return;
        }
        let leave = self.core.handle(self.at, cmd);
        self.said(out);
        if leave.is_some() {
            self.alive = false;
        }
    }

    /// Everything the core said, in order, into `out`.
    fn said(&mut self, out: &mut Vec<Said>) {
        out.extend(std::iter::from_fn(|| self.core.poll()));
    }
}
