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
    use crate::harness::{self, Case, Schedule};
    use crate::status;

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

    /// A core with clock limits on whose robot 1's agent was started.
    fn core() -> LaunchCore {
        let case = Case::small(3);
        let mut setup = harness::setup(&case, &Schedule::clean(3, case.robots));
        setup.clocks = LIMITS;
        let mut core = LaunchCore::new(setup);
        core.advance(0);
        while let Some(out) = core.poll_output() {
            if let Output::Start(robot) = out {
                core.handle(0, Input::Started { robot, pid: None, how: "started".into() });
            }
        }
        core.advance(0);
        while core.poll_output().is_some() {}
        core
    }

    fn register(core: &mut LaunchCore, now: u64, offset_us: Option<i64>) -> Vec<Output> {
        let robot = RobotId(1);
        if let Some(offset_us) = offset_us {
            let c = ClockOffset { robot, offset_us, round_trip_us: 800 };
            core.handle(now, Input::Report(FromAgent::Clock(c)));
        }
        let r = Register {
            robot,
            kind: bycoms_protocol::msg::RobotKind::Simulated,
            protocol_version: PROTOCOL_VERSION,
            instance: 7,
            settings: 0,
            failsafe_grace_ms: 0,
        };
        core.handle(now, Input::Report(FromAgent::Register(r)));
        std::iter::from_fn(|| core.poll_output()).collect()
    }

    fn refused(out: &[Output]) -> Option<Refusal> {
        out.iter().find_map(|o| match o {
            Output::Send(1, ToAgent::Refused(r)) => Some(r.why),
            _ => None,
        })
    }

    /// In virtual time: a host two seconds behind is refused at
    /// registration, one 20 ms ahead is taken and its offset shown by
    /// `status`, one 300 ms off is taken with a note, one that measured
    /// nothing is taken with its offset unknown.
    #[test]
    fn a_registration_is_judged_by_the_offset_reported_before_it() {
        let mut skewed = core();
        let out = register(&mut skewed, 1_000, Some(-2_000_000));
        assert_eq!(refused(&out), Some(Refusal::Clock { offset_ms: -2000, limit_ms: 500 }), "{out:?}");
        assert!(!out.iter().any(|o| matches!(o, Output::Heard(1))), "{out:?}");
        assert!(skewed.slots()[0].registered_before_tick.is_none(), "not registered");

        let mut fine = core();
        let out = register(&mut fine, 2_000_000, Some(20_000));
        assert_eq!(refused(&out), None, "{out:?}");
        assert!(out.iter().any(|o| matches!(o, Output::Heard(1))), "{out:?}");
        let reading = fine.slots()[0].clock();
        assert_eq!(reading, Some(ClockReading { offset_us: 20_000, round_trip_us: 800, at_us: 2_000_000 }));
        let facts = status::Facts {
            swarm: "lab".into(),
            clock: "realtime".into(),
            transport: "zenoh".into(),
            recording: None,
            pid: 1,
            uptime_s: 2.0,
        };
        let shown = status::of(&fine, 3_000_000, &facts);
        let clock = shown.robots[0].clock.expect("status shows the offset");
        assert_eq!((clock.offset_ms, clock.round_trip_ms), (20.0, 0.8));
        assert_eq!(clock.measured_unix_ms, fine.unix_ms(2_000_000));
        assert!(
            status::text(&shown).contains("clock +20.0 ms (round trip 0.8 ms)"),
            "{}",
            status::text(&shown)
        );

        let mut off = core();
        let out = register(&mut off, 1_000, Some(300_000));
        assert_eq!(refused(&out), None, "{out:?}");
        assert!(out.iter().any(|o| matches!(o, Output::Note(n) if n.contains("+300.0 ms off"))), "{out:?}");

        let mut unknown = core();
        let out = register(&mut unknown, 1_000, None);
        assert!(out.iter().any(|o| matches!(o, Output::Heard(1))), "{out:?}");
        assert_eq!(unknown.slots()[0].clock(), None);
    }

    /// A registered robot whose later measurement goes past the limit is
    /// noted once, not refused.
    #[test]
    fn a_later_offset_past_the_limit_is_noted_once() {
        let mut core = core();
        register(&mut core, 1_000, Some(1_000));
        let late = ClockOffset { robot: RobotId(1), offset_us: 900_000, round_trip_us: 500 };
        let mut notes = 0;
        for t in 1..=3 {
            core.handle(t * 10_000_000, Input::Report(FromAgent::Clock(late)));
            let out: Vec<Output> = std::iter::from_fn(|| core.poll_output()).collect();
            assert_eq!(refused(&out), None);
            notes +=
                out.iter().filter(|o| matches!(o, Output::Note(n) if n.contains("+900.0 ms off"))).count();
        }
        assert_eq!(notes, 1);
        assert_eq!(core.slots()[0].clock().map(|c| c.at_us), Some(30_000_000));
    }
}
