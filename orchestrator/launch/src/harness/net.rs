//! A seeded simulated network in virtual time.
//!
//! Why its own: the launch core is tested without sockets or shared memory,
//! so the harness needs a bus whose every delay, loss, duplicate and
//! partition comes from one seed and happens at an exact virtual time. Each
//! message is a [`Packet`] with a delivery time; messages due at the same
//! time are delivered in the order they were sent. A partition cuts one
//! robot's agent off in both directions for an interval.

use bycoms_protocol::msg::{FromAgent, Pose, ToAgent};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// What travels.
#[derive(Clone, Debug, PartialEq)]
pub enum Packet {
    /// A command to robot `.0`'s agent.
    ToAgent(u32, ToAgent),
    /// A report to the orchestrator.
    Report(FromAgent),
    /// A pose on robot `topic`'s pose topic (the orchestrator and later
    /// robots' agents hear it). `relay`: republished by the orchestrator.
    Pose {
        /// The topic's robot.
        topic: u32,
        /// The pose.
        pose: Pose,
        /// The orchestrator's relay of a dead robot.
        relay: bool,
    },
    /// A pose from motion capture the orchestrator passes on to the
    /// robot's gateway (`Output::Forward`).
    Forwarded(Pose),
}

/// The network's faults.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NetFaults {
    /// Shortest one-way delay, µs.
    pub delay_min_us: u64,
    /// Longest one-way delay, µs (a spread reorders messages).
    pub delay_max_us: u64,
    /// Probability a message is lost.
    pub drop: f64,
    /// Probability a message arrives twice.
    pub duplicate: f64,
    /// Losses and duplicates only on the orchestrator's receiving side
    /// (agent reports and poses), as a launch's `[faults]` injects them;
    /// else on every message.
    pub inbound_only: bool,
}

impl NetFaults {
    /// A perfect link: every message after `delay_us`, in order.
    pub fn perfect(delay_us: u64) -> Self {
        Self {
            delay_min_us: delay_us,
            delay_max_us: delay_us,
            drop: 0.0,
            duplicate: 0.0,
            inbound_only: false,
        }
    }

    /// A link of `delay_us` that loses a share `drop` of what the
    /// orchestrator receives (a launch's `[faults] drop`).
    pub fn faults(delay_us: u64, drop: f64) -> Self {
        Self { drop, inbound_only: true, ..Self::perfect(delay_us) }
    }
}

/// Robot `robot`'s agent is cut off from `from_us` until `until_us`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Partition {
    /// The robot.
    pub robot: u32,
    /// Start, µs.
    pub from_us: u64,
    /// End, µs.
    pub until_us: u64,
}

impl Partition {
    /// Whether robot `robot` is cut off at `at`.
    pub fn cuts(&self, robot: u32, at: u64) -> bool {
        self.robot == robot && (self.from_us..self.until_us).contains(&at)
    }
}

/// The network: packets in flight, ordered by delivery time then sending order.
pub struct Net {
    net_faults: NetFaults,
    partitions: Vec<Partition>,
    rng: Xoshiro256PlusPlus,
    queue: BinaryHeap<Reverse<(u64, u64, usize)>>,
    packets: Vec<Option<Packet>>,
    seq: u64,
    /// Packets lost (drops and partitions).
    pub lost: u64,
}

impl Net {
    /// A network with `link`'s faults and `partitions`, drawing from `seed`.
    pub fn new(net_faults: NetFaults, partitions: Vec<Partition>, seed: u64) -> Self {
        Self {
            net_faults,
            partitions,
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            queue: BinaryHeap::new(),
            packets: Vec::new(),
            seq: 0,
            lost: 0,
        }
    }

    /// Whether robot `robot`'s agent is cut off at `at`.
    pub fn cut(&self, robot: u32, at: u64) -> bool {
        self.partitions.iter().any(|p| p.cuts(robot, at))
    }

    /// Sends `packet` at `now`; `robot` is the agent at the other end.
    pub fn send(&mut self, now: u64, robot: u32, packet: Packet) {
        let inbound = matches!(packet, Packet::Report(_) | Packet::Pose { relay: false, .. });
        let faulty = inbound || !self.net_faults.inbound_only;
        let (drop, duplicate) =
            if faulty { (self.net_faults.drop, self.net_faults.duplicate) } else { (0.0, 0.0) };
        if self.cut(robot, now) || self.rng.gen_bool(drop.clamp(0.0, 1.0)) {
            self.lost += 1;
            return;
        }
        let copies = if self.rng.gen_bool(duplicate.clamp(0.0, 1.0)) { 2 } else { 1 };
        for _ in 0..copies {
            let delay = self.rng.gen_range(
                self.net_faults.delay_min_us..=self.net_faults.delay_max_us.max(self.net_faults.delay_min_us),
            );
            let at = now + delay;
            // A message that would arrive while its receiver is cut off is lost.
            if self.cut(robot, at) {
                self.lost += 1;
                continue;
            }
            self.seq += 1;
            self.packets.push(Some(packet.clone()));
            self.queue.push(Reverse((at, self.seq, self.packets.len() - 1)));
        }
    }

    /// When the next packet arrives.
    pub fn next_at(&self) -> Option<u64> {
        self.queue.peek().map(|Reverse((at, _, _))| *at)
    }

    /// The next packet due at or before `now`.
    pub fn pop_due(&mut self, now: u64) -> Option<Packet> {
        let Reverse((at, _, index)) = *self.queue.peek()?;
        if at > now {
            return None;
        }
        self.queue.pop();
        self.packets[index].take()
    }
}
