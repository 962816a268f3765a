//! Simulated agents as threads of the orchestrator, over its in-memory bus.
//!
//! Why: a launch over `transport.kind = "memory"` needs no shared memory,
//! no sockets and no processes, so a test can run the whole launch — the
//! driver, the ports, the recording, the core — in one process in a
//! fraction of a second. Each agent is the same loop a `sim-agent` process
//! runs (`bycoms_sim_agent::run_on`, with its `SimAgentCore`), on a
//! thread of its own with a clone of the launch's `MemoryBus`; what a
//! process would learn from its exit it learns from its thread ending, and
//! what a kill does to a process a flag does to its thread
//! (`Lifeline::with_flag`: the loop checks it every pass and exits).
//!
//! Supervision is the spawned agents': the core's registration and
//! heartbeat timers (`orchestrator/launch-core/src/timers.rs`), a thread's end reported once
//! by [`AgentSource::poll`].

use super::{AgentError, AgentPlan, AgentProperties, AgentSource, Gone, Started};
use bycoms_protocol::bus::memory::MemoryBus;
use bycoms_protocol::Swarm;
use bycoms_runtime::{Lifeline, Transport};
use bycoms_sim_agent::run_on;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

/// One agent thread.
struct Running {
    end: Arc<AtomicBool>,
    thread: JoinHandle<()>,
}

/// Agents as threads on the launch's in-memory bus; see the module docs.
pub struct Threads {
    bus: MemoryBus,
    running: BTreeMap<u32, Running>,
}

impl Threads {
    /// A source whose agents talk over `bus`.
    pub fn new(bus: MemoryBus) -> Self {
        Self { bus, running: BTreeMap::new() }
    }

    /// Ends robot `id`'s thread (its loop sees the flag within a pass) and
    /// waits for it; whether it was running.
    fn end(&mut self, id: u32) -> bool {
        match self.running.remove(&id) {
            Some(r) => {
                r.end.store(true, Ordering::SeqCst);
                let _ = r.thread.join();
                true
            }
            None => false,
        }
    }
}

/// What agent threads are: started one at a time in the launch's own
/// process, over a memory bus that keeps every command, of its own build.
pub fn properties() -> AgentProperties {
    AgentProperties {
        keeps_commands: true,
        ticks_at_once: super::TICKS_AT_ONCE,
        ended_by: "ended (their threads told to stop)",
        ..AgentProperties::of_kind("threads")
    }
}

impl AgentSource for Threads {
    fn properties(&self) -> AgentProperties {
        properties()
    }

    fn start(&mut self, id: u32, plan: &AgentPlan<'_>) -> Result<Started, AgentError> {
        let mut args = plan.joining.sim_agent(id, plan.settings);
        args.bus.transport = Transport::Memory;
        args.parent_pid = None;
        let other = |e: Box<dyn std::error::Error + Send + Sync>| AgentError::Other(e);
        let terrain = bycoms_sim::terrain::parse(&plan.settings.terrain).map_err(|e| other(Box::new(e)))?;
        let settings = plan.settings.clone();
        let swarm = Swarm::new(&args.swarm).map_err(|e| other(Box::new(e)))?;
        let end = Arc::new(AtomicBool::new(false));
        let bus = self.bus.clone();
        let flag = Arc::clone(&end);
        let thread = std::thread::Builder::new()
            .name(format!("agent-{id}"))
            .spawn(move || {
                let mut lifeline = Lifeline::with_flag(flag);
                if let Err(e) = run_on(&bus, &args, &settings, &swarm, terrain, &mut lifeline, None, None) {
                    tracing::error!(robot = id, "robot {id}'s agent thread failed: {e}");
                }
            })
            .map_err(|source| AgentError::Spawn { program: format!("agent thread {id}"), source })?;
        self.end(id);
        self.running.insert(id, Running { end, thread });
        Ok(Started::Thread)
    }

    fn is_running(&self, id: u32) -> bool {
        self.running.contains_key(&id)
    }

    fn pid(&self, _id: u32) -> Option<u32> {
        None
    }

    fn poll(&mut self) -> Vec<(u32, Gone)> {
        let gone: Vec<(u32, Gone)> = self
            .running
            .iter()
            .filter(|(_, r)| r.thread.is_finished())
            .map(|(&id, _)| (id, Gone::ThreadEnded))
            .collect();
        for (id, _) in &gone {
            self.end(*id);
        }
        gone
    }

    fn kill(&mut self, id: u32) -> bool {
        self.end(id)
    }

    fn reap(&mut self) -> bool {
        let ended: Vec<u32> =
            self.running.iter().filter(|(_, r)| r.thread.is_finished()).map(|(&id, _)| id).collect();
        for id in ended {
            self.end(id);
        }
        !self.running.is_empty()
    }

    fn end_rest(&mut self) -> Vec<u32> {
        let told: Vec<u32> = self.running.keys().copied().collect();
        for &id in &told {
            self.end(id);
        }
        told
    }
}

impl Drop for Threads {
    fn drop(&mut self) {
        let ids: Vec<u32> = self.running.keys().copied().collect();
        for id in ids {
            self.end(id);
        }
    }
}
