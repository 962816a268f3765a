//! A stop asked from outside the launch: `orchestrator stop` from another
//! terminal or host, or the ROS 2 stop service (issue 34, issue 32).
//!
//! Why one rule in the core: every way to stop a launch must do the same
//! thing, in the same order, and be tested in virtual time. A graceful stop
//! is Ctrl-C asked from elsewhere: the launch ends (outcome `interrupted`)
//! and the driver winds the agents down with `Shutdown`. A stop `now` first
//! tells every robot whose agent runs `Stop` (a simulated agent stays put,
//! a gateway sends its robot the link's stop frame), all in the same
//! `advance`, then ends the same way. Either records who asked and why
//! ([`LaunchCore::stopped`]: the summary's `stop`, an event per robot told).
//! The first stop asked wins; a later one changes nothing.
//!
//! A robot counts as stopped once its agent says so (`StopDone`: a
//! simulated robot stands still, a gateway sent its robot the link's stop
//! frame). Until every robot told has answered, or [`STOP_WAIT_US`] has
//! passed, the launch decides nothing else and sends `Stop` again to the
//! silent ones on the re-send timer of every wait (`wait.rs`): a `Stop`
//! lost on the bus costs one re-send. Then it ends, the answers (who, how
//! long after, on a robot link or not) and the silent ones in the record.
//! An agent that ends meanwhile is counted silent (its robot is stopped
//! by its own failsafe, not by this stop); its death is recorded but
//! decides nothing: no fault, no new start, no gate verdict (a robot that
//! was moving ends `unfinished`, as every moving robot of a stopped
//! launch does). A robot revoked meanwhile is counted silent too.

use super::stopping::{Stopping, STOP_RESEND_US};
use super::*;
use crate::records::StopAnswer;

/// The longest `who` or `why` a launch keeps, in characters: a sentence
/// for the summary, not a document (120 kB of it went raw into the
/// operators' terminals); `stop --why` and `revoke --why` refuse more.
pub const MAX_WHY_CHARS: usize = 200;

/// Who asked and why, as a launch keeps and prints them: a foreign client
/// may send anything, so control characters are escaped and the text is
/// cut at [`MAX_WHY_CHARS`] (the runtime's one rule,
/// [`bycoms_runtime::words::printable`]); printable text stays as it is.
pub fn shown(text: &str) -> String {
    bycoms_runtime::words::printable(text, MAX_WHY_CHARS)
}

impl LaunchCore {
    /// Books a stop (the first one asked).
    pub(super) fn on_stop(&mut self, now: u64, stop: Stop) {
        if self.stop.is_none() {
            let Stop { now: at_once, who, why } = stop;
            // Kept and printed escaped and bounded, whoever sent them.
            self.stop = Some(StopSummary {
                now: at_once,
                who: shown(&who),
                why: shown(&why),
                unix_ms: self.unix_ms(now),
                told: Vec::new(),
                answered: Vec::new(),
                unanswered: Vec::new(),
            });
        }
    }

    /// Whether a stop was asked and the launch has not ended yet.
    pub(super) fn stop_due(&self) -> bool {
        self.stop.is_some() && self.ending.is_none()
    }

    /// The stop asked, once it was (who, why, the robots told `Stop`).
    pub fn stopped(&self) -> Option<&StopSummary> {
        self.stop.as_ref()
    }

    /// Carries out the stop asked at `now`: `Stop` to every running robot
    /// when it is `now` (then their answers are awaited), else the launch
    /// ends as interrupted at once.
    pub(super) fn stop_all(&mut self, now: u64) {
        let Some(mut stop) = self.stop.take() else { return };
        let by = if stop.why.is_empty() {
            format!("stopped by {}", stop.who)
        } else {
            format!("stopped by {}: {}", stop.who, stop.why)
        };
        if !stop.now {
            self.note(format!("{by}; the launch winds down"));
            self.stop = Some(stop);
            return self.end(Outcome::Interrupted, None);
        }
        let running: Vec<u32> = self.slots.iter().filter(|s| s.alive).map(|s| s.id).collect();
        for &id in &running {
            self.outputs.push_back(Output::Send(id, ToAgent::Stop));
            self.event(id, EventKind::Stopped, None, Some(by.clone()));
        }
        self.note(format!("{by}; every running robot was told to stop ({})", running.len()));
        stop.told = running.clone();
        self.stop = Some(stop);
        // Nothing else is decided while the answers are awaited (`advance`
        // returns before the tick; a tick in flight stays, so the poses it
        // still brings are judged against it, not refused as from the
        // future).
        let wait = AnswerWait::new(now, STOP_WAIT_US, STOP_RESEND_US);
        self.stopping = Some(Stopping { wait, awaiting: running.into_iter().collect() });
        self.stop_answers(now);
    }

    /// A stop `now` under way at `now`: `Stop` again to the silent robots
    /// when due, the end once every robot answered or the wait is over.
    /// Whether one is under way (then nothing else is decided).
    pub(super) fn stop_answers(&mut self, now: u64) -> bool {
        let Some(stopping) = self.stopping.as_mut() else { return false };
        if !stopping.awaiting.is_empty() && !stopping.wait.expired(now) {
            if stopping.wait.resend_due(now, false) {
                let silent: Vec<u32> = stopping.awaiting.iter().copied().collect();
                self.outputs.extend(silent.into_iter().map(|id| Output::Send(id, ToAgent::Stop)));
            }
            return true;
        }
        self.close_stop();
        if let Some(stop) = self.stop.as_ref() {
            let (answered, silent) = (stop.answered.len(), &stop.unanswered);
            let text = match silent.is_empty() {
                true => format!("every robot told answered that it stopped ({answered})"),
                false => format!("{answered} robots answered that they stopped; robots {silent:?} did not"),
            };
            self.note(text);
        }
        self.end(Outcome::Interrupted, None);
        true
    }

    /// Ends the wait of a stop `now` under way (its answers in, or the
    /// launch ending for another reason): the robots still awaited are
    /// named silent.
    pub(super) fn close_stop(&mut self) {
        let (Some(stopping), Some(stop)) = (self.stopping.take(), self.stop.as_mut()) else { return };
        stop.unanswered.extend(stopping.awaiting);
        stop.unanswered.sort_unstable();
    }

    /// Robot `id` answered `Stop` at `now`.
    pub(super) fn on_stop_done(&mut self, now: u64, id: u32, on_link: bool) {
        let Some(stopping) = self.stopping.as_mut() else { return };
        if !stopping.awaiting.remove(&id) {
            return;
        }
        let after_us = now.saturating_sub(stopping.wait.since());
        if let Some(stop) = self.stop.as_mut() {
            stop.answered.push(StopAnswer { robot: id, after_us, on_link });
        }
    }

    /// Robot `id`'s agent ended (or was revoked) during a stop `now`: it
    /// answers no more (named silent). Whether a stop was under way: then
    /// its death is recorded but decides nothing (no fault, no new start).
    pub(super) fn gone_while_stopping(&mut self, id: u32) -> bool {
        let Some(stopping) = self.stopping.as_mut() else { return false };
        if stopping.awaiting.remove(&id) {
            if let Some(stop) = self.stop.as_mut() {
                stop.unanswered.push(id);
            }
        }
        true
    }

    /// When a stop under way is due again.
    pub(super) fn stop_due_at(&self) -> Option<u64> {
        self.stopping.as_ref().map(|s| s.wait.next_due())
    }
}
