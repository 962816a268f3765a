//! Riding out a partition: unreachable agents are held, then resumed.
//!
//! Why: across hosts a link drops for a moment (lab WiFi, a switch). zenoh
//! closes the dead link's transport after one lease and reconnects when the
//! link is back, but whatever was in flight is gone: a `Tick`, its answer,
//! a `Deploy` or a start pose. The launch must neither take the pause for a
//! death nor go on without the lost messages. So:
//!
//! * an agent source that can tell ([`Reach`], remote agents with
//!   `supervision.link_grace`) reports an agent unreachable at once; the
//!   engine records it (an [`Outage`] in the summary, a `link_lost` event),
//!   and the lockstep clock waits: the tick and deploy deadlines do not run
//!   while an awaited agent is unreachable;
//! * when the agent is heard again the engine re-sends what that agent may
//!   have missed ([`Launch::resend`]): the pending `Deploy`, or the current
//!   tick's goal bearing, the dead robots' relays and `Tick`. Agents answer
//!   a repeated `Tick` without stepping again and a repeated `Deploy` with
//!   their start pose, and the gate ignores a pose it has seen, so nothing
//!   is applied twice or out of order;
//! * the same re-send also runs every [`RESEND`] while answers are awaited:
//!   zenoh may close a dead transport late or not report it at all (see
//!   `agents/remote.rs`), and a lost message must not cost a whole
//!   tick timeout;
//! * past the grace the source reports the agent gone and the gate's
//!   dead-robot policy applies, as for any death.

use super::agents::Reach;
use super::engine::{unix_ms, Launch, SLICE};
use super::events::{EventKind, LaunchEvent, EVENT_SCHEMA};
use super::summary::Outage;
use bycoms_protocol::msg::{Tick, ToAgent};
use std::time::{Duration, Instant};

/// How often what is still unanswered is sent again.
pub const RESEND: Duration = Duration::from_millis(1000);

/// The deadline and re-send timer of a wait for answers (a tick's, a start
/// pose's): the deadline restarts while an awaited agent is unreachable, and
/// what is unanswered is due again every [`RESEND`].
#[derive(Clone, Copy, Debug)]
pub struct AnswerWait {
    timeout: Duration,
    deadline: Instant,
    resend_at: Instant,
}

impl AnswerWait {
    /// A wait of `timeout` from now.
    pub fn new(timeout: Duration) -> Self {
        let now = Instant::now();
        Self { timeout, deadline: now + timeout, resend_at: now + RESEND }
    }

    /// At `now`, with `held` when an awaited agent is unreachable (the
    /// deadline restarts): whether to re-send now.
    pub fn resend_due(&mut self, now: Instant, held: bool) -> bool {
        if held {
            self.deadline = now + self.timeout;
        }
        let due = now >= self.resend_at;
        if due {
            self.resend_at = now + RESEND;
        }
        due
    }

    /// Whether the deadline has passed at `now`.
    pub fn expired(&self, now: Instant) -> bool {
        now >= self.deadline
    }

    /// How long to pump before looking again.
    pub fn slice(&self, now: Instant) -> Duration {
        SLICE
            .min(self.deadline.saturating_duration_since(now))
            .min(self.resend_at.saturating_duration_since(now))
    }
}

impl Launch {
    /// Takes in the agent source's reachability changes.
    pub fn take_reach(&mut self) -> anyhow::Result<()> {
        for (id, change) in self.agents.reach() {
            self.on_reach(id, change)?;
        }
        Ok(())
    }

    fn on_reach(&mut self, id: u32, change: Reach) -> anyhow::Result<()> {
        let grace = self.cfg.supervision.link_grace;
        let Some(slot) = self.slot(id) else { return Ok(()) };
        let state = slot.state;
        let (kind, text) = match change {
            Reach::Lost => {
                slot.outages.push(Outage { lost_unix_ms: unix_ms(), back_unix_ms: None });
                tracing::warn!(robot = id, grace_s = grace, "robot {id}'s agent is unreachable");
                (
                    EventKind::LinkLost,
                    format!("robot {id}: link lost — waiting up to {grace} s for it to return"),
                )
            }
            Reach::Back => {
                let now = unix_ms();
                let Some(outage) = slot.outages.last_mut().filter(|o| o.back_unix_ms.is_none()) else {
                    return Ok(());
                };
                outage.back_unix_ms = Some(now);
                let after = now.saturating_sub(outage.lost_unix_ms);
                tracing::info!(robot = id, after_ms = after, "robot {id}'s agent is back");
                (EventKind::LinkBack, format!("robot {id}: link back after {after} ms"))
            }
        };
        self.progress.event(&text);
        let event = LaunchEvent {
            robot: id,
            event: kind,
            pid: None,
            source: None,
            reason: None,
            state: Some(format!("{state:?}")),
        };
        let topic = format!("bycoms/{}/events", self.template.swarm);
        self.ports.recording.json(&topic, EVENT_SCHEMA, &event);
        if change == Reach::Back {
            self.resend(&[id])?;
        }
        Ok(())
    }

    /// Whether robot `id`'s agent is alive but unreachable now (an open
    /// outage; a dead agent's last outage stays open, it never came back).
    pub fn unreachable(&self, id: u32) -> bool {
        id.checked_sub(1)
            .and_then(|i| self.slots.get(i as usize))
            .filter(|s| s.alive)
            .and_then(|s| s.outages.last())
            .is_some_and(|o| o.back_unix_ms.is_none())
    }

    /// Whether any of `ids` is unreachable now.
    pub fn any_unreachable(&self, ids: impl IntoIterator<Item = u32>) -> bool {
        ids.into_iter().any(|id| self.unreachable(id))
    }

    /// Sends robots `ids` again what they may have missed: the pending
    /// `Deploy` of a robot being deployed; for a robot whose answer to the
    /// current tick is awaited, that tick's goal bearing (when it is the
    /// moving robot), the dead robots' relays and the `Tick`.
    pub fn resend(&mut self, ids: &[u32]) -> anyhow::Result<()> {
        let t = self.current_tick;
        let mut relayed = false;
        for &id in ids {
            if let Some(deploy) = self.pending_deploy.filter(|d| d.robot.0 == id) {
                self.ports.send(id, &ToAgent::Deploy(deploy))?;
                self.resends += 1;
            }
            if !self.awaiting.contains(&id) {
                continue;
            }
            if let Some(bearing) = self.last_bearing.filter(|b| b.robot.0 == id && b.step == t) {
                self.ports.send(id, &ToAgent::GoalBearing(bearing))?;
            }
            if !relayed {
                self.relay_dead(t, t * self.cfg.dt_us())?;
                relayed = true;
            }
            self.ports.send(id, &ToAgent::Tick(Tick { step: t }))?;
            self.resends += 1;
        }
        Ok(())
    }
}
