//! Agents that die, never come, come twice or late, or with other settings;
//! a crash or a cut link noticed in time.

use super::*;

#[test]
fn an_agent_dying_before_it_registers_is_started_once_more_then_its_robot_is_absent() {
    let case = long_case();
    // Robot 1's agent never registers: after its registration timeout it
    // is absent (a hung agent is not started again); 2 and 3 carry on.
    let mut s = Schedule::clean(1, 3);
    s.register_delay_us[0] = None;
    let report = harness::run(&case, &s);
    harness::check(&report, &s).unwrap();
    assert_eq!(report.robots[0].0, SlotState::Absent);
    assert!(
        report.gates.iter().any(|g| g.robot.0 == 2 && g.kind == GateKind::Deployed),
        "{:?}",
        report.gates
    );
    assert_ne!(report.ending.as_ref().unwrap().outcome, Outcome::Error);
    // Robot 1's process dies once before it registers: started once more,
    // it runs as in a launch without the death.
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    let mut s = Schedule::clean(1, 3);
    s.early_deaths[0] = 1;
    let report = harness::run(&case, &s);
    harness::check(&report, &s).unwrap();
    same_run(&clean, &report, "one early death");
    // Twice: absent, and the launch goes on without it; the reason is
    // what the process said last, not only that it ended.
    s.early_deaths[0] = 2;
    let report = harness::run(&case, &s);
    harness::check(&report, &s).unwrap();
    assert_eq!(report.robots[0].0, SlotState::Absent);
    let reason = report.deaths[0].as_deref().unwrap_or_default();
    assert!(
        reason.contains("its process ended") && reason.contains("it said: robot 1's agent crashed"),
        "{reason}"
    );
    assert_ne!(report.ending.as_ref().unwrap().outcome, Outcome::Error);
    // `on_agent_death = abort` is about agents that registered: unchanged.
    let mut strict = case.clone();
    strict.on_death = OnDeath::Abort;
    let report = harness::run(&strict, &s);
    assert_eq!(report.robots[0].0, SlotState::Absent);
    assert_ne!(report.ending.as_ref().unwrap().outcome, Outcome::Error);
    // `missing = fail`: the first death ends the launch, naming robot 1.
    let mut strict = case.clone();
    strict.missing = Missing::Fail;
    let report = harness::run(&strict, &s);
    let ending = report.ending.unwrap();
    assert_eq!(ending.outcome, Outcome::Error);
    assert!(
        matches!(ending.error, Some(Fault::NeverRegistered { robot: 1, why: Gone::Exited(_), .. })),
        "{:?}",
        ending.error
    );
}

#[test]
fn an_agent_dying_while_deployed_costs_one_robot_or_aborts() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    let deployed_at = clean.gate_times_us[0];
    let mut s = Schedule::clean(1, 3);
    s.crashes = vec![Crash { robot: 1, at_us: deployed_at + 1_000 }];
    let report = harness::run(&case, &s);
    harness::check(&report, &s).unwrap();
    assert_eq!(report.robots[0].0, SlotState::Died, "{:?}", report.robots);
    assert_ne!(report.ending.as_ref().unwrap().outcome, Outcome::Error);
    let mut strict = case.clone();
    strict.on_death = OnDeath::Abort;
    let ending = harness::run(&strict, &s).ending.unwrap();
    assert_eq!(ending.outcome, Outcome::Error);
    assert!(
        matches!(
            ending.error,
            Some(Fault::Died { robot: 1, when: DiedWhen::Moving, why: Gone::Exited(_), .. })
        ),
        "{:?}",
        ending.error
    );
}

#[test]
fn when_no_agent_ever_registers_the_launch_ends_with_an_error_naming_the_first() {
    let case = long_case();
    let mut s = Schedule::clean(1, 3);
    s.register_delay_us = vec![None; 3];
    let report = harness::run(&case, &s);
    harness::check(&report, &s).unwrap();
    let ending = report.ending.unwrap();
    assert_eq!(ending.outcome, Outcome::Error);
    let error = ending.error.expect("an error");
    assert!(
        matches!(error, Fault::NoneRegistered { robot: 1, why: Some(Gone::NeverRegistered), .. }),
        "{error:?}"
    );
    assert!(
        report.robots.iter().all(|r| r.0 == SlotState::Absent),
        "every robot was tried: {:?}",
        report.robots
    );
}

#[test]
fn remote_robots_are_needed_only_at_their_turn() {
    let case = long_case();
    let mut s = Schedule::clean(1, 3);
    s.remote = true;
    s.register_delay_us[1] = None;
    let report = harness::run(&case, &s);
    harness::check(&report, &s).unwrap();
    // Robot 1 goes as soon as it is ready, not when all are.
    let registered = report.registered_us[0].expect("robot 1 registered");
    assert!(report.gate_times_us[0] - registered < 1_000_000, "{:?}", report.gate_times_us);
    assert_eq!(report.robots[1].0, SlotState::Absent);
    // Another host's agent is not ours to kill: the launch says what it did.
    let why = report.deaths[1].as_deref().expect("why robot 2 is absent");
    assert_eq!(why, "it did not register in time and was dropped from the launch");
    assert!(
        report.gates.iter().any(|g| g.robot.0 == 3 && g.kind == GateKind::Deployed),
        "{:?}",
        report.gates
    );
    // With `missing = fail` every robot is awaited and one missing ends it.
    let mut strict = case.clone();
    strict.missing = Missing::Fail;
    let report = harness::run(&strict, &s);
    let ending = report.ending.unwrap();
    assert_eq!(ending.outcome, Outcome::Error);
    assert!(report.gates.is_empty(), "nothing deployed: {:?}", report.gates);
    let error = ending.error.expect("an error");
    assert!(matches!(&error, Fault::NeverCame { robots, .. } if robots == &[2]), "{error:?}");
    assert!(!error.to_string().contains("killed"), "{error}");
}

#[test]
fn a_remote_robot_that_registers_after_its_turn_takes_a_later_one() {
    let mut case = long_case();
    case.robots = 6;
    case.time_limit = 300.0;
    let mut s = Schedule::clean(1, 6);
    s.remote = true;
    s.realtime = Some(1.0);
    // Robot 2 comes 15 s after the start, past its 10 s registration timeout.
    s.register_delay_us[1] = Some(15_000_000);
    let report = harness::run(&case, &s);
    harness::check(&report, &s).unwrap();
    assert_eq!(report.late, vec![2], "{:?}", report.robots);
    let order: Vec<u32> =
        report.gates.iter().filter(|g| g.kind == GateKind::Deployed).map(|g| g.robot.0).collect();
    let at = |id| order.iter().position(|&r| r == id);
    assert!(at(2) > at(3), "robot 2 deployed after robot 3: {order:?}");
}

#[test]
fn fifty_robots_with_ten_missing_start_at_once_and_wait_one_timeout_per_absent_robot() {
    let timeout_us = (bycoms_launch::LaunchConfig::default().supervision.register_timeout * 1e6) as u64;
    for remote in [true, false] {
        let f = harness::missing_robots(remote);
        harness::check(&f.report, &Schedule { remote, ..Schedule::clean(0, 50) }).unwrap();
        assert_eq!(f.absent, (2..=11).collect::<Vec<u32>>(), "remote {remote}: {:?}", f.report.robots);
        assert!(f.first_deploy_after_register_us < 1_000_000, "remote {remote}: {f:?}");
        assert!(f.longest_wait_per_absent_us <= timeout_us + 500_000, "remote {remote}: {f:?}");
        assert!(f.deployed >= 2, "the launch went past the absent robots: {f:?}");
    }
}

#[test]
fn a_second_agent_for_a_registered_robot_is_refused_and_changes_nothing() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    let mut s = Schedule::clean(1, 3);
    s.second_agents = vec![(1, clean.end_us / 3), (2, clean.end_us / 2)];
    let report = harness::run(&case, &s);
    same_run(&clean, &report, "second agents");
    assert!(report.bad >= 2, "duplicates counted: {}", report.bad);
}

#[test]
fn agents_with_a_short_failsafe_or_other_settings_are_refused_and_change_nothing() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    let mut s = Schedule::clean(1, 3);
    // Before the real agents register (robot 3's turn comes last) and after.
    s.foreign = vec![
        (0, Foreign::ShortGrace(3)),
        (1, Foreign::OtherSettings(3)),
        (clean.end_us / 4, Foreign::ShortGrace(2)),
        (clean.end_us / 3, Foreign::OtherSettings(1)),
    ];
    let report = harness::run(&case, &s);
    same_run(&clean, &report, "refused agents");
    assert_eq!(report.bad, 4, "each refusal counted once");
}

/// An agent's failsafe report is recorded once, as an event and a line,
/// however often the agent repeats it (it does each time it hears the
/// orchestrator again).
#[test]
fn a_failsafe_report_is_recorded_once() {
    use bycoms_launch::core::{Input, LaunchCore, Output};
    use bycoms_launch::events::EventKind;
    use bycoms_protocol::msg::{FailsafeFired, FromAgent, Register, RobotKind};
    use bycoms_protocol::{RobotId, PROTOCOL_VERSION};

    let case = long_case();
    let mut schedule = Schedule::clean(1, 3);
    schedule.remote = true;
    let setup = harness::setup(&case, &schedule);
    let settings = setup.settings;
    let mut core = LaunchCore::new(setup);
    let mut t = 0;
    let mut outputs = Vec::new();
    let mut step = |core: &mut LaunchCore, input: Option<Input>, outputs: &mut Vec<Output>| {
        t += 1_000;
        if let Some(input) = input {
            core.handle(t, input);
        }
        core.advance(t);
        while let Some(o) = core.poll() {
            outputs.push(o);
        }
    };
    step(&mut core, None, &mut outputs);
    for robot in 1..=3 {
        let started = Input::Started { robot, pid: None, how: "awaited".into() };
        step(&mut core, Some(started), &mut outputs);
    }
    let register = Register {
        robot: RobotId(2),
        kind: RobotKind::Simulated,
        protocol_version: PROTOCOL_VERSION,
        instance: 7,
        settings,
        failsafe_grace_ms: 5_000,
    };
    step(&mut core, Some(Input::Report(FromAgent::Register(register))), &mut outputs);
    let fired = FromAgent::Failsafe(FailsafeFired { robot: RobotId(2), silent_ms: 2_100 });
    for _ in 0..3 {
        step(&mut core, Some(Input::Report(fired)), &mut outputs);
    }
    let events: Vec<_> = outputs
        .iter()
        .filter_map(|o| match o {
            Output::Event(e) if e.event == EventKind::FailsafeFired => Some(e.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(events.len(), 1, "{outputs:#?}");
    assert_eq!(events[0].robot, 2);
    assert_eq!(events[0].reason.as_deref(), Some("orchestrator gone for 2100 ms"));
    let refusals =
        outputs.iter().filter(|o| matches!(o, Output::Send(_, bycoms_protocol::msg::ToAgent::Refused(_))));
    assert_eq!(refusals.count(), 0, "a long failsafe grace and the launch's settings are welcome");
}

/// A crash and a cut link are noticed within 500 ms, in virtual time, by
/// the core's supervision timers (what the agent-source suite used to time
/// with real processes on wall clocks): spawned agents by their exit,
/// remote ones by their token or their silence; and the property can fail.
#[test]
fn a_crash_or_a_cut_link_is_noticed_within_500_ms_in_virtual_time() {
    let case = long_case();
    // Real time: the run lasts seconds of virtual time (a lockstep one may
    // be over within 500 ms), and a robot moves at its own pace.
    let mut clean_schedule = Schedule::clean(1, 3);
    clean_schedule.realtime = Some(1.0);
    let clean = harness::run(&case, &clean_schedule);
    let moving = clean.gate_times_us[0] + 1_000;
    for remote in [false, true] {
        let mut s = clean_schedule.clone();
        s.remote = remote;
        s.crashes = vec![Crash { robot: 2, at_us: moving }];
        if remote {
            s.partitions = vec![Partition { robot: 3, from_us: moving, until_us: moving + 6_000_000 }];
        }
        let report = harness::run(&case, &s);
        harness::check(&report, &s).unwrap();
        assert!(report.end_us > moving + harness::NOTICE_US, "the run outlasts the window");
        let faults: Vec<u32> = report.faults.iter().map(|f| f.0).collect();
        let want: &[u32] = if remote { &[2, 3] } else { &[2] };
        assert_eq!(faults, want, "remote {remote}: the faults the schedule made");
        for &(robot, at) in &report.faults {
            let noticed = report.noticed.iter().find(|n| n.0 == robot && n.1 >= at).expect("noticed");
            assert!(noticed.1 - at <= harness::NOTICE_US, "robot {robot}: {} µs", noticed.1 - at);
        }
        // Not noticed: the property fails.
        let mut blind = report.clone();
        blind.noticed.clear();
        assert!(harness::check(&blind, &s).is_err(), "remote {remote}: the property can fail");
    }
}
