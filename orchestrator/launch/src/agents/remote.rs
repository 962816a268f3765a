//! Remote agents: started by hand on other hosts, awaited here.
//!
//! Why the orchestrator spawns nothing: in a lab the agents (simulated on
//! other machines, or robots behind their gateways) exist before and
//! independently of a launch. A remote agent is `sim-agent --transport
//! zenoh --connect tcp/ORCHESTRATOR:PORT --swarm S --robot K`: it takes the
//! run's settings (terrain, ε, noise, seed, clock, swarm size) from the
//! launch, which serves them on `bycoms/<swarm>/settings` (`launch::run`).
//! The launch starts
//! expecting every robot at once ([`AgentProperties::all_at_once`]) and deploys
//! each when its turn comes: a robot whose agent has not registered by
//! then is awaited up to its registration timeout (counted from the start),
//! then skipped as absent; one that registers later takes a later turn
//! (`supervision.missing = "fail"` awaits all and names the missing).
//!
//! Liveness has two signals, both judged by the launch core's timers
//! (`orchestrator/launch-core/src/timers.rs`). The registration and heartbeat timeouts catch
//! an agent that never came or hangs. zenoh liveliness ([`AliveWatch`]:
//! every agent declares `alive/robot/<id>`) catches an agent whose process
//! ended or whose link was cut, within one lease (`Liveness::FAST`:
//! 400 ms): [`AgentSource::tokens`] reports a withdrawn token as a fact, and
//! the core decides (gone at once, or unreachable with a link grace). A
//! refused duplicate agent declares the same token as the accepted one;
//! zenoh's routing merges such twin tokens (a watcher sees the key go only
//! when the last one goes), so its leaving does not make the accepted agent
//! look lost (`tests/tests/remote_agents.rs` checks it). Presence is a flag
//! per robot, not a count: a token may be reported alive twice (the
//! watch's history and the live declaration racing), but it is withdrawn
//! once.
//!
//! Partitions: a lab's link drops for a moment (WiFi, a switch). Remote
//! agents are held when unreachable ([`AgentProperties::held_when_unreachable`]):
//! with a link grace (`supervision.unreachable_grace`) a withdrawn token or a
//! silent agent is first only *unreachable*; the engine holds the robot
//! and, when the agent is heard again, re-sends what it may have missed.
//! Only an agent unreachable for longer than the grace is gone. Silence
//! counts as well as a withdrawn token because zenoh may close a dead
//! link's transport late (seen here: one of three transports closed only
//! when the link came back), so its token would go late or never: an agent
//! not heard for four heartbeat periods ([`QUIET_HEARTBEATS`]) is
//! unreachable too, so every cut is seen within 500 ms.
//!
//! A remote process cannot be killed from here: [`AgentSource::kill`]
//! only drops it from the launch (it was sent `Shutdown`, or it is gone),
//! and winding down waits for the tokens of the agents it sent `Shutdown`
//! to go ([`AgentSource::reap`]), naming only those that stay.

use super::{AgentError, AgentPlan, AgentProperties, AgentSource, Gone, Started};
use bycoms_protocol::bus::zenoh::{AliveWatch, Presence};
use bycoms_protocol::naming::Member;
use std::collections::BTreeSet;

/// The awaited remote agents, by robot id.
pub struct Remote {
    running: BTreeSet<u32>,
    /// The swarm's liveliness tokens (none without zenoh, e.g. in tests).
    watch: Option<AliveWatch>,
    /// Robots whose token is present.
    tokens: BTreeSet<u32>,
    /// Token changes of running robots not yet taken by
    /// [`AgentSource::tokens`].
    changes: Vec<(u32, bool)>,
}

/// Heartbeat periods of silence after which a remote agent is unreachable
/// (the core's quiet rule, `orchestrator/launch-core/src/timers.rs`): at 100 ms heartbeats a
/// cut shows 300–405 ms after it happened, and a process must miss three
/// heartbeats in a row to look unreachable when it is not.
pub const QUIET_HEARTBEATS: u32 = 4;

impl Remote {
    /// A source awaiting agents, watching their liveliness tokens on
    /// `watch` when there is one.
    pub fn new(watch: Option<AliveWatch>) -> Self {
        Self { running: BTreeSet::new(), watch, tokens: BTreeSet::new(), changes: Vec::new() }
    }

    /// Takes in the liveliness changes zenoh delivered so far.
    fn drain_tokens(&mut self) {
        let Some(watch) = &self.watch else { return };
        while let Some(event) = watch.try_recv() {
            let Member::Agent(robot) = event.member else { continue };
            let id = robot.0;
            let present = event.presence == Presence::Alive;
            let changed = if present { self.tokens.insert(id) } else { self.tokens.remove(&id) };
            if changed && self.running.contains(&id) {
                tracing::debug!(robot = id, present, "robot {id}'s liveliness token changed");
                self.changes.push((id, present));
            }
        }
    }

    fn has_token(&self, id: u32) -> bool {
        self.tokens.contains(&id)
    }
}

/// What remote agents are: started elsewhere, all expected at once,
/// held while unreachable, dropped (not killed) when they do not end.
pub fn properties() -> AgentProperties {
    AgentProperties {
        all_at_once: true,
        held_when_unreachable: true,
        start_hint:
            " (start each with `sim-agent --transport zenoh --connect ENDPOINT --swarm SWARM --robot K`)",
        ended_by: "still alive on their hosts, dropped from the launch",
        ..AgentProperties::of_kind("remote")
    }
}

impl AgentSource for Remote {
    fn properties(&self) -> AgentProperties {
        properties()
    }

    fn start(&mut self, id: u32, _plan: &AgentPlan<'_>) -> Result<Started, AgentError> {
        self.running.insert(id);
        Ok(Started::Awaited)
    }

    fn is_running(&self, id: u32) -> bool {
        self.running.contains(&id)
    }

    fn pid(&self, _id: u32) -> Option<u32> {
        None
    }

    /// Nothing of a remote agent ends where this host can see it but its
    /// token ([`AgentSource::tokens`]).
    fn poll(&mut self) -> Vec<(u32, Gone)> {
        Vec::new()
    }

    fn tokens(&mut self) -> Vec<(u32, bool)> {
        self.drain_tokens();
        std::mem::take(&mut self.changes)
    }

    fn kill(&mut self, id: u32) -> bool {
        self.changes.retain(|(r, _)| *r != id);
        self.running.remove(&id)
    }

    /// With liveliness an agent that obeyed `Shutdown` is seen to go (its
    /// token is withdrawn when its session closes); without it nothing can
    /// be seen, and every agent still counted is named.
    fn reap(&mut self) -> bool {
        self.drain_tokens();
        self.watch.is_some() && self.running.iter().any(|&id| self.has_token(id))
    }

    fn end_rest(&mut self) -> Vec<u32> {
        let stayed: Vec<u32> = match &self.watch {
            Some(_) => self.running.iter().copied().filter(|&id| self.has_token(id)).collect(),
            None => self.running.iter().copied().collect(),
        };
        self.running.clear();
        self.changes.clear();
        stayed
    }
}
