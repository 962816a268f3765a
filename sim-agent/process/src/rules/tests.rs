//! The message rules in virtual time, without a bus: heartbeats at their
//! two rates, `Register` repeated until heard from, a tick stepped once (a
//! run of them answered once),
//! real-time periods numbered by the clock, refusals of this instance only.

use super::*;
use bycoms_protocol::msg::{GoalBearing, Refused, Tick, Ticks};
use bycoms_sim::terrain::Terrain;
use bycoms_sim::RunConfig;

const MS: u64 = 1_000;

fn core(clock: Clock) -> SimAgentCore {
    let rules = Rules {
        clock,
        dt_us: 100 * MS,
        period_us: 20 * MS,
        heartbeat_us: 100 * MS,
        parked_heartbeat_us: 500 * MS,
        instance: 7,
        settings: 0x5e7,
        failsafe_grace_ms: 0,
    };
    SimAgentCore::new(RobotCore::new(RobotId(1), Terrain::paper(), RunConfig::paper(2.0)), rules)
}

fn reports(said: &[Said]) -> Vec<&'static str> {
    said.iter()
        .map(|s| match s {
            Said::Report(FromAgent::Register(_)) => "register",
            Said::Report(FromAgent::Heartbeat(_)) => "heartbeat",
            Said::Report(FromAgent::Status(_)) => "status",
            Said::Report(FromAgent::TickDone(_)) => "done",
            Said::Report(FromAgent::Parked(_)) => "parked",
            Said::Report(FromAgent::StopDone(d)) if !d.on_link => "stop done",
            Said::Report(_) => "other",
            Said::Pose(_) => "pose",
            Said::Refused(_) => "refused",
        })
        .collect()
}

/// Drives `a` as its shells do: a call, then everything it said polled
/// into `out`.
fn said(a: &mut SimAgentCore, out: &mut Vec<Said>) {
    out.extend(std::iter::from_fn(|| a.poll()));
}

fn start(a: &mut SimAgentCore, now: Micros, out: &mut Vec<Said>) {
    a.start(now);
    said(a, out);
}

fn advance(a: &mut SimAgentCore, now: Micros, out: &mut Vec<Said>) {
    a.advance(now);
    said(a, out);
}

fn period_if_due(a: &mut SimAgentCore, now: Micros, out: &mut Vec<Said>) -> bool {
    let ran = a.period_if_due(now);
    said(a, out);
    ran
}

/// A command (its rules do not depend on the time: 0).
fn handle(a: &mut SimAgentCore, cmd: &ToAgent, out: &mut Vec<Said>) -> Option<Leave> {
    let leave = a.handle(0, cmd);
    said(a, out);
    leave
}

fn deploy() -> ToAgent {
    ToAgent::Deploy(Deploy { robot: RobotId(1), x: 15.5, y: 15.5, heading: 0.7 })
}

#[test]
fn registers_with_every_beat_until_heard_then_beats_slower_once_parked() {
    let mut a = core(Clock::Lockstep);
    assert_eq!(a.deadline(), None, "nothing before it starts");
    let mut out = Vec::new();
    start(&mut a, 0, &mut out);
    assert_eq!(reports(&out), ["register", "heartbeat"]);
    assert_eq!(a.deadline(), Some(100 * MS));
    out.clear();
    advance(&mut a, 99 * MS, &mut out);
    assert!(out.is_empty(), "nothing before the beat is due: {out:?}");
    advance(&mut a, 100 * MS, &mut out);
    assert_eq!(reports(&out), ["register", "heartbeat"], "unheard: the Register again");
    out.clear();
    assert_eq!(handle(&mut a, &deploy(), &mut out), None);
    assert_eq!(reports(&out), ["pose", "status"]);
    out.clear();
    advance(&mut a, 200 * MS, &mut out);
    assert_eq!(reports(&out), ["heartbeat"], "heard: no more Register");
    assert_eq!(a.deadline(), Some(300 * MS), "a moving robot beats every 100 ms");
    out.clear();
    handle(&mut a, &ToAgent::Stop, &mut out);
    assert_eq!(reports(&out), ["stop done"], "a Stop is answered at once");
    handle(&mut a, &ToAgent::Stop, &mut out);
    assert_eq!(reports(&out), ["stop done", "stop done"], "and again when re-sent");
    advance(&mut a, 300 * MS, &mut out);
    assert_eq!(a.deadline(), Some(800 * MS), "a parked one every 500 ms");
}

#[test]
fn registers_with_its_instance_settings_and_failsafe() {
    let mut a = core(Clock::Lockstep);
    a.set_settings(0xfeed);
    a.set_failsafe_grace_ms(3_000);
    let mut out = Vec::new();
    start(&mut a, 0, &mut out);
    let Said::Report(FromAgent::Register(r)) = &out[0] else { panic!("a register first: {out:?}") };
    assert_eq!((r.robot, r.instance, r.settings, r.failsafe_grace_ms), (RobotId(1), 7, 0xfeed, 3_000));
}

#[test]
fn a_tick_is_stepped_once_and_a_repeat_answered_again() {
    let mut a = core(Clock::Lockstep);
    let mut out = Vec::new();
    start(&mut a, 0, &mut out);
    handle(&mut a, &deploy(), &mut out);
    out.clear();
    let bearing = |step| ToAgent::GoalBearing(GoalBearing { robot: RobotId(1), bearing: 0.7, step });
    handle(&mut a, &bearing(1), &mut out);
    handle(&mut a, &ToAgent::Tick(Tick { step: 1 }), &mut out);
    assert_eq!(reports(&out), ["pose", "status", "done"]);
    let first = out[0].clone();
    out.clear();
    handle(&mut a, &ToAgent::Tick(Tick { step: 1 }), &mut out);
    assert_eq!(reports(&out), ["pose", "done"], "a repeat: answered, not stepped");
    assert_eq!(out[0], first);
    assert_eq!(a.robot().steps(), 1);
    out.clear();
    handle(&mut a, &ToAgent::Tick(Tick { step: 2 }), &mut out);
    assert_eq!(a.counts().stale_bearings, 1, "tick 2 came with the bearing of tick 1");
    out.clear();
    handle(&mut a, &ToAgent::Stop, &mut out);
    assert_eq!(reports(&out), ["stop done"], "lockstep answers a Stop at once too, not with a tick");
    out.clear();
    handle(&mut a, &ToAgent::Tick(Tick { step: 3 }), &mut out);
    assert_eq!(reports(&out), ["pose", "parked", "done"]);
}

/// A run of ticks steps each period as a `Tick` would (the same poses, a
/// status each), answers once for its first step, is answered again
/// without stepping when repeated, and stops where the robot parks.
#[test]
fn a_run_of_ticks_steps_as_ticks_do_and_answers_once() {
    let started = || {
        let mut a = core(Clock::Lockstep);
        let mut out = Vec::new();
        start(&mut a, 0, &mut out);
        handle(&mut a, &deploy(), &mut out);
        handle(
            &mut a,
            &ToAgent::GoalBearing(GoalBearing { robot: RobotId(1), bearing: 0.7, step: 1 }),
            &mut out,
        );
        a
    };
    let (mut ticked, mut ran) = (started(), started());
    let (mut one, mut out) = (Vec::new(), Vec::new());
    for step in 1..=5 {
        handle(&mut ticked, &ToAgent::Tick(Tick { step }), &mut one);
    }
    handle(&mut ran, &ToAgent::Ticks(Ticks { step: 1, count: 5 }), &mut out);
    let poses =
        |said: &[Said]| said.iter().filter(|s| matches!(s, Said::Pose(_))).cloned().collect::<Vec<_>>();
    assert_eq!(poses(&out), poses(&one), "the same five poses, bit for bit");
    let modes = |said: &[Said]| {
        let mut last = 1;
        let mut seen = Vec::new();
        for s in said {
            if let Said::Report(FromAgent::Status(st)) = s {
                seen.push((st.step, st.mode != last));
                last = st.mode;
            }
        }
        seen
    };
    let changed: Vec<u64> = modes(&one).iter().filter(|m| m.1).map(|m| m.0).collect();
    assert_eq!(
        modes(&out).iter().map(|m| m.0).collect::<Vec<_>>(),
        changed,
        "a status only when the mode changed"
    );
    assert_eq!(reports(&out).last(), Some(&"done"));
    assert_eq!(out.last(), Some(&Said::Report(FromAgent::TickDone(TickDone { robot: RobotId(1), step: 1 }))));
    assert_eq!(ran.counts(), ticked.counts(), "stale bearings counted per period");
    assert_eq!(ran.counts().stale_bearings, 4, "periods 2 to 5 on the bearing of period 1");
    out.clear();
    handle(&mut ran, &ToAgent::Ticks(Ticks { step: 1, count: 5 }), &mut out);
    assert_eq!(reports(&out), ["done"], "a repeat: answered, not stepped");
    assert_eq!(ran.robot().steps(), 5);
    out.clear();
    handle(&mut ran, &ToAgent::Stop, &mut out);
    out.clear();
    handle(&mut ran, &ToAgent::Ticks(Ticks { step: 6, count: 4 }), &mut out);
    assert_eq!(reports(&out), ["pose", "parked", "done"], "parked: stops at its first period");
    let parked = Parked { robot: RobotId(1), step: 6 };
    assert_eq!(out[1], Said::Report(FromAgent::Parked(parked)));
    let mut real = core(Clock::Realtime);
    handle(&mut real, &ToAgent::Ticks(Ticks { step: 1, count: 2 }), &mut out);
    assert_eq!(out.last(), Some(&Said::Refused(Reject::TickInRealTime)));
}

#[test]
fn real_time_periods_follow_the_clock_and_late_ones_are_missed() {
    let mut a = core(Clock::Realtime);
    let mut out = Vec::new();
    start(&mut a, 0, &mut out);
    // Not deployed: no periods, only heartbeats (its timer is the beat's).
    assert_eq!(a.next_period(), None);
    assert_eq!(a.deadline(), Some(100 * MS));
    out.clear();
    advance(&mut a, 100 * MS, &mut out);
    assert_eq!(reports(&out), ["register", "heartbeat"], "no period before the Deploy: {out:?}");
    assert_eq!(a.counts(), Counts::default());
    // Deployed at 0.9 s: the start pose is period 0, its clock starts at
    // the next time it is given (due at once).
    advance(&mut a, 900 * MS, &mut out);
    out.clear();
    handle(&mut a, &deploy(), &mut out);
    assert!(matches!(out[0], Said::Pose(Pose { step: 0, time_us: 0, .. })), "{out:?}");
    handle(&mut a, &ToAgent::GoalBearing(GoalBearing { robot: RobotId(1), bearing: 0.7, step: 0 }), &mut out);
    assert_eq!(a.next_period(), Some(900 * MS), "due at once: the clock starts");
    let t0 = 901 * MS;
    out.clear();
    assert!(!period_if_due(&mut a, t0, &mut out), "the clock starts, no period yet");
    assert!(out.is_empty(), "{out:?}");
    assert_eq!(a.next_period(), Some(t0 + 20_000));
    assert!(!period_if_due(&mut a, t0 + 19_999, &mut out));
    assert!(period_if_due(&mut a, t0 + 20_000, &mut out));
    assert!(matches!(out[0], Said::Pose(Pose { step: 1, .. })), "{out:?}");
    out.clear();
    // Late by two periods: period 4 runs, 2 and 3 are missed.
    assert!(period_if_due(&mut a, t0 + 4 * 20_000 + 5, &mut out));
    assert!(matches!(out[0], Said::Pose(Pose { step: 4, .. })), "{out:?}");
    assert_eq!(a.counts(), Counts { periods: 2, missed: 2, stale_bearings: 0 });
    assert_eq!(a.next_period(), Some(t0 + 5 * 20_000));
    out.clear();
    handle(&mut a, &ToAgent::Tick(Tick { step: 9 }), &mut out);
    assert_eq!(out, [Said::Refused(Reject::TickInRealTime)]);
}

#[test]
fn only_a_refusal_of_this_instance_makes_it_leave() {
    let mut a = core(Clock::Lockstep);
    let mut out = Vec::new();
    let refused = |instance| {
        ToAgent::Refused(Refused {
            robot: RobotId(1),
            instance,
            why: bycoms_protocol::msg::Refusal::Duplicate,
        })
    };
    assert_eq!(handle(&mut a, &refused(8), &mut out), None);
    assert_eq!(handle(&mut a, &refused(7), &mut out), Some(Leave::Refused));
    assert_eq!(handle(&mut a, &ToAgent::Shutdown, &mut out), Some(Leave::Shutdown));
    handle(&mut a, &deploy(), &mut out);
    out.clear();
    handle(&mut a, &ToAgent::Deploy(Deploy { robot: RobotId(1), x: 1.5, y: 1.5, heading: 0.0 }), &mut out);
    assert_eq!(out, [Said::Refused(Reject::AlreadyDeployed)], "another Deploy is refused");
}
