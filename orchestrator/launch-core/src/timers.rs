//! The supervision timers: when an agent that is alive as far as the OS
//! knows is gone for the launch.
//!
//! Why in the core: an agent that hangs, never came or whose link is cut
//! only shows by what does *not* arrive, so each rule is a deadline —
//! registration (started + `register_timeout`), heartbeat (last heard +
//! `heartbeat_timeout`), the quiet rule (last heard + `quiet`: unreachable,
//! with an unreachable grace only), the unreachable grace (unreachable since + grace:
//! gone) and the robot-link grace (a gateway said its robot's link is down
//! since + grace: gone). quinn-proto keeps every connection timer in its
//! core the same way: [`LaunchCore::deadline`] covers them, [`LaunchCore::advance`]
//! decides them, and a test drives them in virtual time. The agent seams
//! only report facts with no clock (a process exited, a liveliness token
//! went or came back); being heard is a report the core takes in anyway,
//! and a robot's link is a report (`FromAgent::Link`).
//!
//! The settings ([`Supervision`]) come from the launch's config into the
//! setup (`orchestrator/launch/src/setup.rs`), so `--heartbeat-timeout` and the others drive
//! each rule here and nowhere else. A log recorded before the core kept
//! these timers is upgraded to timers that never expire, its seams'
//! verdicts its inputs (`log/v1.rs`).

use super::watch::{Expired, Watch};
use super::*;

impl LaunchCore {
    /// The timers' settings.
    fn sup(&self) -> &Supervision {
        &self.setup.supervision
    }

    fn watch(&mut self, id: u32) -> Option<&mut Watch> {
        id.checked_sub(1).and_then(|i| self.watches.get_mut(i as usize))
    }

    /// Robot `id`'s agent was started (or is expected again): its
    /// registration timer runs from `now` (a late joiner, registered
    /// already, keeps its heartbeat timer).
    pub(super) fn watch_started(&mut self, now: u64, id: u32) {
        let registered = self.slot_ref(id).is_some_and(|s| s.registered_before_tick.is_some());
        if let Some(w) = self.watch(id) {
            let heard = w.heard.filter(|_| registered);
            *w = Watch { started: Some(now), heard, ..Watch::default() };
        }
    }

    /// Robot `id`'s agent was heard from (a report of a registered agent,
    /// or its registration): alive, and back when it was unreachable.
    pub(super) fn watch_heard(&mut self, now: u64, id: u32) {
        let Some(w) = self.watch(id).filter(|w| w.started.is_some()) else { return };
        w.heard = Some(now);
        if w.unreachable.take().is_some() {
            self.on_reach(now, id, Reach::Back);
        }
    }

    /// Robot `id`'s liveliness token went (`present` false) or came back:
    /// without an unreachable grace its agent is gone at once, with one it is
    /// unreachable (it is back when it is heard again, not when its token
    /// is: a token may come back before messages do).
    pub(super) fn watch_token(&mut self, now: u64, id: u32, present: bool) {
        let supervised = self.watch(id).is_some_and(|w| w.started.is_some());
        if present || !supervised {
            return;
        }
        if !self.sup().holds() {
            self.timer_gone(now, id, Gone::Disconnected);
        } else {
            self.lose(now, id);
        }
    }

    /// What robot `id`'s gateway said about its robot's link.
    pub(super) fn watch_robot_link(&mut self, now: u64, id: u32, up: bool) {
        if self.sup().robot_link_grace_us.is_none() {
            return;
        }
        let Some(w) = self.watch(id).filter(|w| w.started.is_some()) else { return };
        if up {
            if w.link_down.take().is_some() {
                tracing::info!(robot = id, "robot {id}'s link is back within the grace: it stays");
            }
        } else {
            w.link_down.get_or_insert(now);
        }
    }

    /// Robot `id` is no longer supervised (gone, killed).
    pub(super) fn watch_stop(&mut self, id: u32) {
        if let Some(w) = self.watch(id) {
            *w = Watch::default();
        }
    }

    /// Robot `id` is unreachable from `now` (first time only).
    fn lose(&mut self, now: u64, id: u32) {
        let Some(w) = self.watch(id).filter(|w| w.unreachable.is_none()) else { return };
        w.unreachable = Some(now);
        self.on_reach(now, id, Reach::Lost);
    }

    /// When the next supervision timer expires.
    pub(super) fn supervision_due(&self) -> Option<u64> {
        let s = self.sup();
        self.watches.iter().zip(&self.slots).filter_map(|(w, slot)| w.due(s, self.quiet_of(slot))).min()
    }

    /// Decides every supervision timer expired at `now`, in robot order.
    pub(super) fn supervise(&mut self, now: u64) {
        for id in 1..=self.setup.robots {
            match self.expired(now, id) {
                Some(Expired::Unreachable) => self.lose(now, id),
                Some(Expired::Gone(gone)) => self.timer_gone(now, id, gone),
                None => {}
            }
        }
    }

    /// The quiet rule of `slot`'s agent: none for a parked robot (its agent
    /// beats four times per heartbeat timeout, slower than the quiet).
    fn quiet_of(&self, slot: &Slot) -> u64 {
        if slot.parked {
            0
        } else {
            self.sup().quiet_us
        }
    }

    /// Which of robot `id`'s timers expired at `now` ([`Watch::expired`]).
    fn expired(&self, now: u64, id: u32) -> Option<Expired> {
        let w = self.watches.get(id.checked_sub(1)? as usize)?;
        w.expired(self.sup(), self.quiet_of(self.slot_ref(id)?), now)
    }

    /// Robot `id`'s agent is gone by a timer: ended (killed, or dropped
    /// from the launch), then the dead-robot policy.
    fn timer_gone(&mut self, now: u64, id: u32, gone: Gone) {
        self.watch_stop(id);
        self.outputs.push_back(Output::Kill(id));
        self.gone(now, id, gone);
    }
}
