//! The gateway's bus-side rules with a hand-driven clock: no bus, no socket.

use super::*;
use crate::gateway::core::Timers;
use bycoms_protocol::link::LinkKey;
use bycoms_protocol::msg::{Refusal, Refused as RefusedMsg};
use bycoms_protocol::RobotId;
use bycoms_runtime::failsafe::OnOrchestratorLost;

const BEAT: Duration = Duration::from_millis(100);
const BEAT_US: Micros = 100_000;

fn session(t0: Micros, failsafe: Option<Failsafe>) -> Session {
    let core = GatewayCore::new(RobotId(3), LinkKey::new(&[7; 32]), Timers::paper(1.0), 1, t0);
    Session::new(core, BEAT, 77, failsafe)
}

fn reports(s: &mut Session) -> Vec<FromAgent> {
    std::iter::from_fn(|| s.poll())
        .filter_map(|o| match o {
            Output::Report(r) => Some(r),
            Output::Datagram(..) => None,
        })
        .collect()
}

/// `n` ms, in the core's µs.
fn ms(n: u64) -> Micros {
    n * 1000
}

fn start(s: &mut Session, now: Micros) {
    s.handle(now, Input::Start).expect("a start is taken");
}

/// Advances to `now`: why the session ended, if it did.
fn advance(s: &mut Session, now: Micros) -> Option<ExitCause> {
    s.advance(now);
    s.exit()
}

/// One command at `now`: why the session ended, if it did, or the refusal.
fn command(s: &mut Session, cmd: &ToAgent, now: Micros) -> Result<Option<ExitCause>, Rejected> {
    s.handle(now, Input::Command(cmd))?;
    Ok(s.exit())
}

fn orchestrator(s: &mut Session, alive: bool, at: Micros) {
    s.handle(at, Input::Orchestrator { alive }).expect("liveliness is taken");
}

#[test]
fn registers_again_with_each_heartbeat_until_the_orchestrator_speaks() {
    let t0: Micros = 0;
    let mut s = session(t0, None);
    assert_eq!(s.deadline(), None, "nothing is due before the start");
    start(&mut s, t0);
    assert!(advance(&mut s, t0).is_none());
    let first = reports(&mut s);
    assert!(
        matches!(first[..], [FromAgent::Register(r), FromAgent::Heartbeat(h)] if r.robot == RobotId(3) && r.instance == 77 && h.seq == 1)
    );
    assert_eq!(s.deadline(), Some(t0 + BEAT_US));
    advance(&mut s, t0 + BEAT_US);
    let second = reports(&mut s);
    assert!(
        matches!(second[..], [FromAgent::Register(_), FromAgent::Heartbeat(h)] if h.seq == 2),
        "{second:?}"
    );
    assert_eq!(command(&mut s, &ToAgent::Stop, t0 + ms(150)), Ok(None));
    advance(&mut s, t0 + ms(200));
    let third = reports(&mut s);
    assert!(
        matches!(third[..], [FromAgent::StopDone(d), FromAgent::Heartbeat(h)] if h.seq == 3 && !d.on_link),
        "the Stop answered (no robot session: no frame), then heard from: no more Register: {third:?}"
    );
}

#[test]
fn shutdown_and_its_own_refusal_end_it_another_instance_s_does_not() {
    let t0: Micros = 0;
    let mut s = session(t0, None);
    start(&mut s, t0);
    let refusal =
        |instance| ToAgent::Refused(RefusedMsg { robot: RobotId(3), instance, why: Refusal::Duplicate });
    assert_eq!(command(&mut s, &refusal(78), t0), Ok(None));
    assert!(!s.core().stopped());
    assert_eq!(command(&mut s, &refusal(77), t0), Ok(Some(ExitCause::Refused)));
    assert!(s.core().stopped(), "a refused gateway stops its robot");
    let mut s = session(t0, None);
    assert_eq!(command(&mut s, &ToAgent::Shutdown, t0), Ok(Some(ExitCause::Shutdown)));
    assert!(s.core().stopped());
}

#[test]
fn an_orchestrator_gone_past_the_grace_stops_the_robot_and_says_so() {
    let t0: Micros = 0;
    let grace = Duration::from_millis(2000);
    let mut s = session(t0, Some(Failsafe::new(grace, OnOrchestratorLost::Exit)));
    start(&mut s, t0);
    orchestrator(&mut s, true, t0);
    advance(&mut s, t0);
    let registered = reports(&mut s);
    assert!(matches!(registered[0], FromAgent::Register(r) if r.failsafe_grace_ms == 2000));
    orchestrator(&mut s, false, t0 + ms(500));
    let due = s.deadline().expect("the failsafe is due");
    assert!(due <= t0 + ms(100), "heartbeats come first");
    let past = t0 + ms(500) + ms(2000) + 1;
    assert!(advance(&mut s, t0 + ms(2500)).is_none(), "exactly the grace is still fine");
    assert!(!s.core().stopped());
    assert_eq!(advance(&mut s, past), Some(ExitCause::OrchestratorLost));
    assert!(s.core().stopped() && s.failsafe_tripped());
    assert!(reports(&mut s).iter().any(|r| matches!(r, FromAgent::Failsafe(f) if f.silent_ms == 2000)));
}

#[test]
fn a_waiting_failsafe_reminds_the_returning_orchestrator() {
    let t0: Micros = 0;
    let mut s = session(t0, Some(Failsafe::new(Duration::from_millis(1000), OnOrchestratorLost::Wait)));
    start(&mut s, t0);
    orchestrator(&mut s, true, t0);
    orchestrator(&mut s, false, t0);
    assert_eq!(advance(&mut s, t0 + ms(1001)), None, "wait: the session goes on");
    assert!(s.core().stopped());
    let _ = reports(&mut s);
    orchestrator(&mut s, true, t0 + ms(3000));
    advance(&mut s, t0 + ms(3000));
    assert!(reports(&mut s).iter().any(|r| matches!(r, FromAgent::Failsafe(_))), "reminded");
    advance(&mut s, t0 + ms(3050));
    assert!(!reports(&mut s).iter().any(|r| matches!(r, FromAgent::Failsafe(_))), "once");
}
