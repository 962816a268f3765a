//! The supervision settings and each robot's timers, as the core keeps
//! them (`timers.rs` holds the rules that set and decide them).

use serde::{Deserialize, Serialize};

/// The supervision settings of a launch, µs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Supervision {
    /// Whether the core keeps the timers (false: a setup recorded before
    /// it did; the verdicts are inputs then).
    pub on: bool,
    /// A started agent must register within this long.
    pub register_timeout_us: u64,
    /// A registered agent silent this long is gone ([`Gone::Silent`](crate::agents::Gone::Silent)), or
    /// unreachable with a link grace.
    pub heartbeat_timeout_us: u64,
    /// How long an unreachable agent is held before it is gone
    /// ([`Gone::Unreachable`](crate::agents::Gone::Unreachable)); zero: no holding (a withdrawn token is
    /// [`Gone::Disconnected`](crate::agents::Gone::Disconnected) at once). Agents that can come back only
    /// (remote agents, gateways elsewhere).
    pub unreachable_grace_us: u64,
    /// With a link grace: the silence after which a heard agent is
    /// unreachable (zero: only the heartbeat timeout). Not for a parked
    /// robot's agent: it beats slower (four times per heartbeat timeout).
    pub quiet_us: u64,
    /// How long a robot's own link reported down must stay down before the
    /// robot is gone ([`Gone::RobotLinkLost`](crate::agents::Gone::RobotLinkLost)); none: robot links are not
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
    /// Unreachable since (link grace running).
    pub(super) unreachable: Option<u64>,
    /// Its robot's link down since (robot-link grace running).
    pub(super) link_down: Option<u64>,
}

impl Watch {
    /// The next time one of this robot's timers expires (`quiet`: its
    /// quiet rule, none for a parked robot).
    pub(super) fn due(&self, s: &Supervision, quiet: u64) -> Option<u64> {
        let started = self.started?;
        let hold = s.unreachable_grace_us > 0;
        let mut due = match (self.unreachable, self.heard) {
            (Some(since), _) => since.saturating_add(s.unreachable_grace_us),
            (None, Some(h)) if hold && quiet > 0 => h.saturating_add(quiet.min(s.heartbeat_timeout_us)),
            (None, Some(h)) => h.saturating_add(s.heartbeat_timeout_us),
            (None, None) => started.saturating_add(s.register_timeout_us),
        };
        if let (Some(down), Some(grace)) = (self.link_down, s.robot_link_grace_us) {
            due = due.min(down.saturating_add(grace));
        }
        Some(due)
    }
}
