//! Who of a swarm is alive: zenoh liveliness tokens, one per agent and one
//! for the orchestrator (names in [`crate::naming`]'s `alive` module).
//!
//! Why zenoh's liveliness and not heartbeats of our own: a token is tied to
//! the declaring session, so zenoh itself withdraws it when the process
//! ends (its socket closes: seen at once) or when the link stays silent
//! for one lease (a cut cable, a crashed host). With [`Liveness::FAST`] on
//! both ends that is ≤ 400 ms, under the 500 ms the issue asks for, while
//! the keep-alives cost four tiny frames per lease. A watcher sees each
//! change as a [`PresenceEvent`], stamped when zenoh delivered it, so a
//! benchmark can time detection without polling.
//!
//! The watcher asks for history: tokens declared before it are reported as
//! [`Presence::Alive`] first. Events are queued unbounded (a swarm has a few
//! hundred members at most, each changes rarely), so none is lost.
//!
//! [`Liveness::FAST`]: super::Liveness::FAST

use super::ZenohBus;
use crate::bus::BusError;
use crate::naming::{Member, Swarm};
use ::zenoh::liveliness::LivelinessToken;
use ::zenoh::pubsub::Subscriber;
use ::zenoh::sample::{Sample, SampleKind};
use ::zenoh::Wait as _;
use core::time::Duration;
use std::sync::mpsc;
use std::time::Instant;

/// A declared liveliness token; dropping it withdraws it (the member is
/// then reported lost by every watcher).
pub struct AliveToken {
    _token: LivelinessToken,
    member: Member,
}

impl AliveToken {
    /// Whose token this is.
    pub fn member(&self) -> Member {
        self.member
    }
}

/// Whether a member appeared or disappeared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Presence {
    /// Its token appeared (or was there when the watch started).
    Alive,
    /// Its token was withdrawn: the process ended, undeclared it, or its
    /// link was silent for a lease.
    Lost,
}

/// One change seen by an [`AliveWatch`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PresenceEvent {
    /// Whose token changed.
    pub member: Member,
    /// Alive or lost.
    pub presence: Presence,
    /// When zenoh delivered the change to this process.
    pub at: Instant,
}

/// The liveliness changes of one swarm, in the order zenoh delivered them.
pub struct AliveWatch {
    _subscriber: Subscriber<()>,
    events: mpsc::Receiver<PresenceEvent>,
}

impl AliveWatch {
    /// The next change, waiting up to `timeout`; `None` when it passed.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<PresenceEvent> {
        self.events.recv_timeout(timeout).ok()
    }

    /// The next change if one is pending.
    pub fn try_recv(&self) -> Option<PresenceEvent> {
        self.events.try_recv().ok()
    }

    /// Waits up to `timeout` for `member` to become `presence`, skipping
    /// (and returning) the other events seen meanwhile.
    pub fn wait_for(
        &self,
        member: Member,
        presence: Presence,
        timeout: Duration,
    ) -> (Option<PresenceEvent>, Vec<PresenceEvent>) {
        let deadline = Instant::now() + timeout;
        let mut skipped = Vec::new();
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            match self.recv_timeout(left) {
                Some(e) if e.member == member && e.presence == presence => return (Some(e), skipped),
                Some(e) => skipped.push(e),
                None => break,
            }
        }
        (None, skipped)
    }
}

fn event_of(swarm: &Swarm, sample: &Sample) -> Option<PresenceEvent> {
    let at = Instant::now();
    let key = sample.key_expr().as_str();
    let Some(member) = swarm.member_of(key) else {
        tracing::debug!(key, "liveliness token outside the naming scheme ignored");
        return None;
    };
    let presence = match sample.kind() {
        SampleKind::Put => Presence::Alive,
        SampleKind::Delete => Presence::Lost,
    };
    Some(PresenceEvent { member, presence, at })
}

impl ZenohBus {
    /// Declares `member`'s liveliness token in `swarm`; it lasts as long
    /// as the returned value and this session.
    pub fn declare_alive(&self, swarm: &Swarm, member: Member) -> Result<AliveToken, BusError> {
        let name = swarm.alive(member);
        let token =
            self.session().liveliness().declare_token(name.as_str().to_owned()).wait().map_err(|e| {
                super::text::backend("declare liveliness token", Some(name.to_string()), None, &e)
            })?;
        Ok(AliveToken { _token: token, member })
    }

    /// Watches every liveliness token of `swarm` (history included).
    pub fn watch_alive(&self, swarm: &Swarm) -> Result<AliveWatch, BusError> {
        self.watch_keys(swarm, swarm.alive_everyone().as_str())
    }

    /// Watches `member`'s token of `swarm` alone (history included). An
    /// agent needs only the orchestrator's: watching every token would send
    /// each member's every change to every agent, N² deliveries in a swarm
    /// of N (300 agents starting at once on one router kept it so busy that
    /// their links timed out).
    pub fn watch_alive_of(&self, swarm: &Swarm, member: Member) -> Result<AliveWatch, BusError> {
        self.watch_keys(swarm, swarm.alive(member).as_str())
    }

    /// Watches the liveliness tokens of `swarm` under `keys`.
    fn watch_keys(&self, swarm: &Swarm, keys: &str) -> Result<AliveWatch, BusError> {
        let (tx, events) = mpsc::channel();
        let swarm = *swarm;
        let subscriber = self
            .session()
            .liveliness()
            .declare_subscriber(keys.to_owned())
            .history(true)
            .callback(move |sample: Sample| {
                if let Some(event) = event_of(&swarm, &sample) {
                    // The watch may be gone already; nothing to tell then.
                    let _ = tx.send(event);
                }
            })
            .wait()
            .map_err(|e| super::text::backend("watch liveliness", None, Some(&keys), &e))?;
        Ok(AliveWatch { _subscriber: subscriber, events })
    }
}
