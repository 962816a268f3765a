//! A robot's voice taken away while the launch runs: `orchestrator revoke`
//! and `orchestrator certs --revoke` picked up by a running launch (issue 34).
//!
//! Why in the core: zenoh checks no certificate revocation list, and a
//! running zenoh router keeps the access-control list it started with. So
//! over QUIC or TLS a revoked robot's certificate still opens a session and
//! its agent can still publish on its own topics until the orchestrator is
//! restarted with the rewritten ACL (`certs.rs`). The launch therefore takes
//! the voice away itself, by one rule tested in virtual time:
//!
//! * the robot is told `Stop` once, if its agent runs (a simulated agent
//!   stays put, a gateway sends its robot the link's stop frame), and
//!   right after it `Shutdown`: its agent ends (a gateway stops its robot
//!   again and exits), so `orchestrator status`'s "agent not running" is
//!   true and nothing of it runs on; one that ignores it is ended with
//!   the others when the launch winds down;
//! * from then on nothing from it changes the launch: each of its reports
//!   is dropped and counted (the summary's and the status's `revoked`,
//!   `dropped`), a `Register` for it (any agent instance) is refused with
//!   [`Refusal::Revoked`], and what its agent source says of it (started,
//!   gone, unreachable, its token) is ignored;
//! * it counts as a dead robot whose death the launch goes on from,
//!   whatever `supervision.on_death` says (the operator chose it, it is no
//!   fault): moving, it becomes a beacon where it stopped (gate event
//!   `died`, summary `end: died`); not deployed yet, it is lost and skipped
//!   at its turn (summary `not_deployed`); already decided (stuck,
//!   arrived), it keeps its end. Its death's reason says who revoked it
//!   and why. Its poses are ignored as a dead robot's are.
//!
//! The first revocation of a robot counts; asking again changes nothing.

use super::stop::shown;
use super::*;

impl LaunchCore {
    /// Takes robot `revoke.robot`'s voice away (see the module docs).
    pub(super) fn on_revoke(&mut self, now: u64, revoke: Revoke) {
        let Revoke { robot: id, who, why } = revoke;
        if self.slot_ref(id).is_none() || self.is_revoked(id) {
            return;
        }
        // Kept and printed escaped and bounded, whoever sent them.
        let (who, why) = (shown(&who), shown(&why));
        let by =
            if why.is_empty() { format!("revoked by {who}") } else { format!("revoked by {who}: {why}") };
        let unix_ms = self.unix_ms(now);
        self.revoked.push(RevokedSummary { robot: id, who, why, unix_ms, dropped: 0 });
        self.watch_stop(id);
        // A stop `now` under way no longer awaits it: its answer would be
        // dropped.
        self.gone_while_stopping(id);
        self.late.retain(|&late| late != id);
        if let Some(tick) = self.tick.as_mut() {
            tick.awaiting.remove(&id);
            if tick.pose_of == Some(id) {
                tick.pose_of = None;
            }
        }
        let Some(slot) = self.slot(id) else { return };
        let running = slot.alive;
        slot.alive = false;
        if slot.death.is_none() {
            slot.death = Some(Death { reason: by.clone(), noticed_unix_ms: unix_ms });
        }
        match slot.state {
            SlotState::Moving => self.queue.push_back(Pending::Died(id)),
            SlotState::Stuck | SlotState::Arrived | SlotState::Died | SlotState::Unfinished => {}
            _ => self.set_state(id, SlotState::Lost),
        }
        if running {
            // Stopped first (a gateway sends its robot the stop frame),
            // then told to end, as every agent is at the launch's end: the
            // agent source reaps it, and what it says meanwhile is dropped.
            self.outputs.push_back(Output::Send(id, ToAgent::Stop));
            self.outputs.push_back(Output::Send(id, ToAgent::Shutdown));
        }
        let told = if running { "told to stop and to end" } else { "its agent was not running" };
        self.note(format!("robot {id}: {by}; {told}; its reports are dropped from now on"));
        self.event(id, EventKind::Revoked, None, Some(by));
    }

    /// Whether robot `id` was revoked.
    pub(super) fn is_revoked(&self, id: u32) -> bool {
        self.revoked.iter().any(|r| r.robot == id)
    }

    /// The robots revoked so far, in the order they were, each with the
    /// reports of it dropped since.
    pub fn revoked(&self) -> &[RevokedSummary] {
        &self.revoked
    }

    /// Whether `input` is about a revoked robot, and so changes nothing:
    /// a report is counted as dropped (a `Register` is also refused), what
    /// its agent source says of it is ignored. Poses go on to the dead
    /// robot's rule (ignored, not counted: the launch's own relays of a
    /// beacon come back on its topic).
    pub(super) fn revoked_drops(&mut self, input: &Input) -> bool {
        let id = match input {
            Input::Report(msg) => msg.robot().0,
            Input::Started { robot, .. } => *robot,
            Input::Gone(id, _) | Input::Said(id, _) | Input::Token(id, _) => *id,
            _ => return false,
        };
        let Some(record) = self.revoked.iter_mut().find(|r| r.robot == id) else { return false };
        if let Input::Report(msg) = input {
            record.dropped += 1;
            if let FromAgent::Register(r) = msg {
                self.refuse(id, r.instance, Refusal::Revoked);
            }
        }
        true
    }
}
