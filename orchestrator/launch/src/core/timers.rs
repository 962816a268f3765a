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
//! each rule here and nowhere else. A setup recorded before the core kept
//! these timers decodes with them off ([`Supervision::on`] false): its
//! recorded log carries the seams' verdicts as inputs, and replays as it ran.

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
        if present || !supervised || !self.sup().on {
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
        if !s.on {
            return None;
        }
        self.watches.iter().zip(&self.slots).filter_map(|(w, slot)| w.due(s, self.quiet_of(slot))).min()
    }

    /// Decides every supervision timer expired at `now`, in robot order.
    pub(super) fn supervise(&mut self, now: u64) {
        if !self.sup().on {
            return;
        }
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

#[cfg(test)]
mod tests {
    //! Every supervision rule in virtual time: what the agents seams'
    //! conformance suite used to time on wall clocks with real processes.

    use super::*;
    use crate::agents::gateways::LINK_GRACE;
    use crate::config::LaunchConfig;
    use crate::harness::{self, Case, Schedule};
    use bycoms_protocol::msg::{Heartbeat, LinkStatus, Parked};

    const MS: u64 = 1000;

    /// A launch of two robots in virtual time, its agents started at once
    /// and answered by hand.
    struct Lab {
        core: LaunchCore,
        now: u64,
        /// Robots the core ended, with when.
        killed: Vec<(u32, u64)>,
        /// The reachability changes the core noticed, with when.
        reach: Vec<(u32, EventKind, u64)>,
    }

    impl Lab {
        /// Remote agents (`held`: held when unreachable) or spawned ones,
        /// with the launch's default supervision but for `tune`, and robot
        /// links watched when `robot_links`.
        fn new(held: bool, robot_links: bool, tune: impl FnOnce(&mut LaunchConfig)) -> Self {
            let mut case = Case::small(1);
            case.robots = 2;
            let mut schedule = Schedule::clean(1, 2);
            schedule.remote = true;
            let mut setup = harness::setup(&case, &schedule);
            let mut cfg = LaunchConfig::default();
            tune(&mut cfg);
            setup.supervision = crate::setup::supervision(&cfg, held, robot_links.then_some(LINK_GRACE));
            let mut lab =
                Self { core: LaunchCore::new(setup), now: 0, killed: Vec::new(), reach: Vec::new() };
            lab.at(0, None);
            lab
        }

        /// Runs the core's deadlines up to `t`, then hands in `input` (if
        /// any) at `t` and lets the core decide.
        fn at(&mut self, t: u64, input: Option<Input>) {
            self.run_to(t);
            if let Some(input) = input {
                self.core.handle(t, input);
            }
            self.decide(t);
        }

        fn decide(&mut self, t: u64) {
            self.now = t;
            self.core.advance(t);
            while let Some(out) = self.core.poll_output() {
                match out {
                    Output::Start(id) => {
                        self.core.handle(t, Input::Started { robot: id, pid: None, how: "awaited".into() });
                    }
                    Output::Kill(id) => self.killed.push((id, t)),
                    Output::Event(e) if matches!(e.event, EventKind::Unreachable | EventKind::Reachable) => {
                        self.reach.push((e.robot, e.event, t));
                    }
                    _ => {}
                }
            }
        }

        fn register(&mut self, t: u64, id: u32) {
            let r = Register {
                robot: RobotId(id),
                kind: bycoms_protocol::msg::RobotKind::Simulated,
                protocol_version: PROTOCOL_VERSION,
                instance: 0x1000 + u64::from(id),
                settings: 0,
                failsafe_grace_ms: 0,
            };
            self.at(t, Some(Input::Report(FromAgent::Register(r))));
        }

        fn beat(&mut self, t: u64, id: u32) {
            self.at(t, Some(Input::Report(FromAgent::Heartbeat(Heartbeat { robot: RobotId(id), seq: t }))));
        }

        fn link(&mut self, t: u64, id: u32, up: bool) {
            let l = LinkStatus { robot: RobotId(id), up, silent_ms: 300, refused: 0 };
            self.at(t, Some(Input::Report(FromAgent::Link(l))));
        }

        /// Runs the core to `until` from one deadline to the next.
        fn run_to(&mut self, until: u64) {
            while let Some(d) = self.core.deadline().filter(|&d| d <= until) {
                self.decide(d.max(self.now));
                if self.core.deadline() == Some(d) {
                    break;
                }
            }
            self.now = self.now.max(until);
        }

        fn gone(&self, id: u32) -> Option<Gone> {
            self.core.slots()[id as usize - 1].gone()
        }
    }

    #[test]
    fn an_agent_that_never_registers_is_gone_at_the_registration_timeout() {
        let mut lab = Lab::new(false, false, |c| c.supervision.register_timeout = 3.0);
        lab.register(50 * MS, 1);
        for t in (150..6_000).step_by(100) {
            lab.beat(t * MS, 1);
            assert_eq!(lab.gone(2).is_some(), t >= 3_000, "at {t} ms");
        }
        assert_eq!(lab.gone(2), Some(Gone::NeverRegistered));
        let robot_2: Vec<_> = lab.killed.iter().filter(|k| k.0 == 2).collect();
        assert_eq!(robot_2, [&(2, 3_000 * MS)], "ended at the timeout, once");
        assert_ne!(lab.gone(1), Some(Gone::NeverRegistered), "an agent that registered did");
    }

    #[test]
    fn heartbeat_timeout_from_the_config_drives_the_core() {
        for timeout in [0.3, 2.0] {
            let mut lab = Lab::new(false, false, |c| c.supervision.heartbeat_timeout = timeout);
            lab.register(0, 1);
            lab.register(0, 2);
            for t in (100..1_000).step_by(100) {
                lab.beat(t * MS, 1);
                lab.beat(t * MS, 2);
            }
            let last = 900 * MS;
            let due = last + (timeout * 1e6) as u64;
            for t in (1_000..3_000).step_by(100) {
                lab.beat(t * MS, 2);
            }
            lab.run_to(due + 5_000 * MS);
            assert_eq!(lab.gone(1), Some(Gone::Silent), "timeout {timeout}");
            assert_eq!(
                lab.killed.first(),
                Some(&(1, due)),
                "timeout {timeout}: silent at last heard + timeout"
            );
            assert!(lab.reach.is_empty(), "spawned agents are never only unreachable");
        }
    }

    #[test]
    fn a_cut_link_is_noticed_within_500_ms_held_for_the_grace_and_back_when_heard() {
        let mut lab = Lab::new(true, false, |c| c.supervision.unreachable_grace = 2.0);
        lab.register(0, 1);
        lab.register(0, 2);
        let mut t = 0;
        while t < 1_000 * MS {
            t += 100 * MS;
            lab.beat(t, 1);
            lab.beat(t, 2);
        }
        // Robot 1's link is cut after its beat at 1 s; robot 2 beats on.
        let cut = t;
        while t < 2_000 * MS {
            t += 100 * MS;
            lab.beat(t, 2);
        }
        let noticed = lab.reach.iter().find(|r| r.0 == 1).map(|r| r.2).expect("noticed");
        assert_eq!(lab.reach[0].1, EventKind::Unreachable);
        assert!(noticed - cut <= 500 * MS, "noticed {} ms after the cut", (noticed - cut) / MS);
        assert_eq!(lab.gone(1), None, "held within the grace");
        lab.beat(t, 1);
        assert_eq!(lab.reach.last().map(|r| (r.0, r.1)), Some((1, EventKind::Reachable)));
        // Cut again, for longer than the grace: gone at unreachable + grace.
        let cut = t;
        while t < 6_000 * MS {
            t += 100 * MS;
            lab.beat(t, 2);
        }
        let lost = lab.reach.last().map(|r| r.2).expect("lost again");
        assert!(lost - cut <= 500 * MS);
        assert_eq!(lab.gone(1), Some(Gone::Unreachable { grace_ms: 2_000 }));
        assert_eq!(lab.killed, [(1, lost + 2_000 * MS)]);
        assert_eq!(lab.gone(2), None);
    }

    #[test]
    fn a_withdrawn_token_is_unreachable_with_a_grace_and_gone_at_once_without() {
        let mut lab = Lab::new(true, false, |c| c.supervision.unreachable_grace = 2.0);
        lab.register(0, 1);
        lab.register(0, 2);
        lab.at(100 * MS, Some(Input::Token(1, false)));
        assert_eq!(lab.reach, [(1, EventKind::Unreachable, 100 * MS)], "at once");
        assert_eq!(lab.gone(1), None);

        let mut lab = Lab::new(true, false, |c| c.supervision.unreachable_grace = 0.0);
        lab.register(0, 1);
        lab.register(0, 2);
        lab.at(100 * MS, Some(Input::Token(1, true)));
        assert_eq!(lab.gone(1), None, "a token that comes is nothing");
        lab.at(100 * MS, Some(Input::Token(1, false)));
        assert_eq!(lab.gone(1), Some(Gone::Disconnected));
        assert_eq!(lab.killed, [(1, 100 * MS)]);
        assert!(lab.reach.is_empty());
    }

    #[test]
    fn a_robot_link_lost_past_its_grace_is_gone_one_healed_within_stays() {
        let mut lab = Lab::new(false, true, |_| {});
        lab.register(0, 1);
        lab.register(0, 2);
        let grace = LINK_GRACE.as_micros() as u64;
        lab.link(100 * MS, 1, false);
        lab.link(100 * MS, 2, false);
        // Repeats keep the first time; robot 2's link heals within the grace.
        lab.link(150 * MS, 1, false);
        lab.link(200 * MS, 2, true);
        lab.run_to(100 * MS + grace);
        assert_eq!(lab.gone(1), Some(Gone::RobotLinkLost));
        assert_eq!(lab.killed, [(1, 100 * MS + grace)], "450 ms after a cut at the gateway's 300 ms");
        lab.run_to(1_000 * MS);
        assert_eq!(lab.gone(2), None);

        // Sources of simulated robots do not watch robot links.
        let mut lab = Lab::new(false, false, |_| {});
        lab.register(0, 1);
        lab.link(100 * MS, 1, false);
        lab.beat(900 * MS, 1);
        assert_eq!(lab.gone(1), None);
    }

    #[test]
    fn a_parked_agent_beating_slower_than_the_quiet_is_not_unreachable() {
        let mut lab = Lab::new(true, false, |_| {});
        lab.register(0, 1);
        lab.register(0, 2);
        // Only a deployed robot can be parked: mark robot 1 moving by hand.
        lab.core.slots[0].state = SlotState::Stuck;
        lab.at(10 * MS, Some(Input::Report(FromAgent::Parked(Parked { robot: RobotId(1), step: 3 }))));
        for t in (510..5_000).step_by(500) {
            lab.beat(t * MS, 1);
            lab.beat(t * MS, 2);
        }
        assert!(lab.reach.iter().all(|r| r.0 == 2), "robot 1 parked, beating every 0.5 s: {:?}", lab.reach);
        assert!(lab.reach.iter().any(|r| r.0 == 2), "robot 2, not parked, beating as slowly, is unreachable");
    }
}
