//! The deadline and re-send timer of a wait for answers (a tick's, a start
//! pose's), in launch time.
//!
//! Why a timer of its own: across hosts a link drops for a moment and what
//! was in flight is gone. The deadline must not run while an awaited agent
//! is known to be unreachable (it is held, see the core's partition rules),
//! and what is unanswered is sent again so that a lost message costs one
//! re-send, not a whole timeout.
//!
//! Why the first re-send comes after a few answer times and not after a
//! second: on a lossy bus (`[faults] drop`) a lockstep launch loses an
//! answer every few ticks, and a tick takes a fraction of a millisecond; at
//! one second per loss a run of 0.15 s took 114 s. So, as TCP times its
//! retransmissions, [`AnswerTime`] keeps a smoothed answer time and its
//! deviation from the waits that needed no re-send, the first re-send of a
//! wait comes after twice that time and four deviations (at least
//! [`MIN_RESEND_US`]), the next few as often, and each further one after
//! twice as long as the one before, up to [`RESEND_US`]: a partition (answers missing for seconds,
//! zenoh closing a dead transport late) is re-sent once a second, as
//! before. A re-send that was not needed costs only messages: agents answer
//! a repeated `Tick` without stepping and a repeated `Deploy` with their
//! pose.

/// The longest time between two re-sends of what is still unanswered, µs.
pub const RESEND_US: u64 = 1_000_000;

/// The shortest time before a first re-send, µs.
pub const MIN_RESEND_US: u64 = 2_000;

/// The time before a first re-send until answers were timed, µs.
pub const FIRST_RESEND_US: u64 = 100_000;

/// Re-sends of a wait that come at its first interval before the interval
/// doubles: on a lossy bus a re-send is lost as often as the first send,
/// and doubling at once made a loss of 30 % cost tens of milliseconds each.
const STEADY_RESENDS: u32 = 3;

/// A wait of `timeout_us` for answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AnswerWait {
    timeout_us: u64,
    since: u64,
    deadline: u64,
    resend_at: u64,
    interval_us: u64,
    resent: u32,
}

impl AnswerWait {
    /// A wait of `timeout_us` from `now`, re-sending first after `first_us`.
    pub fn new(now: u64, timeout_us: u64, first_us: u64) -> Self {
        let interval_us = first_us.clamp(MIN_RESEND_US, RESEND_US);
        Self {
            timeout_us,
            since: now,
            deadline: now.saturating_add(timeout_us),
            resend_at: now.saturating_add(interval_us),
            interval_us,
            resent: 0,
        }
    }

    /// A wait of `timeout_us` from `now` that never re-sends: for agents
    /// whose messages are never lost on the way (a bus on this host).
    pub fn without_resends(now: u64, timeout_us: u64) -> Self {
        Self { resend_at: u64::MAX, interval_us: RESEND_US, ..Self::new(now, timeout_us, RESEND_US) }
    }

    /// At `now`, with `held` when an awaited agent is unreachable (the
    /// deadline restarts, and re-sends come once a second): whether to
    /// re-send now.
    pub fn resend_due(&mut self, now: u64, held: bool) -> bool {
        if held {
            self.deadline = now.saturating_add(self.timeout_us);
            self.interval_us = RESEND_US;
        }
        let due = now >= self.resend_at;
        if due {
            self.resent = self.resent.saturating_add(1);
            if self.resent >= STEADY_RESENDS {
                self.interval_us = self.interval_us.saturating_mul(2).min(RESEND_US);
            }
            self.resend_at = now.saturating_add(self.interval_us);
        }
        due
    }

    /// Whether the deadline has passed at `now`.
    pub fn expired(&self, now: u64) -> bool {
        now >= self.deadline
    }

    /// The next moment something is due.
    pub fn next_due(&self) -> u64 {
        self.deadline.min(self.resend_at)
    }

    /// When the wait began, µs of launch time.
    pub fn since(&self) -> u64 {
        self.since
    }

    /// Times what it waits for was sent again.
    pub fn resent(&self) -> u32 {
        self.resent
    }
}

/// How long answers take: a smoothed time and its deviation (RFC 6298's
/// estimator), from waits answered without a re-send (after one, which
/// sending an answer answers is not known). A wait that needed a re-send
/// doubles the next wait's first re-send, until a wait without one is timed
/// again (RFC 6298's back-off): else answers that became slower would never
/// be timed, every wait re-sending before its answer came.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AnswerTime {
    smoothed_us: Option<u64>,
    deviation_us: u64,
    backoff: u32,
}

impl AnswerTime {
    /// `wait` was answered in full at `now`.
    pub fn answered(&mut self, wait: &AnswerWait, now: u64) {
        if wait.resent > 0 {
            self.backoff = (self.backoff + 1).min(MAX_BACKOFF);
            return;
        }
        self.backoff = 0;
        let took = now.saturating_sub(wait.since);
        match self.smoothed_us {
            None => {
                self.smoothed_us = Some(took);
                self.deviation_us = took / 2;
            }
            Some(s) => {
                self.deviation_us = (3 * self.deviation_us + s.abs_diff(took)) / 4;
                self.smoothed_us = Some((7 * s + took) / 8);
            }
        }
    }

    /// When a wait re-sends first: after twice the smoothed answer time and
    /// four deviations (answers that always take about as long still vary
    /// by a fraction of that), doubled for each wait in a row that needed a
    /// re-send; [`FIRST_RESEND_US`] until answers were timed.
    pub fn first_resend_us(&self) -> u64 {
        let first = |s: u64| s.saturating_mul(2).saturating_add(4 * self.deviation_us).max(MIN_RESEND_US);
        let base = self.smoothed_us.map_or(FIRST_RESEND_US, first);
        base.saturating_mul(1 << self.backoff).min(RESEND_US)
    }
}

/// Doublings of the first re-send at most. One is enough for answers that
/// became slower to be timed again (in the launch harness's 10 000 seeded
/// schedules, answer times spread from 0.1 to 100 ms, none re-sends more
/// than its bound; with none, they re-send spuriously for ever), and each
/// more doubles what a loss costs on a very lossy bus, where most waits
/// need a re-send (the default launch with `[faults] drop = 0.3`, debug
/// build: 18 s with one, 25 s with two; 0.5 s without faults).
const MAX_BACKOFF: u32 = 1;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_deadline_waits_while_held_and_resends_back_off_to_every_second() {
        let mut w = AnswerWait::new(0, 3_000_000, 100_000);
        assert!(!w.resend_due(99_999, false));
        assert!(w.resend_due(100_000, false), "first after 100 ms");
        assert!(w.resend_due(200_000, false), "the next few as often");
        assert!(w.resend_due(300_000, false));
        assert!(!w.resend_due(499_999, false));
        assert!(w.resend_due(500_000, false), "then twice as late");
        assert!(w.resend_due(900_000, false));
        assert!(w.resend_due(1_700_000, false));
        assert!(!w.resend_due(2_500_000, true), "held at 2.5 s: deadline moves to 5.5 s");
        assert!(w.resend_due(2_700_000, true), "every second");
        assert!(!w.expired(5_699_999));
        assert!(w.expired(5_700_000));
        assert_eq!(w.next_due(), 3_700_000);
        assert_eq!(w.resent(), 7);
    }

    #[test]
    fn the_first_resend_follows_the_answer_times_of_waits_without_resends() {
        let mut t = AnswerTime::default();
        assert_eq!(t.first_resend_us(), FIRST_RESEND_US, "nothing timed yet");
        for at in 0..20u64 {
            let w = AnswerWait::new(at * 1_000, 5_000_000, t.first_resend_us());
            t.answered(&w, at * 1_000 + 300);
        }
        assert_eq!(t.first_resend_us(), MIN_RESEND_US, "0.3 ms answers: the shortest first re-send");
        let mut resent = AnswerWait::new(0, 5_000_000, t.first_resend_us());
        assert!(resent.resend_due(MIN_RESEND_US, false));
        t.answered(&resent, 900_000);
        assert_eq!(t.first_resend_us(), 2 * MIN_RESEND_US, "a wait with a re-send times nothing, backs off");
        for at in 0..20u64 {
            let w = AnswerWait::new(at * 100_000, 5_000_000, t.first_resend_us());
            t.answered(&w, at * 100_000 + 20_000);
        }
        let first = t.first_resend_us();
        assert!((40_000..60_000).contains(&first), "20 ms answers: {first} µs");
    }

    #[test]
    fn a_wait_without_re_sends_has_only_its_deadline() {
        let mut w = AnswerWait::without_resends(0, 5_000_000);
        assert!(!w.resend_due(4_999_999, false), "never re-sent");
        assert_eq!(w.next_due(), 5_000_000, "only its deadline is due");
        assert!(!w.expired(4_999_999));
        assert!(w.expired(5_000_000));
        assert_eq!(w.resent(), 0);
    }
}
