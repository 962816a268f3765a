//! What agents that ran ahead sent for later steps, kept until each step's
//! tick (`ahead.rs` says why and when).
//!
//! A file of its own, with no use of the core's types: the core holds one,
//! and `ahead.rs` (which uses the core) fills and empties it.

use bycoms_protocol::msg::Pose;
use std::collections::BTreeMap;

/// Something an agent sent for a step after the tick in flight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Held {
    /// Its pose.
    Pose(Pose),
    /// Its controller's mode (a `Status`).
    Mode(u8),
    /// Its robot will never move again (a `Parked`).
    Parked,
}

/// Held messages by step, each step's in the order they came.
#[derive(Clone, Debug, Default)]
pub(super) struct HeldBack {
    by_step: BTreeMap<u64, Vec<(u32, Held)>>,
}

impl HeldBack {
    /// Keeps `what` of robot `id` for `step`.
    pub(super) fn hold(&mut self, step: u64, id: u32, what: Held) {
        self.by_step.entry(step).or_default().push((id, what));
    }

    /// Everything held for `step` and before it, in step order and then in
    /// the order it came; no longer held.
    pub(super) fn take_through(&mut self, step: u64) -> Vec<(u32, Held)> {
        let mut due = Vec::new();
        while let Some(entry) = self.by_step.first_entry() {
            if *entry.key() > step {
                break;
            }
            due.extend(entry.remove());
        }
        due
    }
}
