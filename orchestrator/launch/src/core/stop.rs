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
use crate::summary::StopAnswer;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::{self, Case, Schedule};
    use bycoms_protocol::msg::{RobotKind, StopDone};

    fn register(robot: u32) -> Input {
        Input::Report(FromAgent::Register(Register {
            robot: RobotId(robot),
            kind: RobotKind::Simulated,
            protocol_version: PROTOCOL_VERSION,
            instance: u64::from(robot),
            settings: 0,
            failsafe_grace_ms: 0,
        }))
    }

    fn done(robot: u32) -> Input {
        Input::Report(FromAgent::StopDone(StopDone { robot: RobotId(robot), on_link: false }))
    }

    /// The `Stop`s the core put out since the last call, by robot.
    fn stops(core: &mut LaunchCore) -> Vec<u32> {
        std::iter::from_fn(|| core.poll_output())
            .filter_map(|o| match o {
                Output::Send(id, ToAgent::Stop) => Some(id),
                _ => None,
            })
            .collect()
    }

    /// Three robots whose agents run (all started at once, as remote
    /// agents are), registered at 1 ms.
    fn running() -> LaunchCore {
        let case = Case { robots: 3, ..Case::small(3) };
        let mut schedule = Schedule::clean(3, case.robots);
        schedule.remote = true;
        let mut core = LaunchCore::new(harness::setup(&case, &schedule));
        core.advance(0);
        for id in 1..=3 {
            core.handle(0, Input::Started { robot: id, pid: None, how: "remote".into() });
            core.handle(1_000, register(id));
        }
        core.advance(1_000);
        stops(&mut core);
        core
    }

    fn stop_now() -> Input {
        Input::Stop(Stop { now: true, who: "me".into(), why: "a test".into() })
    }

    /// In virtual time: a stop `now` tells every running robot `Stop` at
    /// once, sends it again to the silent ones, ends the launch as soon as
    /// every robot answered, and records each answer with its time.
    #[test]
    fn a_stop_now_ends_once_every_robot_answered_and_re_sends_to_the_silent() {
        let mut core = running();
        core.handle(2_000, stop_now());
        core.advance(2_000);
        assert_eq!(stops(&mut core), [1, 2, 3], "told all at once");
        core.handle(2_400, done(2));
        core.advance(2_400);
        assert!(core.ending().is_none(), "robots 1 and 3 are awaited");
        let resend = core.deadline().expect("a re-send is due");
        assert!(resend > 2_400 && resend < 2_000 + STOP_WAIT_US, "{resend}");
        core.advance(resend);
        assert_eq!(stops(&mut core), [1, 3], "only the silent ones again");
        core.handle(resend + 100, done(1));
        core.handle(resend + 200, done(3));
        core.handle(resend + 300, done(3));
        core.advance(resend + 300);
        assert_eq!(core.ending().map(|e| e.outcome), Some(Outcome::Interrupted));
        let stop = core.stopped().expect("recorded");
        let answers: Vec<(u32, u64)> = stop.answered.iter().map(|a| (a.robot, a.after_us)).collect();
        assert_eq!(answers, [(2, 400), (1, resend + 100 - 2_000), (3, resend + 200 - 2_000)]);
        assert!(stop.unanswered.is_empty());
    }

    /// A robot that never answers is named silent once the wait is over; an
    /// agent that ends during the wait is named silent at once, its death
    /// recorded without a fault (the launch ends interrupted, not in error).
    #[test]
    fn the_silent_and_the_gone_are_named_and_the_wait_is_bounded() {
        let mut core = running();
        core.handle(2_000, stop_now());
        core.advance(2_000);
        stops(&mut core);
        core.handle(3_000, done(1));
        core.handle(4_000, Input::Gone(2, Gone::Exited(std::process::ExitStatus::default())));
        core.advance(4_000);
        assert!(core.ending().is_none(), "robot 3 is still awaited");
        let mut now = 4_000;
        while core.ending().is_none() {
            now = core.deadline().expect("the wait is bounded");
            assert!(now <= 2_000 + STOP_WAIT_US, "past the wait: {now}");
            core.advance(now);
        }
        assert_eq!(now, 2_000 + STOP_WAIT_US);
        assert_eq!(core.ending().map(|e| e.outcome), Some(Outcome::Interrupted));
        let stop = core.stopped().expect("recorded");
        assert_eq!(stop.unanswered, [2, 3]);
        assert_eq!(stop.answered.len(), 1);
        assert!(core.slots()[1].death().is_some(), "robot 2's death is recorded");
    }

    /// A robot revoked while a stop `now` awaits it is named silent at once
    /// (its answer would be dropped): the launch ends when the others have
    /// answered, not after the whole wait.
    #[test]
    fn a_robot_revoked_during_a_stop_is_not_awaited() {
        let mut core = running();
        core.handle(2_000, stop_now());
        core.advance(2_000);
        stops(&mut core);
        core.handle(3_000, Input::Revoke(Revoke { robot: 3, who: "me".into(), why: "stolen".into() }));
        core.handle(3_500, done(1));
        core.handle(4_000, done(2));
        core.advance(4_000);
        assert_eq!(core.ending().map(|e| e.outcome), Some(Outcome::Interrupted), "nobody else to await");
        assert_eq!(core.stopped().map(|s| s.unanswered.clone()), Some(vec![3]));
    }

    /// A foreign client's who and why (newlines, escapes, a bell, 120 kB)
    /// are kept, noted and recorded escaped and bounded; a revocation's too.
    #[test]
    fn who_and_why_from_a_foreign_client_are_escaped_and_bounded() {
        let mut core = running();
        let why = format!("line\n\u{1b}[2J\u{7}{}", "x".repeat(120_000));
        core.handle(2_000, Input::Stop(Stop { now: true, who: "evil\r\n".into(), why: why.clone() }));
        core.handle(2_000, Input::Revoke(Revoke { robot: 3, who: "evil".into(), why }));
        core.advance(2_000);
        let notes: Vec<String> = std::iter::from_fn(|| core.poll_output())
            .filter_map(|o| match o {
                Output::Note(text) => Some(text),
                Output::Event(e) => e.reason,
                _ => None,
            })
            .collect();
        assert!(
            notes.iter().any(|n| n.starts_with("stopped by evil\\r\\n: line\\n\\u{1b}[2J\\u{7}xx")),
            "{notes:?}"
        );
        for text in &notes {
            assert!(!text.chars().any(char::is_control) && text.len() < 1_000, "{text:?}");
        }
        let stop = core.stopped().expect("recorded");
        assert_eq!((stop.who.as_str(), stop.why.chars().count()), ("evil\\r\\n", MAX_WHY_CHARS));
        assert!(stop.why.ends_with("… (cut from 120010 characters)"), "{}", stop.why);
        assert!(!core.revoked()[0].why.chars().any(char::is_control));
    }
}
