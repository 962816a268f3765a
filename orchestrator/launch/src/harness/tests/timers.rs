//! Every supervision rule in virtual time: what the agents seams'
//! conformance suite used to time on wall clocks with real processes.

use crate::agents::gateways::LINK_GRACE;
use crate::config::LaunchConfig;
use crate::core::*;
use crate::events::EventKind;
use crate::harness::{self, Case, Schedule};
use bycoms_protocol::msg::{FromAgent, Register};
use bycoms_protocol::msg::{Heartbeat, LinkStatus, Parked};
use bycoms_protocol::{RobotId, PROTOCOL_VERSION};

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
        let mut lab = Self { core: LaunchCore::new(setup), now: 0, killed: Vec::new(), reach: Vec::new() };
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
        while let Some(out) = self.core.poll() {
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
        assert_eq!(lab.killed.first(), Some(&(1, due)), "timeout {timeout}: silent at last heard + timeout");
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
    lab.core.set_state_by_hand(1, SlotState::Stuck);
    lab.at(10 * MS, Some(Input::Report(FromAgent::Parked(Parked { robot: RobotId(1), step: 3 }))));
    for t in (510..5_000).step_by(500) {
        lab.beat(t * MS, 1);
        lab.beat(t * MS, 2);
    }
    assert!(lab.reach.iter().all(|r| r.0 == 2), "robot 1 parked, beating every 0.5 s: {:?}", lab.reach);
    assert!(lab.reach.iter().any(|r| r.0 == 2), "robot 2, not parked, beating as slowly, is unreachable");
}
