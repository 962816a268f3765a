//! The agents' host clocks against the orchestrator's (issue 34): what a
//! measured offset means, decided here.
//!
//! Why in the core: a host whose clock is off by more than the limit is
//! refused at registration, like an agent of other settings, and that is
//! a rule of the launch, to be replayed and tested in virtual time. The
//! core measures nothing: an agent measures its own offset over zenoh
//! (`bus::zenoh::clock`) and reports it (`FromAgent::Clock`) before it
//! registers and every 10 s after; the core keeps the last one per robot
//! (the summary and `status` show it) and judges it against the limits of
//! its [`ClockLimits`] (from the config's `supervision.clock_warn` and
//! `supervision.clock_limit` via `setup.rs`; off over iceoryx2, where
//! every agent shares the orchestrator's clock). The judging arithmetic
//! ([`ClockLimits::judge`]) lives beside the measurement in
//! `bus::zenoh::clock`, so the doctors of the robots' hosts (`agent
//! doctor`, `sim-agent doctor`) judge an offset as the launch does.
//!
//! The rule: an offset past the limit refuses a registration
//! ([`Refusal::Clock`], whose text says how to fix the clock); past the
//! warning it is noted; an agent that reported no offset (an agent of an
//! older build, a foreign client) is taken, its offset unknown. A robot
//! already registered whose offset later goes past the limit is noted and
//! warned about, not refused: its robot may be moving.

use super::*;

/// The refusal of an agent whose host is `offset_us` off, past `limits`.
fn refusal(limits: &ClockLimits, offset_us: i64) -> Refusal {
    let ms = (offset_us / 1000).clamp(i64::from(i32::MIN), i64::from(i32::MAX));
    Refusal::Clock {
        offset_ms: ms as i32,
        limit_ms: u32::try_from(limits.limit_us / 1000).unwrap_or(u32::MAX),
    }
}

impl LaunchCore {
    /// Keeps robot `c.robot`'s reported offset, registered or not (it comes
    /// before the `Register` it is judged with); a registered robot's
    /// offset past the warning is noted when it first gets there.
    pub(super) fn on_clock(&mut self, now: u64, c: &ClockOffset) {
        let id = c.robot.0;
        let limits = self.setup.clocks;
        let Some(slot) = self.slot(id) else { return };
        let before = slot.clock.map(|r| limits.judge(r.offset_us));
        slot.clock =
            Some(ClockReading { offset_us: c.offset_us, round_trip_us: c.round_trip_us, at_us: now });
        let registered = slot.registered_before_tick.is_some();
        let verdict = limits.judge(c.offset_us);
        if registered && verdict != ClockVerdict::Fine && before != Some(verdict) {
            let ms = c.offset_us as f64 / 1000.0;
            let text = format!(
                "robot {id}: its host's clock is {ms:+.1} ms off the orchestrator's (warning past {} ms, limit {} ms); synchronise it (chrony)",
                limits.warn_us / 1000,
                limits.limit_us / 1000
            );
            tracing::warn!(robot = id, offset_ms = ms, "{text}");
            self.note(text);
        }
    }

    /// Why robot `id`'s first `Register` is refused for its clock, if it is
    /// (see the module doc); a registration past the warning is noted.
    pub(super) fn clock_refusal(&mut self, id: u32) -> Option<Refusal> {
        let limits = self.setup.clocks;
        let reading = self.slot_ref(id).and_then(|s| s.clock)?;
        match limits.judge(reading.offset_us) {
            ClockVerdict::Fine => None,
            ClockVerdict::Refuse => Some(refusal(&limits, reading.offset_us)),
            ClockVerdict::Warn => {
                let ms = reading.offset_us as f64 / 1000.0;
                let warn = limits.warn_us / 1000;
                let text = format!("robot {id}: its host's clock is {ms:+.1} ms off the orchestrator's (past {warn} ms); synchronise it (chrony)");
                tracing::warn!(robot = id, offset_ms = ms, "{text}");
                self.note(text);
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: ClockLimits = ClockLimits { warn_us: 100_000, limit_us: 500_000 };

    #[test]
    fn a_refusal_says_how_far_which_way_and_how_to_fix_it() {
        let why = refusal(&LIMITS, -2_000_400);
        assert_eq!(why, Refusal::Clock { offset_ms: -2000, limit_ms: 500 });
        let text = why.to_string();
        assert!(text.contains("2000 ms behind the orchestrator's"), "{text}");
        assert!(text.contains("limit of 500 ms") && text.contains("chrony"), "{text}");
        let ahead = refusal(&LIMITS, i64::MAX).to_string();
        assert!(ahead.contains("ahead of"), "{ahead}");
    }
}
