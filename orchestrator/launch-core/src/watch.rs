//! The supervision settings and each robot's timers, as the core keeps
//! them, and their one reading (`timers.rs` holds the rules that set the
//! timers and acts on what expired).
//!
//! Why one reading: [`Watch::timers`] says which timer expires when and
//! what it means then; both the deadline the core reports and the verdict
//! it takes at that deadline read it, so they cannot disagree (they were
//! two copies of the same case analysis).

use crate::Gone;
use serde::{Deserialize, Serialize};

/// The supervision settings of a launch, µs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Supervision {
    /// A started agent must register within this long.
    pub register_timeout_us: u64,
    /// A registered agent silent this long is gone ([`Gone::Silent`]), or
    /// unreachable when the launch holds its agents.
    pub heartbeat_timeout_us: u64,
    /// The unreachable grace (`supervision.unreachable_grace`), the one
    /// value of it: how long an unreachable agent is held before it is
    /// gone ([`Gone::Unreachable`]) when [`Self::held`], what the messages
    /// say, and what the least failsafe grace an agent may register with
    /// is made from ([`least_failsafe_grace_ms`]).
    pub unreachable_grace_us: u64,
    /// Whether the launch's agents can come back (remote agents, gateways
    /// elsewhere), so that an unreachable one is held for the grace
    /// ([`Self::holds`]); else a withdrawn token is [`Gone::Disconnected`]
    /// at once.
    pub held: bool,
    /// When the launch holds its agents: the silence after which a heard agent is
    /// unreachable (zero: only the heartbeat timeout). Not for a parked
    /// robot's agent: it beats slower (four times per heartbeat timeout).
    pub quiet_us: u64,
    /// How long a robot's own link reported down must stay down before the
    /// robot is gone ([`Gone::RobotLinkLost`]); none: robot links are not
    /// watched (simulated agents have none).
    pub robot_link_grace_us: Option<u64>,
}

/// One robot's timers (all µs of launch time).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Watch {
    /// Supervised since its agent was started (none: not supervised).
    pub(super) started: Option<u64>,
    /// When it was last heard from, once registered.
    pub(super) heard: Option<u64>,
    /// Unreachable since (unreachable grace running).
    pub(super) unreachable: Option<u64>,
    /// Its robot's link down since (robot-link grace running).
    pub(super) link_down: Option<u64>,
}

/// What an expired timer means.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Expired {
    /// Unreachable from now on (held within the unreachable grace).
    Unreachable,
    /// Gone for the launch.
    Gone(Gone),
}

impl Supervision {
    /// Timers that never expire, with an unreachable grace of `grace_us`
    /// (what the messages and the least failsafe grace read), agents not
    /// held: every verdict then comes as an input ([`Input::Gone`](crate::Input::Gone)), as in
    /// tests that lose robots by hand.
    pub fn never(grace_us: u64) -> Self {
        Self {
            register_timeout_us: u64::MAX,
            heartbeat_timeout_us: u64::MAX,
            unreachable_grace_us: grace_us,
            held: false,
            quiet_us: 0,
            robot_link_grace_us: None,
        }
    }

    /// Whether an agent the launch cannot reach is held (for
    /// [`Self::unreachable_grace_us`]) rather than gone at once: the one
    /// test of it (the timers, a withdrawn token). A grace of 0 holds no
    /// agent.
    pub fn holds(&self) -> bool {
        self.held && self.unreachable_grace_us > 0
    }
}

/// The least failsafe grace an agent of a launch whose unreachable grace
/// is `grace_us` (`supervision.unreachable_grace`, µs) may register with,
/// ms (rounded up): shorter, a cut the launch rides out would stop its
/// robot for good. The one decider of it: the core refuses a shorter one
/// ([`Refusal::Grace`](bycoms_protocol::msg::Refusal::Grace)) and the launch
/// gives its own agents at least this (`setup::joining`).
pub fn least_failsafe_grace_ms(grace_us: u64) -> u32 {
    grace_us.div_ceil(1000).min(u64::from(u32::MAX)) as u32
}

impl Watch {
    /// This robot's running timers, each with when it expires and what it
    /// means then, the robot's link first (it wins when both are due): the
    /// one case analysis that [`Self::due`] and [`Self::expired`] read
    /// (`quiet`: the robot's quiet rule, none for a parked robot).
    fn timers(&self, s: &Supervision, quiet: u64) -> impl Iterator<Item = (u64, Expired)> {
        let link = match (self.link_down, s.robot_link_grace_us) {
            (Some(down), Some(grace)) => {
                Some((down.saturating_add(grace), Expired::Gone(Gone::RobotLinkLost)))
            }
            _ => None,
        };
        let agent = self.started.map(|started| match (self.unreachable, self.heard) {
            (Some(since), _) => (
                since.saturating_add(s.unreachable_grace_us),
                Expired::Gone(Gone::Unreachable { grace_ms: s.unreachable_grace_us / 1000 }),
            ),
            (None, Some(h)) if s.holds() && quiet > 0 => {
                (h.saturating_add(quiet.min(s.heartbeat_timeout_us)), Expired::Unreachable)
            }
            (None, Some(h)) if s.holds() => (h.saturating_add(s.heartbeat_timeout_us), Expired::Unreachable),
            (None, Some(h)) => (h.saturating_add(s.heartbeat_timeout_us), Expired::Gone(Gone::Silent)),
            (None, None) => {
                (started.saturating_add(s.register_timeout_us), Expired::Gone(Gone::NeverRegistered))
            }
        });
        // A saturated time is a timer that never expires (`Supervision::never`).
        self.started.and(link).into_iter().chain(agent).filter(|&(at, _)| at != u64::MAX)
    }

    /// The next time one of this robot's timers expires.
    pub(super) fn due(&self, s: &Supervision, quiet: u64) -> Option<u64> {
        self.timers(s, quiet).map(|(at, _)| at).min()
    }

    /// Which of this robot's timers expired at `now`, if one did.
    pub(super) fn expired(&self, s: &Supervision, quiet: u64, now: u64) -> Option<Expired> {
        self.timers(s, quiet).find(|&(at, _)| now >= at).map(|(_, what)| what)
    }
}

#[cfg(test)]
mod tests {
    //! The deadline and the verdict are one reading: at every robot's
    //! deadline a timer has expired, and none before it.

    use super::*;

    #[test]
    fn a_robot_s_timers_expire_at_its_deadline_and_not_before() {
        let mut seed = 0x5eed_u64;
        let mut draw = |n: u64| {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 33) % n
        };
        for _ in 0..10_000 {
            let pick = |d: u64, at: u64| (d > 0).then_some(at);
            let s = Supervision {
                register_timeout_us: 1 + draw(5_000),
                heartbeat_timeout_us: 1 + draw(5_000),
                unreachable_grace_us: draw(2) * draw(5_000),
                held: draw(4) > 0,
                quiet_us: draw(2) * draw(5_000),
                robot_link_grace_us: pick(draw(2), draw(5_000)),
            };
            let w = Watch {
                started: pick(draw(4), draw(1_000)),
                heard: pick(draw(2), draw(1_000)),
                unreachable: pick(draw(3) / 2, draw(1_000)),
                link_down: pick(draw(2), draw(1_000)),
            };
            let quiet = draw(2) * s.quiet_us;
            let Some(due) = w.due(&s, quiet) else {
                assert_eq!(w.started, None, "a supervised robot has a deadline");
                continue;
            };
            assert!(w.expired(&s, quiet, due).is_some(), "{s:?} {w:?}: nothing at {due}");
            if let Some(before) = due.checked_sub(1) {
                assert_eq!(w.expired(&s, quiet, before), None, "{s:?} {w:?}: expired before {due}");
            }
        }
    }
}
