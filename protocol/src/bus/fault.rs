//! A seeded fault layer around any bus backend: drop, delay, duplicate and
//! reorder messages (the decisions are [`crate::fault`]'s, shared with the
//! robot link's fault proxy).
//!
//! Why on the receiving side: a real link loses, delays, repeats and swaps
//! messages independently for each receiver, and only the receiver can
//! *hold* a delayed message and hand it out later without a thread of its
//! own (a publisher never runs again if nothing else is published). So
//! [`FaultBus`] hands out the inner backend's publishers unchanged and wraps
//! each subscriber in a [`FaultSubscriber`] that pulls messages from the
//! inner subscriber through its own [`FaultQueue`], seeded from the seed
//! and the subscriber's creation index. With every rate 0 the layer is
//! transparent: it passes the bus conformance suite unchanged
//! (`tests/bus_fault.rs`).

use super::{copy_out, Bus, BusError, Limits, Subscribe};
use crate::fault::FaultQueue;
pub use crate::fault::{FaultConfig, FaultStats};
use crate::naming::TopicName;
use core::sync::atomic::{AtomicU64, Ordering};
use core::time::Duration;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

/// A bus whose subscribers suffer the faults of a [`FaultConfig`].
#[derive(Clone)]
pub struct FaultBus<B> {
    inner: B,
    config: FaultConfig,
    next_subscriber: Arc<AtomicU64>,
}

impl<B: Bus> FaultBus<B> {
    /// Wraps `inner`; fails if a rate is outside `0..=1`.
    pub fn new(inner: B, config: FaultConfig) -> Result<Self, BusError> {
        // (The rate and its value: `FaultConfig::validate`'s own words, which
        // the launch's config check says first.)
        config.validate().map_err(|_| BusError::InvalidConfig("a fault rate lies outside 0..=1"))?;
        Ok(Self { inner, config, next_subscriber: Arc::new(AtomicU64::new(0)) })
    }

    /// The wrapped backend.
    pub fn inner(&self) -> &B {
        &self.inner
    }
}

impl<B: Bus> Bus for FaultBus<B> {
    type Publisher = B::Publisher;
    type Subscriber = FaultSubscriber<B::Subscriber>;
    type FanIn = FaultSubscriber<B::FanIn>;

    fn publisher(&self, topic: &TopicName) -> Result<Self::Publisher, BusError> {
        self.inner.publisher(topic)
    }

    fn subscriber(&self, topic: &TopicName) -> Result<Self::Subscriber, BusError> {
        let index = self.next_subscriber.fetch_add(1, Ordering::Relaxed);
        let inner = self.inner.subscriber(topic)?;
        Ok(FaultSubscriber::new(inner, self.config, index))
    }

    fn fan_in(&self, topics: &[TopicName]) -> Result<Self::FanIn, BusError> {
        // One fault stream over the merged messages (each keeps its tag).
        let index = self.next_subscriber.fetch_add(1, Ordering::Relaxed);
        let inner = self.inner.fan_in(topics)?;
        Ok(FaultSubscriber::new(inner, self.config, index))
    }

    fn limits(&self) -> Limits {
        self.inner.limits()
    }
}

struct State {
    queue: FaultQueue,
    scratch: Vec<u8>,
}

/// A subscriber that drops, duplicates, delays and reorders what its inner
/// subscriber receives (see the module documentation).
pub struct FaultSubscriber<S> {
    inner: S,
    state: Mutex<State>,
}

impl<S: Subscribe> FaultSubscriber<S> {
    fn new(inner: S, config: FaultConfig, index: u64) -> Self {
        let state = State { queue: FaultQueue::new(config, index), scratch: vec![0; inner.max_payload()] };
        Self { inner, state: Mutex::new(state) }
    }

    /// The faults applied so far.
    pub fn stats(&self) -> FaultStats {
        self.lock().queue.stats()
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    fn recv_until(&self, buf: &mut [u8], deadline: Instant) -> Result<Option<usize>, BusError> {
        let mut guard = self.lock();
        let s = &mut *guard;
        loop {
            let now = Instant::now();
            if let Some(payload) = s.queue.take_due(now) {
                return copy_out(&payload, buf).map(Some);
            }
            if let Some(len) = self.inner.try_recv_into(&mut s.scratch)? {
                s.queue.admit(s.scratch.get(..len).unwrap_or_default(), now);
                continue;
            }
            if now >= deadline {
                return Ok(None);
            }
            let wake = s.queue.next_release().map_or(deadline, |r| r.min(deadline));
            if let Some(len) = self.inner.recv_timeout_into(&mut s.scratch, wake - now)? {
                s.queue.admit(s.scratch.get(..len).unwrap_or_default(), Instant::now());
            } else if Instant::now() < wake && s.queue.next_release().is_none() {
                // Woken early (a signal) with nothing held: report it like the inner bus.
                return Ok(None);
            }
        }
    }
}

impl<S: Subscribe> Subscribe for FaultSubscriber<S> {
    fn max_payload(&self) -> usize {
        self.inner.max_payload()
    }

    fn try_recv_into(&self, buf: &mut [u8]) -> Result<Option<usize>, BusError> {
        self.recv_until(buf, Instant::now())
    }

    fn recv_timeout_into(&self, buf: &mut [u8], timeout: Duration) -> Result<Option<usize>, BusError> {
        self.recv_until(buf, Instant::now() + timeout)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_outside_zero_to_one_are_refused() {
        let bus = crate::bus::memory::MemoryBus::new(Limits::default()).expect("bus");
        for bad in [-0.1, 1.5, f64::NAN] {
            let config = FaultConfig { drop: bad, ..FaultConfig::none(1) };
            assert!(matches!(FaultBus::new(bus.clone(), config), Err(BusError::InvalidConfig(_))));
        }
    }
}
