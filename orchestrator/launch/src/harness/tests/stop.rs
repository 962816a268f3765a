use crate::core::*;
use crate::harness::{self, Case, Schedule};
use crate::summary::Outcome;
use bycoms_protocol::msg::{FromAgent, Register, ToAgent};
use bycoms_protocol::msg::{RobotKind, StopDone};
use bycoms_protocol::{RobotId, PROTOCOL_VERSION};

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
    std::iter::from_fn(|| core.poll())
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
    let notes: Vec<String> = std::iter::from_fn(|| core.poll())
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
