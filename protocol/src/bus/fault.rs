//! A seeded fault layer around any bus backend: drop, delay, duplicate and
//! reorder messages, to prove that the orchestrator and the agents survive
//! a lossy link.
//!
//! Why on the receiving side: a real link loses, delays, repeats and swaps
//! messages independently for each receiver, and only the receiver can
//! *hold* a delayed message and hand it out later without a thread of its
//! own (a publisher never runs again if nothing else is published). So
//! [`FaultBus`] hands out the inner backend's publishers unchanged and wraps
//! each subscriber in a [`FaultSubscriber`] that pulls messages from the
//! inner subscriber and decides, for each one, with its own seeded
//! generator:
//!
//! 1. drop it (probability [`FaultConfig::drop`]);
//! 2. else deliver it twice (probability [`FaultConfig::duplicate`]);
//! 3. hold it for [`FaultConfig::delay_by`] (probability
//!    [`FaultConfig::delay`]) — later messages overtake it;
//! 4. hold it until the next message has been delivered, i.e. swap it with
//!    its successor (probability [`FaultConfig::reorder`]; not for a message
//!    already delayed); a held message is released anyway after `delay_by`
//!    if no successor comes.
//!
//! The decisions depend only on the seed, the subscriber's creation index
//! and the sequence of messages, never on timing, so a run with a fixed seed
//! drops and duplicates the same messages every time. With every rate 0 the
//! layer is transparent: it passes the bus conformance suite unchanged
//! (`tests/bus_fault.rs`).
//!
//! The generator is `rand_xoshiro`'s Xoshiro256++ (already the workspace's
//! seeded generator), seeded per subscriber from `seed + index`.

use super::{copy_out, Bus, BusError, Limits, Subscribe};
use crate::naming::TopicName;
use core::sync::atomic::{AtomicU64, Ordering};
use core::time::Duration;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

/// Fault rates (probabilities in `0..=1`, per received message) and the seed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultConfig {
    /// Probability that a message is lost.
    pub drop: f64,
    /// Probability that a (not dropped) message is delivered twice.
    pub duplicate: f64,
    /// Probability that a message is held back for [`FaultConfig::delay_by`].
    pub delay: f64,
    /// How long a delayed message is held (and the longest a reordered one waits).
    pub delay_by: Duration,
    /// Probability that a message is swapped with its successor.
    pub reorder: f64,
    /// Seed of the fault decisions.
    pub seed: u64,
}

impl FaultConfig {
    /// No faults at all (a transparent layer), with `seed`.
    pub fn none(seed: u64) -> Self {
        Self {
            drop: 0.0,
            duplicate: 0.0,
            delay: 0.0,
            delay_by: Duration::from_millis(10),
            reorder: 0.0,
            seed,
        }
    }

    fn validate(&self) -> Result<(), BusError> {
        let rates = [self.drop, self.duplicate, self.delay, self.reorder];
        if rates.iter().any(|p| !(0.0..=1.0).contains(p)) {
            return Err(BusError::InvalidConfig("fault rates must lie in 0..=1"));
        }
        Ok(())
    }
}

/// What a [`FaultSubscriber`] did so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultStats {
    /// Messages taken from the inner subscriber.
    pub received: u64,
    /// Of those, lost.
    pub dropped: u64,
    /// Delivered a second time.
    pub duplicated: u64,
    /// Held back for `delay_by`.
    pub delayed: u64,
    /// Swapped with their successor (or released late for lack of one).
    pub reordered: u64,
}

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
        config.validate()?;
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

    fn publisher(&self, topic: &TopicName) -> Result<Self::Publisher, BusError> {
        self.inner.publisher(topic)
    }

    fn subscriber(&self, topic: &TopicName) -> Result<Self::Subscriber, BusError> {
        let index = self.next_subscriber.fetch_add(1, Ordering::Relaxed);
        let inner = self.inner.subscriber(topic)?;
        Ok(FaultSubscriber::new(inner, self.config, index))
    }

    fn limits(&self) -> Limits {
        self.inner.limits()
    }
}

/// A message waiting to be handed out.
struct Pending {
    release: Instant,
    /// Arrival order, to break ties between equal release times.
    order: u64,
    payload: Vec<u8>,
}

struct State {
    rng: Xoshiro256PlusPlus,
    stats: FaultStats,
    pending: Vec<Pending>,
    /// A message waiting for its successor (reorder), and when it gives up.
    held: Option<Pending>,
    next_order: u64,
    scratch: Vec<u8>,
}

/// A subscriber that drops, duplicates, delays and reorders what its inner
/// subscriber receives (see the module documentation).
pub struct FaultSubscriber<S> {
    inner: S,
    config: FaultConfig,
    state: Mutex<State>,
}

impl<S: Subscribe> FaultSubscriber<S> {
    fn new(inner: S, config: FaultConfig, index: u64) -> Self {
        let state = State {
            rng: Xoshiro256PlusPlus::seed_from_u64(config.seed.wrapping_add(index)),
            stats: FaultStats::default(),
            pending: Vec::new(),
            held: None,
            next_order: 0,
            scratch: vec![0; inner.max_payload()],
        };
        Self { inner, config, state: Mutex::new(state) }
    }

    /// The faults applied so far.
    pub fn stats(&self) -> FaultStats {
        self.lock().stats
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Decides the fate of one message taken from the inner subscriber.
    fn admit(&self, s: &mut State, len: usize, now: Instant) {
        let c = &self.config;
        s.stats.received += 1;
        // Always draw all four, so one rate does not shift the others' stream.
        let (drop, dup, delay, reorder) = (
            s.rng.gen_bool(c.drop),
            s.rng.gen_bool(c.duplicate),
            s.rng.gen_bool(c.delay),
            s.rng.gen_bool(c.reorder),
        );
        if drop {
            s.stats.dropped += 1;
            return;
        }
        let payload = s.scratch.get(..len).unwrap_or_default().to_vec();
        let release = if delay {
            s.stats.delayed += 1;
            now + c.delay_by
        } else {
            now
        };
        let copies = if dup {
            s.stats.duplicated += 1;
            2
        } else {
            1
        };
        let mut items: Vec<Pending> = (0..copies)
            .map(|_| {
                s.next_order += 1;
                Pending { release, order: s.next_order, payload: payload.clone() }
            })
            .collect();
        if reorder && s.held.is_none() && !delay {
            s.stats.reordered += 1;
            let mut first = items.remove(0);
            first.release = now + c.delay_by;
            s.held = Some(first);
            s.pending.extend(items);
            return;
        }
        s.pending.extend(items);
        // The successor has come: the held message goes right after it.
        if let Some(mut held) = s.held.take() {
            s.next_order += 1;
            held.order = s.next_order;
            held.release = release;
            s.pending.push(held);
        }
    }

    /// Hands out the first pending message due at `now`, if any.
    fn take_due(s: &mut State, now: Instant, buf: &mut [u8]) -> Option<Result<usize, BusError>> {
        if s.held.as_ref().is_some_and(|h| h.release <= now) {
            if let Some(held) = s.held.take() {
                s.pending.push(held);
            }
        }
        let due = s
            .pending
            .iter()
            .enumerate()
            .filter(|(_, p)| p.release <= now)
            .min_by_key(|(_, p)| (p.release, p.order))
            .map(|(i, _)| i)?;
        let p = s.pending.swap_remove(due);
        Some(copy_out(&p.payload, buf))
    }

    /// When the next held or delayed message falls due.
    fn next_release(s: &State) -> Option<Instant> {
        s.pending.iter().map(|p| p.release).chain(s.held.as_ref().map(|h| h.release)).min()
    }

    fn recv_until(&self, buf: &mut [u8], deadline: Instant) -> Result<Option<usize>, BusError> {
        let mut s = self.lock();
        loop {
            let now = Instant::now();
            if let Some(r) = Self::take_due(&mut s, now, buf) {
                return r.map(Some);
            }
            let state = &mut *s;
            if let Some(len) = self.inner.try_recv_into(&mut state.scratch)? {
                self.admit(state, len, now);
                continue;
            }
            if now >= deadline {
                return Ok(None);
            }
            let wake = Self::next_release(&s).map_or(deadline, |r| r.min(deadline));
            let state = &mut *s;
            if let Some(len) = self.inner.recv_timeout_into(&mut state.scratch, wake - now)? {
                self.admit(state, len, Instant::now());
            } else if Instant::now() < wake && Self::next_release(&s).is_none() {
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
