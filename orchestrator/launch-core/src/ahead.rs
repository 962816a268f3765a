//! Lockstep: a creeping robot stepped several periods at once.
//!
//! Why: a robot the gate judged stuck is a beacon, but unless it froze in
//! a wall (`Parked`) it still creeps, and parity with `simulate` needs its
//! pose at every step (it moves the beacon the next robots sense). Most
//! agents a crowd's tick steps are such robots (`bench crowd`: about 100 of
//! 102 at 1000 robots), each a wake-up through the kernel each way per
//! tick. Once judged, the robot is sent no goal bearing and no beacons any
//! more, so its next periods depend on nothing the launch could still tell
//! it: one [`ToAgent::Ticks`] steps [`Commands::ticks_at_once`] of them, and
//! its agent publishes every pose (and status) at once.
//!
//! What keeps the run the same: what such an agent sends for a step beyond
//! the tick in flight (a pose, a `Status`, a `Parked`) is held here and
//! taken in when that step's tick is answered, exactly when its answer to a
//! `Tick` would have come; poses of the tick in flight are taken at once,
//! as always. What is held past the launch's end is dropped (the
//! simulation stopped there too). Only agents the launch started itself
//! are sent it (`Commands::ticks_at_once` is 1 otherwise): they are of its own
//! build and on its own host, where nothing is lost on the way.

use super::held::Held;
use super::*;

impl LaunchCore {
    /// Whether robot `id`'s agent steps several periods per message: a
    /// robot judged stuck that creeps, in lockstep, when the seam allows.
    pub(super) fn runs_ahead(&self, slot: &Slot) -> bool {
        self.setup.lockstep
            && self.setup.commands.ticks_at_once > 1
            && slot.state == SlotState::Stuck
            && !slot.parked
            && self.referee.watched() != Some(slot.id)
    }

    /// Tick `t` for robot `id`'s agent, which runs ahead: `None` when an
    /// earlier run covers `t` already (nothing to send, nothing to await),
    /// else the `Ticks` that starts a new run at `t`. Runs end at the
    /// multiples of [`Commands::ticks_at_once`] (a robot's first run is
    /// shorter), so the agents that run ahead are all woken by the same
    /// ticks: their wake-ups overlap on the cores instead of each adding
    /// its own to a tick of its own.
    pub(super) fn run_from(&mut self, id: u32, t: u64) -> Option<ToAgent> {
        let every = u64::from(self.setup.commands.ticks_at_once.max(1));
        let slot = self.slot(id)?;
        if slot.ran_ahead.is_some_and(|(first, last)| (first..=last).contains(&t)) {
            return None;
        }
        let last = t.div_ceil(every) * every;
        slot.ran_ahead = Some((t, last));
        Some(ToAgent::Ticks(Ticks { step: t, count: (last - t + 1) as u32 }))
    }

    /// The command that (re-)sends tick `t` to robot `id`: the run that
    /// began at `t` if one did, else a `Tick`.
    pub(super) fn tick_command(&self, id: u32, t: u64) -> ToAgent {
        match self.slot_ref(id).and_then(|s| s.ran_ahead) {
            Some((first, last)) if first == t => {
                ToAgent::Ticks(Ticks { step: t, count: (last - first + 1) as u32 })
            }
            _ => ToAgent::Tick(Tick { step: t }),
        }
    }

    /// Holds what robot `id`'s agent sent for `step` if that is after the
    /// tick in flight and the agent ran ahead; true when held.
    pub(super) fn held_back(&mut self, id: u32, step: u64, what: Held) -> bool {
        let newest = self.tick.as_ref().map_or(self.ticks, |t| t.step);
        let ran = self.slot_ref(id).and_then(|s| s.ran_ahead).is_some_and(|(_, last)| step <= last);
        if !self.setup.lockstep || step <= newest || !ran {
            return false;
        }
        self.held.hold(step, id, what);
        true
    }

    /// Tick `step` is answered: everything held for it (and before it) is
    /// taken in, in the order it came.
    pub(super) fn release_held(&mut self, now: u64, step: u64) {
        for (id, what) in self.held.take_through(step) {
            // An agent gone since: what it sent for later is not taken.
            if !self.slot_ref(id).is_some_and(|s| s.alive) {
                continue;
            }
            match what {
                Held::Pose(pose) => self.on_pose(now, id, pose),
                Held::Mode(mode) => self.take_mode(id, mode),
                Held::Parked => self.take_parked(id),
            }
        }
    }

    /// A `Status`'s mode, taken.
    pub(super) fn take_mode(&mut self, id: u32, mode: u8) {
        if let Some(slot) = self.slot(id) {
            slot.mode = mode;
        }
    }

    /// A `Parked`, taken. Only a deployed robot can be parked: an agent that
    /// says so before would miss the ticks that number its start pose.
    pub(super) fn take_parked(&mut self, id: u32) {
        if let Some(slot) = self.slot(id) {
            slot.parked |= matches!(slot.state, SlotState::Moving | SlotState::Stuck | SlotState::Arrived);
        }
    }
}
