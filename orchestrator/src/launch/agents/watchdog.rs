//! Registration and heartbeat deadlines, shared by every agent source.
//!
//! Why separate: a spawned process, a remote agent and a robot's gateway
//! all show a hang the same way — silence. A process that exits is seen by
//! its source directly (`try_wait`), but an agent that is alive and hung,
//! or one that never came, only shows by the absence of messages: not
//! registered within `register_timeout` of being started, or silent for
//! `heartbeat_timeout` after its last message.

use super::Gone;
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

#[derive(Clone, Copy, Debug)]
struct Times {
    started: Instant,
    last_heard: Option<Instant>,
}

/// Deadlines of the agents being watched, by robot id.
#[derive(Clone, Debug)]
pub struct Watchdog {
    register_timeout: Duration,
    heartbeat_timeout: Duration,
    agents: BTreeMap<u32, Times>,
}

impl Watchdog {
    /// A watchdog with these timeouts and no agent.
    pub fn new(register_timeout: Duration, heartbeat_timeout: Duration) -> Self {
        Self { register_timeout, heartbeat_timeout, agents: BTreeMap::new() }
    }

    /// Starts watching robot `id` (its registration timeout runs from now).
    pub fn start(&mut self, id: u32) {
        self.agents.insert(id, Times { started: Instant::now(), last_heard: None });
    }

    /// Notes a message from robot `id`.
    pub fn heard(&mut self, id: u32) {
        if let Some(t) = self.agents.get_mut(&id) {
            t.last_heard = Some(Instant::now());
        }
    }

    /// Stops watching robot `id`; whether it was watched.
    pub fn forget(&mut self, id: u32) -> bool {
        self.agents.remove(&id).is_some()
    }

    /// Whether robot `id` is watched.
    pub fn watches(&self, id: u32) -> bool {
        self.agents.contains_key(&id)
    }

    /// Whether robot `id` has been heard from since it was started.
    pub fn was_heard(&self, id: u32) -> bool {
        self.agents.get(&id).is_some_and(|t| t.last_heard.is_some())
    }

    /// The watched robots, in id order.
    pub fn ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.agents.keys().copied()
    }

    /// How long robot `id` has been silent at `now`, once it was heard.
    pub fn silent_for(&self, id: u32, now: Instant) -> Option<Duration> {
        Some(now.saturating_duration_since(self.agents.get(&id)?.last_heard?))
    }

    /// Whether robot `id` has missed its deadline at `now`, and which.
    pub fn overdue(&self, id: u32, now: Instant) -> Option<Gone> {
        let t = self.agents.get(&id)?;
        match t.last_heard {
            Some(heard) if now.duration_since(heard) > self.heartbeat_timeout => Some(Gone::Silent),
            None if now.duration_since(t.started) > self.register_timeout => Some(Gone::NeverRegistered),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registration_then_heartbeat_deadlines() {
        let mut w = Watchdog::new(Duration::from_millis(100), Duration::from_millis(50));
        w.start(1);
        let t0 = Instant::now();
        assert_eq!(w.overdue(1, t0), None);
        assert_eq!(w.overdue(1, t0 + Duration::from_millis(150)), Some(Gone::NeverRegistered));
        w.heard(1);
        let heard = Instant::now();
        assert!(w.was_heard(1));
        assert_eq!(w.overdue(1, heard + Duration::from_millis(20)), None);
        assert_eq!(w.overdue(1, heard + Duration::from_millis(80)), Some(Gone::Silent));
        // Heard just before `heard` was taken: silent for at least 80 ms.
        assert!(w.silent_for(1, heard + Duration::from_millis(80)) >= Some(Duration::from_millis(80)));
        assert_eq!(w.silent_for(2, heard), None);
        assert_eq!(w.overdue(2, heard), None, "an unwatched robot is never overdue");
        assert!(w.forget(1) && !w.forget(1) && !w.watches(1));
    }
}
