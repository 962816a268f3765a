//! The deadline and re-send timer of a wait for answers (a tick's, a start
//! pose's), in launch time.
//!
//! Why a timer of its own: across hosts a link drops for a moment and what
//! was in flight is gone. The deadline must not run while an awaited agent
//! is known to be unreachable (it is held, see the core's partition rules),
//! and what is unanswered is sent again every [`RESEND_US`] so that a lost
//! message costs one re-send, not a whole timeout.

/// How often what is still unanswered is sent again, µs.
pub const RESEND_US: u64 = 1_000_000;

/// A wait of `timeout_us` for answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AnswerWait {
    timeout_us: u64,
    deadline: u64,
    resend_at: u64,
}

impl AnswerWait {
    /// A wait of `timeout_us` from `now`.
    pub fn new(now: u64, timeout_us: u64) -> Self {
        Self {
            timeout_us,
            deadline: now.saturating_add(timeout_us),
            resend_at: now.saturating_add(RESEND_US),
        }
    }

    /// At `now`, with `held` when an awaited agent is unreachable (the
    /// deadline restarts): whether to re-send now.
    pub fn resend_due(&mut self, now: u64, held: bool) -> bool {
        if held {
            self.deadline = now.saturating_add(self.timeout_us);
        }
        let due = now >= self.resend_at;
        if due {
            self.resend_at = now.saturating_add(RESEND_US);
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_deadline_waits_while_held_and_resends_come_every_second() {
        let mut w = AnswerWait::new(0, 3_000_000);
        assert!(!w.resend_due(999_999, false));
        assert!(w.resend_due(1_000_000, false));
        assert!(!w.resend_due(1_500_000, false));
        assert!(w.resend_due(2_500_000, true), "held at 2.5 s: deadline moves to 5.5 s");
        assert!(!w.expired(5_499_999));
        assert!(w.expired(5_500_000));
        assert_eq!(w.next_due(), 3_500_000);
    }
}
