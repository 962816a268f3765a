use crate::core::log::*;
use crate::core::Supervision;
use crate::core::*;
use crate::harness::{self, Case, Schedule};
use bycoms_protocol::msg::Pose;

/// The harness's launches, logged as the driver logs them, replay to
/// the same gate events and ending, through the encoding.
#[test]
fn a_logged_launch_replays_to_the_same_decisions() {
    for seed in 0..40 {
        let case = Case::small(seed);
        let schedule = Schedule::draw(seed, case.robots, 400);
        let (report, setup, calls) = harness::run_logged(&case, &schedule);
        let bytes = encode_calls(&calls);
        let calls = decode_calls(Version::CURRENT, &bytes).expect("decodes");
        let setup = decode_setup(Version::CURRENT, &encode_setup(&setup)).expect("decodes");
        let (gates, ending) = replay(setup, &calls);
        assert_eq!(gates, report.gates, "seed {seed}");
        assert_eq!(ending, report.ending, "seed {seed}");
    }
}

/// FNV-1a, 64 bits: a pin of bytes that must not change.
fn pin(bytes: &[u8]) -> (usize, u64) {
    let hash = bytes
        .iter()
        .fold(0xcbf2_9ce4_8422_2325_u64, |h, b| (h ^ u64::from(*b)).wrapping_mul(0x100_0000_01b3));
    (bytes.len(), hash)
}

/// The current version's bytes, pinned: a change of the core's types that
/// changes what a launch records fails here, and must become a new
/// version of the log's schema with an upgrade from this one (`log.rs`).
/// (A change of the harness's launch itself, its settings or its rules,
/// changes them too: then only the pins are new.)
#[test]
fn the_current_versions_bytes_are_pinned() {
    let case = Case::small(3);
    let schedule = Schedule::draw(3, case.robots, 400);
    let (_, setup, calls) = harness::run_logged(&case, &schedule);
    assert_eq!(Version::CURRENT.number(), bycoms_record::schema::CORE_LOG_VERSION);
    assert_eq!(pin(&encode_setup(&setup)), SETUP_PIN, "the setup's bytes changed: a new log version");
    assert_eq!(pin(&encode_calls(&calls)), CALLS_PIN, "the calls' bytes changed: a new log version");
}

const SETUP_PIN: (usize, u64) = (263, 8264451577438867004);
const CALLS_PIN: (usize, u64) = (17030, 7185601953443555074);

/// `setup` as a version-1 launch recorded it, with every addition.
fn as_v1(setup: &Setup) -> v1::Recorded {
    let s = setup.clone();
    let sup = s.supervision;
    v1::Recorded {
        setup: v1::Setup {
            robots: s.robots,
            lockstep: s.lockstep,
            params: s.params,
            step_limit: s.step_limit,
            wall_period_us: s.wall_period_us,
            speed: s.speed,
            tick_timeout_us: s.tick_timeout_us,
            on_death: s.on_death,
            missing: s.missing,
            prespawn: s.prespawn,
            start: s.start,
            goal: s.goal,
            max_speed: s.max_speed,
            unreachable_grace_s: sup.unreachable_grace_us as f64 / 1e6,
            register_timeout_s: s.register_timeout_s,
            agents: s.agents,
            unix_base_ms: s.unix_base_ms,
            settings: s.settings,
        },
        supervision: Some(v1::SupervisionV1 {
            on: true,
            register_timeout_us: sup.register_timeout_us,
            heartbeat_timeout_us: sup.heartbeat_timeout_us,
            unreachable_grace_us: if sup.held { sup.unreachable_grace_us } else { 0 },
            quiet_us: sup.quiet_us,
            robot_link_grace_us: sup.robot_link_grace_us,
        }),
        clocks: s.clocks,
        commands: s.commands,
        starts: s.starts,
        members: s.members,
    }
}

/// A version-1 setup's bytes cut after its first `parts` additions (a
/// setup recorded before the next one existed).
fn v1_bytes(setup: &Setup, parts: usize) -> Vec<u8> {
    let old = as_v1(setup);
    let mut bytes = postcard::to_allocvec(&old.setup).expect("encodes");
    let additions = [
        postcard::to_allocvec(&old.supervision.expect("set")),
        postcard::to_allocvec(&old.clocks),
        postcard::to_allocvec(&old.commands),
        postcard::to_allocvec(&old.starts),
        postcard::to_allocvec(&old.members.simulated),
        postcard::to_allocvec(&old.members.sim_speed),
    ];
    for part in additions.into_iter().take(parts) {
        bytes.extend(part.expect("encodes"));
    }
    bytes
}

/// A version-1 setup with every addition upgrades to the setup it was
/// made from; `v1::encode_setup` writes the same bytes.
#[test]
fn a_version_1_setup_upgrades_to_the_setup_it_was() {
    for seed in [3, 4, 5] {
        let case = Case::small(seed);
        let mut setup = harness::setup(&case, &Schedule::clean(seed, case.robots));
        setup.clocks = ClockLimits { warn_us: 100_000, limit_us: 500_000 };
        setup.members = Members { simulated: vec![1, 3], sim_speed: 4.0 };
        let bytes = v1_bytes(&setup, 6);
        assert_eq!(v1::encode_setup(&as_v1(&setup)), bytes);
        assert_eq!(decode_setup(Version::V1, &bytes).expect("decodes"), setup, "seed {seed}");
    }
}

/// A version-1 setup recorded before the supervision timers were in the
/// core (no settings after it): its seams' verdicts are its log's inputs,
/// so its timers never expire; its unreachable grace is held as its remote
/// seam held it.
#[test]
fn a_version_1_setup_from_before_the_timers_upgrades_to_timers_that_never_expire() {
    let case = Case::small(3);
    let setup = harness::setup(&case, &Schedule::clean(3, case.robots));
    let decoded = decode_setup(Version::V1, &v1_bytes(&setup, 0)).expect("an old setup decodes");
    let never = Supervision { held: true, ..Supervision::never(setup.supervision.unreachable_grace_us) };
    assert_eq!(decoded.supervision, never);
    let off = Setup {
        supervision: never,
        clocks: Default::default(),
        commands: Default::default(),
        starts: Starts { ahead: 1 },
        ..setup.clone()
    };
    assert_eq!(decoded, off);
}

/// Each later addition, absent from a version-1 setup recorded before it,
/// takes the value the launch ran with then: no clock limits, one `Tick`
/// a period with full re-sends, one agent started ahead, speed-up 1.
#[test]
fn a_version_1_setup_from_before_each_addition_upgrades_as_it_ran() {
    let case = Case::small(6);
    let mut setup = harness::setup(&case, &Schedule::clean(6, case.robots));
    setup.clocks = ClockLimits { warn_us: 100_000, limit_us: 500_000 };
    setup.members = Members { simulated: vec![1, 3], sim_speed: 4.0 };
    assert!(setup.commands.kept, "the harness's spawned agents keep every command");
    assert_eq!(setup.starts.ahead, crate::setup::STARTS_AHEAD, "a lockstep launch starts agents ahead");
    let upgraded =
        |parts| decode_setup(Version::V1, &v1_bytes(&setup, parts)).expect("an older setup decodes");
    let no_clocks = upgraded(1);
    assert!(!no_clocks.clocks.on());
    assert_eq!(
        no_clocks,
        Setup {
            clocks: Default::default(),
            commands: Default::default(),
            starts: Starts { ahead: 1 },
            members: Default::default(),
            ..setup.clone()
        }
    );
    let no_commands = Setup {
        commands: Default::default(),
        starts: Starts { ahead: 1 },
        members: Default::default(),
        ..setup.clone()
    };
    assert_eq!(upgraded(2), no_commands);
    assert_eq!(
        upgraded(3),
        Setup { starts: Starts { ahead: 1 }, members: Default::default(), ..setup.clone() }
    );
    assert_eq!(upgraded(4), Setup { members: Default::default(), ..setup.clone() });
    let before_speed = upgraded(5);
    assert_eq!(
        (before_speed.members.simulated.as_slice(), before_speed.members.sim_speed),
        ([1, 3].as_slice(), 1.0)
    );
    assert_eq!(upgraded(6), setup);
}

/// A version-1 log's `Reach` (a seam's word, from before the core kept the
/// timers) upgrades to the withdrawn token (`Lost`), which the core holds
/// for the grace, and to nothing (`Back`), which the core says when the
/// agent is next heard; every other call is as it was.
#[test]
fn a_version_1_logs_reach_upgrades_to_the_token_and_to_being_heard() {
    use bycoms_protocol::msg::{FromAgent, Heartbeat};
    use bycoms_protocol::RobotId;
    let beat = FromAgent::Heartbeat(Heartbeat { robot: RobotId(2), seq: 7 });
    let old = vec![
        v1::Call::Advance(10),
        v1::Call::Handle(20, v1::Input::Reach(2, v1::Reach::Lost)),
        v1::Call::Handle(30, v1::Input::Report(beat)),
        v1::Call::Handle(30, v1::Input::Reach(2, v1::Reach::Back)),
        v1::Call::Handle(40, v1::Input::Token(3, true)),
        v1::Call::Handle(50, v1::Input::Interrupt),
    ];
    let bytes = postcard::to_allocvec(&old).expect("encodes");
    let upgraded = decode_calls(Version::V1, &bytes).expect("decodes");
    assert_eq!(
        upgraded,
        [
            Call::Advance(10),
            Call::Handle(20, Input::Token(2, false)),
            Call::Handle(30, Input::Report(beat)),
            Call::Handle(40, Input::Token(3, true)),
            Call::Handle(50, Input::Interrupt),
        ]
    );
}

/// A call of the current log as a version-1 launch logged it.
fn call_as_v1(call: &Call) -> v1::Call {
    let input = |input: &Input| match input.clone() {
        Input::Started { robot, pid, how } => v1::Input::Started { robot, pid, how },
        Input::Failed(e) => v1::Input::Failed(e),
        Input::Report(r) => v1::Input::Report(r),
        Input::Pose { topic, pose } => v1::Input::Pose { topic, pose },
        Input::Gone(id, gone) => v1::Input::Gone(id, gone),
        Input::Interrupt => v1::Input::Interrupt,
        Input::Said(id, text) => v1::Input::Said(id, text),
        Input::Stop(stop) => v1::Input::Stop(stop),
        Input::Token(id, present) => v1::Input::Token(id, present),
        Input::Revoke(revoke) => v1::Input::Revoke(revoke),
    };
    match call {
        Call::Handle(at, i) => v1::Call::Handle(*at, input(i)),
        Call::Advance(at) => v1::Call::Advance(*at),
        &Call::HandleRecordedPose { at, topic, number, fingerprint } => {
            v1::Call::HandleRecordedPose { at, topic, number, fingerprint }
        }
    }
}

/// A version-1 recording from before the timers, whose seam said robot 2
/// unreachable and back around one of its reports, replays to the
/// launch's decisions: the upgraded log holds it and lets it go as the
/// seam did, and no timer of the upgraded setup decides anything.
#[test]
fn a_version_1_log_from_before_the_timers_replays_to_the_launchs_decisions() {
    for seed in [3, 7] {
        let case = Case::small(seed);
        let (report, setup, calls) = harness::run_logged(&case, &Schedule::clean(seed, case.robots));
        let mut old: Vec<v1::Call> = Vec::new();
        let mut cut = false;
        for call in &calls {
            let heard_2 = matches!(call, Call::Handle(_, Input::Report(r)) if r.robot().0 == 2);
            match call {
                Call::Handle(at, _) if heard_2 && !cut => {
                    old.push(v1::Call::Handle(*at, v1::Input::Reach(2, v1::Reach::Lost)));
                    old.push(call_as_v1(call));
                    old.push(v1::Call::Handle(*at, v1::Input::Reach(2, v1::Reach::Back)));
                    cut = true;
                }
                _ => old.push(call_as_v1(call)),
            }
        }
        assert!(cut, "seed {seed}: robot 2 reports");
        // Its timers off, its other settings the launch's (a setup from
        // before the timers would have none of them after, and then
        // replays with what launches had then).
        let mut recorded = as_v1(&setup);
        recorded.supervision = recorded.supervision.map(|s| v1::SupervisionV1 { on: false, ..s });
        let setup = decode_setup(Version::V1, &v1::encode_setup(&recorded)).expect("decodes");
        assert_eq!(setup.supervision.register_timeout_us, u64::MAX, "no timer of its own");
        let bytes = postcard::to_allocvec(&old).expect("encodes");
        let calls = decode_calls(Version::V1, &bytes).expect("decodes");
        let (gates, ending) = replay(setup, &calls);
        assert_eq!(gates, report.gates, "seed {seed}");
        assert_eq!(ending, report.ending, "seed {seed}");
    }
}

/// A log that names its poses by their number on their robot's pose
/// topic (as a recording's does) resolves to the log that held them,
/// in fewer bytes; one naming a pose the record lacks says which.
#[test]
fn poses_named_by_their_number_resolve_to_the_same_calls() {
    use std::collections::BTreeMap;
    let case = Case::small(5);
    let (_, _, calls) = harness::run_logged(&case, &Schedule::clean(5, case.robots));
    let mut on: BTreeMap<u32, Vec<Pose>> = BTreeMap::new();
    let named: Vec<Call> = calls
        .iter()
        .map(|c| match c {
            Call::Handle(now, Input::Pose { topic, pose }) => {
                let list = on.entry(*topic).or_default();
                list.push(*pose);
                let (number, fingerprint) = (list.len() as u32 - 1, fingerprint(pose));
                Call::HandleRecordedPose { at: *now, topic: *topic, number, fingerprint }
            }
            other => other.clone(),
        })
        .collect();
    assert!(on.values().map(Vec::len).sum::<usize>() > 10, "the run hands poses");
    let named = decode_calls(Version::CURRENT, &encode_calls(&named)).expect("decodes");
    assert!(encode_calls(&named).len() < encode_calls(&calls).len());
    let (resolved, missing) = resolve(&named, |robot, n| on.get(&robot)?.get(n as usize).copied());
    assert_eq!((resolved, missing), (calls.clone(), None));
    let (cut, missing) =
        resolve(&named, |robot, n| if robot == 1 { None } else { Some(on[&robot][n as usize]) });
    assert_eq!(missing, Some((1, 0)));
    assert!(cut.len() < calls.len());
    // A pose on the record that is not the one handed: its bits changed.
    let moved = |robot: u32, n: u32| {
        let mut p = on[&robot][n as usize];
        p.x += if robot == 2 && n == 3 { 0.001 } else { 0.0 };
        Some(p)
    };
    assert_eq!(resolve(&named, moved).1, Some((2, 3)));
}

/// A replay that is handed other inputs reaches other decisions: the
/// comparison can fail.
#[test]
fn a_changed_input_changes_the_replay() {
    let case = Case::small(3);
    let (report, setup, mut calls) = harness::run_logged(&case, &Schedule::clean(3, case.robots));
    // Drop every pose of robot 1: it is never seen to start.
    calls.retain(|c| !matches!(c, Call::Handle(_, Input::Pose { topic: 1, .. })));
    let (gates, _) = replay(setup, &calls);
    assert_ne!(gates, report.gates);
}
