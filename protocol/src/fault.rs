//! Seeded faults for any message path: drop, delay, duplicate and reorder,
//! to prove that the orchestrator, the agents and the robot link survive a
//! lossy network.
//!
//! Why one sans-IO queue: the bus ([`crate::bus::fault`]) and the robot
//! link ([`crate::link::proxy`]) lose, delay, repeat and swap messages the
//! same way, so the decisions live here once, with no clock and no socket:
//! a wrapper hands each received message to [`FaultQueue::admit`] and takes
//! out what [`FaultQueue::take_due`] says is due. For each message, with the
//! queue's own seeded generator:
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
//! The decisions depend only on the seed and the sequence of messages,
//! never on timing, so a run with a fixed seed drops and duplicates the
//! same messages every time. With every rate 0 the queue is transparent.
//!
//! The generator is `rand_xoshiro`'s Xoshiro256++ (already the workspace's
//! seeded generator).

use core::time::Duration;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
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

    /// Checks that every rate lies in `0..=1`; else says which, and its
    /// value: "drop = 1.5: a fault rate must lie in 0..=1".
    pub fn validate(&self) -> Result<(), String> {
        let rates = [
            ("drop", self.drop),
            ("duplicate", self.duplicate),
            ("delay", self.delay),
            ("reorder", self.reorder),
        ];
        match rates.into_iter().find(|(_, p)| !(0.0..=1.0).contains(p)) {
            Some((key, p)) => Err(format!("{key} = {p:?}: a fault rate must lie in 0..=1")),
            None => Ok(()),
        }
    }
}

/// What a fault queue did so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultStats {
    /// Messages admitted.
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

/// A message waiting to be handed out.
struct Pending {
    release: Instant,
    /// Arrival order, to break ties between equal release times.
    order: u64,
    payload: Vec<u8>,
}

/// The fault decisions of one receiver (see the module documentation).
pub struct FaultQueue {
    config: FaultConfig,
    rng: Xoshiro256PlusPlus,
    stats: FaultStats,
    pending: Vec<Pending>,
    /// A message waiting for its successor (reorder), and when it gives up.
    held: Option<Pending>,
    next_order: u64,
}

impl FaultQueue {
    /// A queue deciding with `config`, its generator seeded from
    /// `config.seed + stream` (one stream per receiver).
    pub fn new(config: FaultConfig, stream: u64) -> Self {
        Self {
            config,
            rng: Xoshiro256PlusPlus::seed_from_u64(config.seed.wrapping_add(stream)),
            stats: FaultStats::default(),
            pending: Vec::new(),
            held: None,
            next_order: 0,
        }
    }

    /// The faults applied so far.
    pub fn stats(&self) -> FaultStats {
        self.stats
    }

    /// Decides the fate of one received message at `now`.
    pub fn admit(&mut self, payload: &[u8], now: Instant) {
        let c = self.config;
        self.stats.received += 1;
        // Always draw all four, so one rate does not shift the others' stream.
        let (drop, dup, delay, reorder) = (
            self.rng.gen_bool(c.drop),
            self.rng.gen_bool(c.duplicate),
            self.rng.gen_bool(c.delay),
            self.rng.gen_bool(c.reorder),
        );
        if drop {
            self.stats.dropped += 1;
            return;
        }
        let release = if delay {
            self.stats.delayed += 1;
            now + c.delay_by
        } else {
            now
        };
        let copies = if dup {
            self.stats.duplicated += 1;
            2
        } else {
            1
        };
        let mut items: Vec<Pending> = (0..copies)
            .map(|_| {
                self.next_order += 1;
                Pending { release, order: self.next_order, payload: payload.to_vec() }
            })
            .collect();
        if reorder && self.held.is_none() && !delay {
            self.stats.reordered += 1;
            let mut first = items.remove(0);
            first.release = now + c.delay_by;
            self.held = Some(first);
            self.pending.extend(items);
            return;
        }
        self.pending.extend(items);
        // The successor has come: the held message goes right after it.
        if let Some(mut held) = self.held.take() {
            self.next_order += 1;
            held.order = self.next_order;
            held.release = release;
            self.pending.push(held);
        }
    }

    /// The first message due at `now`, if any.
    pub fn take_due(&mut self, now: Instant) -> Option<Vec<u8>> {
        if self.held.as_ref().is_some_and(|h| h.release <= now) {
            if let Some(held) = self.held.take() {
                self.pending.push(held);
            }
        }
        let due = self
            .pending
            .iter()
            .enumerate()
            .filter(|(_, p)| p.release <= now)
            .min_by_key(|(_, p)| (p.release, p.order))
            .map(|(i, _)| i)?;
        Some(self.pending.swap_remove(due).payload)
    }

    /// When the next held or delayed message falls due.
    pub fn next_release(&self) -> Option<Instant> {
        self.pending.iter().map(|p| p.release).chain(self.held.as_ref().map(|h| h.release)).min()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(config: FaultConfig, n: u8) -> (Vec<u8>, FaultStats) {
        let mut q = FaultQueue::new(config, 0);
        let t0 = Instant::now();
        let mut out = Vec::new();
        for i in 0..n {
            let now = t0 + Duration::from_millis(u64::from(i));
            q.admit(&[i], now);
            while let Some(m) = q.take_due(now) {
                out.extend(m);
            }
        }
        let late = t0 + Duration::from_secs(10);
        while let Some(m) = q.take_due(late) {
            out.extend(m);
        }
        (out, q.stats())
    }

    #[test]
    fn transparent_without_faults_and_seeded_with_them() {
        let (out, stats) = run(FaultConfig::none(3), 50);
        assert_eq!(out, (0..50).collect::<Vec<u8>>());
        assert_eq!(stats.dropped + stats.duplicated + stats.delayed + stats.reordered, 0);
        let lossy =
            FaultConfig { drop: 0.2, duplicate: 0.1, delay: 0.1, reorder: 0.1, ..FaultConfig::none(3) };
        let (a, sa) = run(lossy, 200);
        let (b, sb) = run(lossy, 200);
        assert_eq!((a.clone(), sa), (b, sb), "same seed, same faults");
        assert!(sa.dropped > 0 && sa.duplicated > 0 && sa.reordered > 0, "{sa:?}");
        assert_eq!(a.len() as u64, 200 - sa.dropped + sa.duplicated);
        let (c, _) = run(FaultConfig { seed: 4, ..lossy }, 200);
        assert_ne!(a, c, "another seed, other faults");
    }

    #[test]
    fn rates_outside_zero_to_one_are_refused() {
        for bad in [-0.1, 1.5, f64::NAN] {
            assert!(FaultConfig { drop: bad, ..FaultConfig::none(1) }.validate().is_err());
        }
        let said = FaultConfig { reorder: 1.5, ..FaultConfig::none(1) }.validate().unwrap_err();
        assert_eq!(said, "reorder = 1.5: a fault rate must lie in 0..=1", "the key and its value");
    }
}
