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
        let calls = decode_calls(&bytes).expect("decodes");
        let setup = decode_setup(&encode_setup(&setup)).expect("decodes");
        let (gates, ending) = replay(setup, &calls);
        assert_eq!(gates, report.gates, "seed {seed}");
        assert_eq!(ending, report.ending, "seed {seed}");
    }
}

/// A setup recorded before the supervision timers were in the core (no
/// settings after it) decodes with them off: its log carries the seams'
/// verdicts as inputs and replays as it ran.
#[test]
fn a_setup_recorded_before_the_timers_decodes_with_them_off() {
    let case = Case::small(3);
    let setup = harness::setup(&case, &Schedule::clean(3, case.robots));
    assert!(setup.supervision.on);
    let old = postcard::to_allocvec(&setup).expect("encodes");
    let decoded = decode_setup(&old).expect("an old setup decodes");
    assert_eq!(decoded.supervision, Supervision::default());
    assert!(!decoded.supervision.on);
    let off = Setup {
        supervision: Supervision::default(),
        clocks: Default::default(),
        commands: Default::default(),
        starts: Default::default(),
        ..setup.clone()
    };
    assert_eq!(decoded, off);
    assert_eq!(decode_setup(&encode_setup(&setup)).expect("decodes"), setup);
}

/// A setup recorded before the clock limits (the setup and its
/// supervision only) decodes with them off; one with them keeps them.
#[test]
fn a_setup_recorded_before_the_clock_limits_decodes_with_them_off() {
    let case = Case::small(4);
    let mut setup = harness::setup(&case, &Schedule::clean(4, case.robots));
    setup.clocks = ClockLimits { warn_us: 100_000, limit_us: 500_000 };
    let mut old = postcard::to_allocvec(&setup).expect("encodes");
    old.extend(postcard::to_allocvec(&setup.supervision).expect("encodes"));
    let decoded = decode_setup(&old).expect("an older setup decodes");
    assert!(!decoded.clocks.on());
    assert_eq!(
        decoded,
        Setup {
            clocks: Default::default(),
            commands: Default::default(),
            starts: Default::default(),
            ..setup.clone()
        }
    );
    assert_eq!(decode_setup(&encode_setup(&setup)).expect("decodes"), setup);
}

/// A setup recorded before the agents' command properties (up to its
/// clock limits) decodes with one `Tick` a period and full re-sends, as
/// it ran; one with them keeps them.
#[test]
fn a_setup_recorded_before_the_command_properties_decodes_as_it_ran() {
    let case = Case::small(4);
    let setup = harness::setup(&case, &Schedule::clean(4, case.robots));
    assert_eq!(
        setup.commands.ticks_at_once,
        crate::agents::TICKS_AT_ONCE,
        "the harness's spawned agents run ahead"
    );
    let mut old = postcard::to_allocvec(&setup).expect("encodes");
    old.extend(postcard::to_allocvec(&setup.supervision).expect("encodes"));
    old.extend(postcard::to_allocvec(&setup.clocks).expect("encodes"));
    let decoded = decode_setup(&old).expect("an older setup decodes");
    assert!(setup.commands.kept, "the harness's spawned agents keep every command");
    assert_eq!(decoded, Setup { commands: Default::default(), starts: Default::default(), ..setup.clone() });
    assert_eq!(decode_setup(&encode_setup(&setup)).expect("decodes"), setup);
}

/// A setup recorded before agents were started more than one ahead (up
/// to its command properties) decodes with one ahead, as it ran; one
/// with it keeps it.
#[test]
fn a_setup_recorded_before_the_starts_ahead_decodes_as_it_ran() {
    let case = Case::small(5);
    let setup = harness::setup(&case, &Schedule::clean(5, case.robots));
    assert_eq!(setup.starts.ahead, crate::setup::STARTS_AHEAD, "a lockstep launch starts agents ahead");
    let mut old = postcard::to_allocvec(&setup).expect("encodes");
    old.extend(postcard::to_allocvec(&setup.supervision).expect("encodes"));
    old.extend(postcard::to_allocvec(&setup.clocks).expect("encodes"));
    old.extend(postcard::to_allocvec(&setup.commands).expect("encodes"));
    let decoded = decode_setup(&old).expect("an older setup decodes");
    assert_eq!(decoded.starts.ahead, 0, "none recorded: one ahead, as the core reads it");
    assert_eq!(decoded, Setup { starts: Default::default(), ..setup.clone() });
    assert_eq!(decode_setup(&encode_setup(&setup)).expect("decodes"), setup);
}

/// A mixed swarm's setup recorded before `--sim-speed` (its members
/// the last thing on it) decodes at speed-up 1, as it ran; one with a
/// speed-up keeps it.
#[test]
fn a_mixed_setup_recorded_before_the_sim_speed_decodes_at_speed_up_1() {
    let case = Case::small(6);
    let mut setup = harness::setup(&case, &Schedule::clean(6, case.robots));
    setup.members = Members { simulated: vec![1, 3], sim_speed: 4.0 };
    let mut old = postcard::to_allocvec(&setup).expect("encodes");
    for part in [
        postcard::to_allocvec(&setup.supervision),
        postcard::to_allocvec(&setup.clocks),
        postcard::to_allocvec(&setup.commands),
        postcard::to_allocvec(&setup.starts),
        postcard::to_allocvec(&setup.members.simulated),
    ] {
        old.extend(part.expect("encodes"));
    }
    let decoded = decode_setup(&old).expect("an older setup decodes");
    assert_eq!((decoded.members.simulated.as_slice(), decoded.members.sim_speed), ([1, 3].as_slice(), 1.0));
    assert_eq!(decode_setup(&encode_setup(&setup)).expect("decodes"), setup);
    assert_eq!((setup.members.speed_up(3), setup.members.speed_up(2)), (4.0, 1.0));
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
    let named = decode_calls(&encode_calls(&named)).expect("decodes");
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
