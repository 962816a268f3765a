//! A mixed swarm's agents: simulated members (`kind = "sim"` in the robots
//! file) beside real robots, one source.
//!
//! Why a source of its own and not a special case in the engine: the
//! engine holds one [`AgentSource`]; this one starts robot `k`'s agent as
//! the robots file says it is, a `sim-agent` on the lab's arena
//! ([`Spawned`], with the run's settings: the arena in metres, the real
//! robots' speed) or the real robot's own agent (the wrapped source, e.g.
//! [`Ros2Robots`](super::ros2_robots::Ros2Robots)), and answers for both
//! when asked which ran, ended or was heard. What it says of its agents is
//! the real source's properties with the simulated robots named
//! ([`AgentProperties::simulated`]): the core places only the real ones and
//! forwards poses only to them; the gate, the field and the order of
//! deployment are the same for every member.

use super::spawned::{AgentCommand, Spawned};
use super::{AgentError, AgentPlan, AgentProperties, AgentSource, Gone, Started};

/// The agents of a mixed swarm.
pub struct Mixed {
    /// The simulated members' `sim-agent`s.
    simulated: Spawned,
    /// Their ids, in order.
    ids: Vec<u32>,
    /// The real robots' agents.
    real: Box<dyn AgentSource>,
}

impl Mixed {
    /// Robots `ids` simulated by `sim_agent`, the others real, from `real`.
    pub fn new(sim_agent: AgentCommand, mut ids: Vec<u32>, real: Box<dyn AgentSource>) -> Self {
        ids.sort_unstable();
        Self { simulated: Spawned::new(sim_agent), ids, real }
    }

    fn is_simulated(&self, id: u32) -> bool {
        self.ids.binary_search(&id).is_ok()
    }

    /// The source robot `id`'s agent comes from.
    fn of(&self, id: u32) -> &(dyn AgentSource + 'static) {
        if self.is_simulated(id) {
            &self.simulated
        } else {
            self.real.as_ref()
        }
    }

    fn of_mut(&mut self, id: u32) -> &mut (dyn AgentSource + 'static) {
        if self.is_simulated(id) {
            &mut self.simulated
        } else {
            self.real.as_mut()
        }
    }

    /// Both sources, the simulated one first.
    fn each(&mut self) -> impl Iterator<Item = &mut (dyn AgentSource + 'static)> + '_ {
        let simulated: &mut (dyn AgentSource + 'static) = &mut self.simulated;
        std::iter::once(simulated).chain(std::iter::once(self.real.as_mut()))
    }
}

/// What a mixed swarm's agents are: `real`'s (real robots: all at once,
/// placed, told to stop, one tick a message), with `simulated` named.
pub fn properties(real: AgentProperties, simulated: Vec<u32>) -> AgentProperties {
    AgentProperties { kind: "mixed", simulated, ..real }
}

impl AgentSource for Mixed {
    fn properties(&self) -> AgentProperties {
        properties(self.real.properties(), self.ids.clone())
    }

    fn start(&mut self, id: u32, plan: &AgentPlan<'_>) -> Result<Started, AgentError> {
        self.of_mut(id).start(id, plan)
    }

    fn heard(&mut self, id: u32) {
        self.of_mut(id).heard(id);
    }

    fn is_running(&self, id: u32) -> bool {
        self.of(id).is_running(id)
    }

    fn pid(&self, id: u32) -> Option<u32> {
        self.of(id).pid(id)
    }

    fn poll(&mut self) -> Vec<(u32, Gone)> {
        self.each().flat_map(|s| s.poll()).collect()
    }

    fn tokens(&mut self) -> Vec<(u32, bool)> {
        self.each().flat_map(|s| s.tokens()).collect()
    }

    fn kill(&mut self, id: u32) -> bool {
        self.of_mut(id).kill(id)
    }

    fn last_error(&mut self, id: u32) -> Option<String> {
        self.of_mut(id).last_error(id)
    }

    fn ask_to_end(&mut self) {
        self.each().for_each(|s| s.ask_to_end());
    }

    fn reap(&mut self) -> bool {
        // Every source reaps, whether or not another still has agents running.
        self.each().fold(false, |running, s| s.reap() | running)
    }

    fn end_rest(&mut self) -> Vec<u32> {
        let mut ended: Vec<u32> = self.each().flat_map(|s| s.end_rest()).collect();
        ended.sort_unstable();
        ended
    }
}
