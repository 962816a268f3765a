use crate::core::*;
use crate::events::EventKind;
use crate::harness::{self, Case, Schedule};
use bycoms_protocol::msg::{FromAgent, Refusal, Refused, Register, ToAgent};
use bycoms_protocol::msg::{Heartbeat, RobotKind};
use bycoms_protocol::{RobotId, PROTOCOL_VERSION};

fn register(robot: u32, instance: u64) -> Input {
    Input::Report(FromAgent::Register(Register {
        robot: RobotId(robot),
        kind: RobotKind::Simulated,
        protocol_version: PROTOCOL_VERSION,
        instance,
        settings: 0,
        failsafe_grace_ms: 0,
    }))
}

fn revoke(robot: u32) -> Input {
    Input::Revoke(Revoke { robot, who: "me".into(), why: "stolen".into() })
}

/// Everything the core put out since the last call.
fn outputs(core: &mut LaunchCore) -> Vec<Output> {
    std::iter::from_fn(|| core.poll()).collect()
}

/// In virtual time: a running robot revoked is told `Stop` once, a
/// robot not started yet is told nothing; from then on a `Register` of
/// either is refused as revoked, every report counted as dropped, what
/// the agent source says of them ignored; neither is ever started or
/// deployed again, and the launch goes on with the next robot.
#[test]
fn a_revoked_robot_is_stopped_once_refused_silenced_and_skipped() {
    let case = Case { robots: 3, ..Case::small(3) };
    let mut core = LaunchCore::new(harness::setup(&case, &Schedule::clean(3, case.robots)));
    core.advance(0);
    assert!(outputs(&mut core).contains(&Output::Start(1)), "spawned agents start at their turn");
    core.handle(0, Input::Started { robot: 1, pid: Some(7), how: "started".into() });
    core.handle(1_000, register(1, 11));
    core.advance(1_000);
    outputs(&mut core);

    core.handle(2_000, revoke(2));
    let out = outputs(&mut core);
    assert!(!out.iter().any(|o| matches!(o, Output::Send(..))), "robot 2's agent never ran: {out:?}");
    assert!(out.iter().any(|o| matches!(o, Output::Event(e) if e.event == EventKind::Revoked)));
    core.handle(3_000, revoke(1));
    assert_eq!(core.slots()[0].state(), SlotState::Lost);
    let out = outputs(&mut core);
    let told: Vec<&Output> = out.iter().filter(|o| matches!(o, Output::Send(1, _))).collect();
    assert_eq!(
        told,
        [&Output::Send(1, ToAgent::Stop), &Output::Send(1, ToAgent::Shutdown)],
        "robot 1's agent ran: told Stop once, then to end"
    );
    core.handle(4_000, revoke(1));
    assert!(outputs(&mut core).is_empty(), "a second revocation changes nothing");

    core.handle(5_000, register(2, 22));
    let refused = Refused { robot: RobotId(2), instance: 22, why: Refusal::Revoked };
    assert!(outputs(&mut core).contains(&Output::Send(2, ToAgent::Refused(refused))));
    core.handle(6_000, Input::Report(FromAgent::Heartbeat(Heartbeat { robot: RobotId(1), seq: 9 })));
    core.handle(6_000, Input::Gone(1, Gone::Disconnected));
    core.handle(6_000, Input::Token(1, false));
    core.handle(6_000, Input::Started { robot: 2, pid: None, how: "late".into() });
    let dropped: Vec<(u32, u64)> = core.revoked().iter().map(|r| (r.robot, r.dropped)).collect();
    assert_eq!(dropped, [(2, 1), (1, 1)], "in the order revoked, each report counted");
    assert!(core.slots()[0].outages().is_empty(), "nothing the source says of robot 1 counts");
    assert!(!core.is_running(2));

    for t in (10_000..200_000).step_by(10_000) {
        core.advance(t);
        for out in outputs(&mut core) {
            if let Output::Start(id) = out {
                assert_eq!(id, 3, "only robot 3 is started after 1 and 2 were revoked");
                core.handle(t, Input::Started { robot: 3, pid: Some(9), how: "started".into() });
            }
        }
    }
    assert_eq!(
        core.phase(),
        Phase::AwaitingRegistration(3),
        "the launch went on with robot 3: {:?}",
        core.ending()
    );
    let death = core.slots()[1].death().map(|d| d.reason.clone());
    assert_eq!(death.as_deref(), Some("revoked by me: stolen"));
}
