use crate::core::*;
use crate::harness::{self, Case, Schedule};
use crate::status;
use bycoms_protocol::msg::{ClockOffset, FromAgent, Refusal, Register, ToAgent};
use bycoms_protocol::{RobotId, PROTOCOL_VERSION};

const LIMITS: ClockLimits = ClockLimits { warn_us: 100_000, limit_us: 500_000 };

/// A core with clock limits on whose robot 1's agent was started.
fn core() -> LaunchCore {
    let case = Case::small(3);
    let mut setup = harness::setup(&case, &Schedule::clean(3, case.robots));
    setup.clocks = LIMITS;
    let mut core = LaunchCore::new(setup);
    core.advance(0);
    while let Some(out) = core.poll() {
        if let Output::Start(robot) = out {
            core.handle(0, Input::Started { robot, pid: None, how: "started".into() });
        }
    }
    core.advance(0);
    while core.poll().is_some() {}
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
    std::iter::from_fn(|| core.poll()).collect()
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
    assert!(skewed.slots()[0].registered_before_tick().is_none(), "not registered");

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
    assert!(status::text(&shown).contains("clock +20.0 ms (round trip 0.8 ms)"), "{}", status::text(&shown));

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
        let out: Vec<Output> = std::iter::from_fn(|| core.poll()).collect();
        assert_eq!(refused(&out), None);
        notes += out.iter().filter(|o| matches!(o, Output::Note(n) if n.contains("+900.0 ms off"))).count();
    }
    assert_eq!(notes, 1);
    assert_eq!(core.slots()[0].clock().map(|c| c.at_us), Some(30_000_000));
}
