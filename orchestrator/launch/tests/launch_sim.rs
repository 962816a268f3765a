//! The launch core under simulation testing: whole launches with simulated
//! agents over a seeded simulated network, in virtual time
//! (`orchestrator/launch/src/harness/`).
//!
//! * every drawn schedule keeps the properties of `harness::check` (the
//!   launch ends with a clear outcome; no robot deployed twice; verdicts in
//!   deployment order; nothing charged twice; re-sends bounded);
//! * without faults a lockstep launch equals `simulate` bit for bit;
//! * forged and foreign traffic (on either clock), and partitions shorter
//!   than the link grace, change nothing;
//! * the defects found by hand (a step of `u64::MAX`, a forged pose at the
//!   goal, a stray `Register` of another protocol version, an agent dying
//!   before it registers or while it is deployed) each have a case.
//!
//! A failing schedule prints its seed; replay it exactly with
//! `BYCOMS_SIM_SEED=<seed> cargo test -p bycoms-orchestrator --test launch_sim -- one_seed --nocapture`.
//! `BYCOMS_SIM_SCHEDULES` sets how many schedules `schedules_keep_the_properties` draws
//! (default 10 000).

use bycoms_launch::agents::Gone;
use bycoms_launch::config::{Missing, OnDeath};
use bycoms_launch::core::{DiedWhen, Fault, SlotState};
use bycoms_launch::harness::{self, Case, Crash, Foreign, Partition, Report, Schedule};
use bycoms_launch::Outcome;
use bycoms_protocol::msg::GateKind;
use bycoms_sim::runner::RobotEnd;

/// Robot `robot`'s first `Register` from a simulated agent, as the
/// harness's cases take it (no settings fingerprint, no failsafe grace).
fn simulated_register(robot: u32) -> bycoms_protocol::msg::Register {
    bycoms_protocol::msg::Register {
        robot: bycoms_protocol::RobotId(robot),
        kind: bycoms_protocol::msg::RobotKind::Simulated,
        protocol_version: bycoms_protocol::PROTOCOL_VERSION,
        instance: 1,
        settings: 0,
        failsafe_grace_ms: 0,
    }
}

/// Lockstep ticks a small case runs at most (faults fall within them).
const TICKS: u64 = 400;

fn replay_hint(seed: u64) -> String {
    format!(
        "replay: BYCOMS_SIM_SEED={seed} cargo test -p bycoms-orchestrator --test launch_sim -- one_seed --nocapture"
    )
}

fn one(seed: u64) -> (Case, Schedule, Report) {
    let case = Case::small(seed);
    let schedule = Schedule::draw(seed, case.robots, TICKS);
    let report = harness::run(&case, &schedule);
    (case, schedule, report)
}

/// One schedule's tally: outcome, kind of error, bad traffic, re-sends,
/// and which kinds of launch it was (see `covered`).
type Played = (String, Option<String>, u64, u64, [bool; 5]);

#[test]
fn schedules_keep_the_properties() {
    use rayon::prelude::*;
    let count: u64 =
        std::env::var("BYCOMS_SIM_SCHEDULES").ok().and_then(|v| v.parse().ok()).unwrap_or(10_000);
    // Every schedule is independent and deterministic from its seed: they
    // are played on every core, and the tallies do not depend on the order.
    let played: Vec<Played> = (0..count)
        .into_par_iter()
        .map(|seed| {
            let (_, schedule, report) = one(seed);
            if let Err(e) = harness::check(&report, &schedule) {
                panic!(
                    "schedule {seed} broke a property: {e}\n{}\nschedule: {schedule:?}",
                    replay_hint(seed)
                );
            }
            let ending = report.ending.expect("checked");
            // The kind of error: its variant (the core's typed fault).
            let error = ending
                .error
                .as_ref()
                .map(|e| format!("{e:?}").split([' ', '(', '{']).next().unwrap_or("").to_string());
            // What a launch can be that the schedules must reach.
            let covered = [
                schedule.gateway_seams && report.forwarded > 0,
                schedule.stop_when_stuck && report.stops_sent.iter().sum::<u64>() > 0,
                schedule.recording_fails,
                schedule.gateways && report.deploys_sent.iter().sum::<u64>() > 0,
                schedule.gateways && matches!(ending.error, Some(Fault::NotPlaced { .. })),
            ];
            (format!("{:?}", ending.outcome), error, report.bad, report.resends, covered)
        })
        .collect();
    let mut outcomes = std::collections::BTreeMap::new();
    let mut errors = std::collections::BTreeMap::new();
    let (mut bad, mut resends) = (0u64, 0u64);
    let mut covered = [0u64; 5];
    for (outcome, error, b, r, c) in played {
        for (n, c) in covered.iter_mut().zip(c) {
            *n += u64::from(c);
        }
        *outcomes.entry(outcome).or_insert(0u64) += 1;
        if let Some(kind) = error {
            *errors.entry(kind).or_insert(0u64) += 1;
        }
        bad += b;
        resends += r;
    }
    eprintln!("{count} schedules: outcomes {outcomes:?}, bad traffic counted {bad}, re-sends {resends}");
    eprintln!("errors: {errors:#?}");
    eprintln!(
        "gateway seams with poses forwarded, stuck robots stopped, recordings failed, \
         gateway agents deployed, robots never placed: {covered:?}"
    );
    // The schedules reach every kind of ending, or they test too little.
    if count >= 1000 {
        // Real robots are one schedule in 200 (they cost the most): their
        // kinds are required from 5 000 schedules on.
        let kinds = if count >= 5000 { covered.len() } else { 3 };
        assert!(covered[..kinds].iter().all(|&n| n > 0), "a kind of launch never drawn: {covered:?}");
        for o in ["Arrived", "RobotsExhausted", "TimeLimit", "Interrupted"] {
            assert!(outcomes.contains_key(o), "no schedule ended {o}: {outcomes:?}");
        }
    }
}

#[test]
fn one_seed() {
    let seed: u64 = std::env::var("BYCOMS_SIM_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(0);
    let (case, schedule, report) = one(seed);
    eprintln!("case: {case:?}\nschedule: {schedule:?}\nreport: {report:#?}");
    harness::check(&report, &schedule).unwrap_or_else(|e| panic!("schedule {seed}: {e}"));
}

/// Without faults, the launch's result is `simulate`'s, bit for bit.
#[test]
fn without_faults_lockstep_equals_simulate_bit_for_bit() {
    for seed in 0..432 {
        let case = Case::small(seed);
        let report = harness::run(&case, &Schedule::clean(seed, case.robots));
        assert_simulates(&case, &report, &format!("seed {seed}"));
    }
}

/// Issue 31: `--dwell 1e9` never ended, whatever the time limit (a robot
/// that stopped was watched until it had stood still for the dwell). The
/// time limit bounds every run, and the result is still `simulate`'s: a
/// robot standing still when the time is up stopped within it.
#[test]
fn a_dwell_longer_than_the_run_ends_at_the_time_limit_as_simulate_does() {
    for seed in (0..432).step_by(7) {
        let mut case = Case::small(seed);
        case.dwell = 1e9;
        let schedule = Schedule::clean(seed, case.robots);
        let report = harness::run(&case, &schedule);
        harness::check(&report, &schedule).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        assert_simulates(&case, &report, &format!("seed {seed}, dwell 1e9 s"));
    }
}

/// `report`'s launch ended as `simulate` runs `case`: outcome, budget, and
/// every robot's end, steps and position, bit for bit.
fn assert_simulates(case: &Case, report: &Report, what: &str) {
    let expected = bycoms_sim::run(&case.terrain, &case.run_config());
    let ending = report.ending.as_ref().unwrap_or_else(|| panic!("{what}: {:?}", report.failure));
    let outcome = match expected.outcome {
        bycoms_sim::Outcome::Arrived => Outcome::Arrived,
        bycoms_sim::Outcome::TimeLimit => Outcome::TimeLimit,
        bycoms_sim::Outcome::RobotsExhausted => Outcome::RobotsExhausted,
    };
    assert_eq!(ending.outcome, outcome, "{what}");
    assert_eq!(report.spent, expected.steps, "{what}: steps");
    for run in &expected.robots {
        let (state, steps, pose) = report.robots[run.id as usize - 1];
        let want = match run.end {
            RobotEnd::Stuck => SlotState::Stuck,
            RobotEnd::Arrived => SlotState::Arrived,
            RobotEnd::Moving => SlotState::Unfinished,
        };
        assert_eq!(state, want, "{what} robot {}", run.id);
        assert_eq!(steps, run.steps, "{what} robot {}", run.id);
        let pose = pose.expect("a deployed robot has a pose");
        assert_eq!(
            (pose.x.to_bits(), pose.y.to_bits()),
            (run.position.x.to_bits(), run.position.y.to_bits()),
            "{what} robot {}",
            run.id
        );
    }
    let deployed = report.gates.iter().filter(|g| g.kind == GateKind::Deployed).count();
    assert_eq!(deployed as u32, expected.robots_used, "{what}");
}

/// A robot that froze says so (`Parked`) and, once the gate has judged it,
/// gets no more ticks: a long run wakes only the agents whose robots can
/// still move, and the result stays `simulate`'s (the test above).
#[test]
fn a_frozen_robot_gets_no_tick_after_its_verdict() {
    let mut judged_before_the_end = 0;
    for seed in 0..216 {
        let case = Case::small(seed);
        let report = harness::run(&case, &Schedule::clean(seed, case.robots));
        assert!(report.ending.is_some(), "seed {seed}: {:?}", report.failure);
        for (k, (state, _, pose)) in report.robots.iter().enumerate() {
            if *state != SlotState::Stuck {
                continue;
            }
            let judged = pose.expect("a stuck robot has a pose").step;
            assert_eq!(report.last_tick[k], Some(judged), "seed {seed} robot {}: its last tick", k + 1);
            judged_before_the_end += usize::from(judged < report.ticks);
        }
    }
    // Most stuck robots were judged long before their run ended: without
    // `Parked` each of them would have been ticked to the end.
    assert!(judged_before_the_end > 100, "only {judged_before_the_end} robots judged before the end");
}

/// An agent whose robot is not deployed yet steps nothing, so a tick
/// costs it nothing: it is ticked only when it was just sent beacons (its
/// answer says it holds them) and while it settles, never merely because
/// the robot before it moves (issue 35: a prespawned agent used to be
/// ticked every tick). Each such tick carries a beacon to it, but for one
/// settling tick per deployment; the results are unchanged (the parity
/// tests above).
#[test]
fn an_agent_whose_robot_is_not_deployed_is_ticked_only_to_take_beacons_or_settle() {
    let (mut idle, mut moving) = (0, 0);
    for seed in 0..120 {
        let case = Case::small(seed);
        let report = harness::run(&case, &Schedule::clean(seed, case.robots));
        assert!(report.ending.is_some(), "seed {seed}: {:?}", report.failure);
        let idle_ticks: u64 = report.idle_ticks.iter().sum();
        let deployed = report.deploys_sent.iter().filter(|&&d| d > 0).count() as u64;
        let bound = report.beacons_sent + deployed + report.resends;
        assert!(idle_ticks <= bound, "seed {seed}: {idle_ticks} idle ticks, at most {bound} expected");
        idle += idle_ticks;
        moving += report.ticks;
    }
    assert!(idle > 0, "settling robots are ticked");
    assert!(idle * 4 < moving, "{idle} idle ticks in {moving} ticks");
}

/// The harness's agents are built as the launch's spawned agents are:
/// from its agent template and run settings (no restated periods: they
/// beat every 100 ms, every 500 ms once parked), and the core's setup
/// carries the fingerprint those agents register with.
#[test]
fn harness_agents_beat_and_register_as_the_launch_tells_its_agents() {
    use std::time::Duration;
    let case = Case::small(0);
    let schedule = Schedule::clean(0, case.robots);
    let launch = harness::Launch::of(&case, &schedule);
    assert_eq!(launch.timing.heartbeat, Duration::from_millis(100));
    assert_eq!(launch.timing.parked_heartbeat, Duration::from_millis(500));
    assert_eq!(launch.setup(&schedule).settings, launch.settings.fingerprint());
    assert_eq!(launch.setup(&schedule), harness::setup(&case, &schedule));
}

/// Agents that stop stuck robots (the gateways' property, through the
/// launch's own setup) are told `Stop` once per robot judged stuck, and
/// nothing else changes: in lockstep a judged robot gets no tick anyway,
/// and the sim-agent's own rules park it (`Parked`, slower heartbeats).
#[test]
fn stop_when_stuck_stops_each_stuck_robot_once_and_changes_nothing_else() {
    let mut stopped = 0;
    for seed in 0..120 {
        let case = Case::small(seed);
        let clean = Schedule::clean(seed, case.robots);
        let stopping = Schedule { stop_when_stuck: true, ..clean.clone() };
        let (base, report) = (harness::run(&case, &clean), harness::run(&case, &stopping));
        harness::check(&report, &stopping).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        same_run(&base, &report, &format!("seed {seed}, stop when stuck"));
        for (k, (state, _, _)) in report.robots.iter().enumerate() {
            let expected = u64::from(matches!(state, SlotState::Stuck | SlotState::Arrived));
            assert_eq!(report.stops_sent[k], expected, "seed {seed} robot {}: Stops for {state:?}", k + 1);
            assert_eq!(base.stops_sent[k], u64::from(*state == SlotState::Arrived), "seed {seed} without");
            stopped += usize::from(*state == SlotState::Stuck);
        }
    }
    assert!(stopped > 100, "only {stopped} stuck robots stopped");
}

fn same_run(a: &Report, b: &Report, what: &str) {
    assert_eq!(a.ending, b.ending, "{what}: ending");
    assert_eq!(a.gates, b.gates, "{what}: gate events");
    let ends = |r: &Report| {
        r.robots
            .iter()
            .map(|(s, n, p)| (*s, *n, p.map(|p| (p.x.to_bits(), p.y.to_bits()))))
            .collect::<Vec<_>>()
    };
    assert_eq!(ends(a), ends(b), "{what}: robots");
}

#[test]
fn forged_and_foreign_traffic_changes_nothing_and_is_counted() {
    let mut counted = 0;
    for seed in 0..300 {
        let case = Case::small(seed);
        // Every other seed on the real-time clock (at 5×).
        let realtime = (seed % 2 == 1).then_some(5.0);
        let clean_schedule = Schedule { realtime, ..Schedule::clean(seed, case.robots) };
        let clean = harness::run(&case, &clean_schedule);
        let forged = Schedule { realtime, ..Schedule::forgeries(seed, case.robots, clean.end_us) };
        let report = harness::run(&case, &forged);
        harness::check(&report, &forged).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        same_run(&clean, &report, &format!("seed {seed}, {:?}", forged.foreign));
        counted += report.bad;
    }
    assert!(counted > 300, "forgeries were delivered and counted: {counted}");
}

#[test]
fn a_partition_shorter_than_the_link_grace_ends_as_without_it() {
    for seed in 0..200 {
        let case = Case::small(seed);
        let mut clean = Schedule::clean(seed, case.robots);
        clean.remote = true;
        clean.link = harness::Link::perfect(20_000);
        let base = harness::run(&case, &clean);
        let mut cut = clean.clone();
        let robot = 1 + (seed % u64::from(case.robots)) as u32;
        let from_us = base.end_us * (seed % 7 + 1) / 9;
        cut.partitions = vec![Partition { robot, from_us, until_us: from_us + 1_500_000 }];
        let report = harness::run(&case, &cut);
        harness::check(&report, &cut).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        same_run(&base, &report, &format!("seed {seed}, robot {robot} cut at {from_us} µs"));
    }
}

/// The case where robot 1 moves for a while first (a wall far away).
fn long_case() -> Case {
    let mut case = Case::small(0);
    case.robots = 3;
    case
}

#[test]
fn a_pose_with_step_u64_max_neither_stalls_nor_changes_the_run() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    for forgery in [Foreign::StepFromTheFuture(1), Foreign::HugeStep(1)] {
        let mut s = Schedule::clean(1, 3);
        s.foreign = vec![(clean.end_us / 10, forgery)];
        let report = harness::run(&case, &s);
        harness::check(&report, &s).unwrap();
        same_run(&clean, &report, &format!("{forgery:?}"));
        assert_eq!(report.bad, 1, "refused and counted");
    }
}

#[test]
fn a_forged_pose_at_the_goal_does_not_win() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    let mut s = Schedule::clean(1, 3);
    s.foreign = vec![(clean.end_us / 10, Foreign::AtTheGoal(1))];
    let report = harness::run(&case, &s);
    same_run(&clean, &report, "forged pose at the goal");
    assert_eq!(report.bad, 1);
}

/// Issue 31: poses of robot 2 at the goal, one every 0.1 s from halfway
/// to its deployment on (steps 5, 6, … in real time, behind its agent's
/// clock), and a forger who answers robot 2's `Deploy` with a pose at the
/// goal before its agent does. On either clock the run is the clean one:
/// robot 2 starts where it was deployed, and its agent's poses are judged
/// against that start, not against a forgery ("ahead of the launch's
/// clock").
#[test]
fn poses_at_the_goal_before_a_robot_is_deployed_neither_start_it_nor_refuse_its_own() {
    let case = long_case();
    for realtime in [Some(1.0), Some(5.0), None] {
        // Lockstep ticks of 20 ms: robot 1 moves for about a second.
        let link = harness::Link::perfect(10_000);
        let clean_schedule = Schedule { realtime, link, ..Schedule::clean(1, 3) };
        let clean = harness::run(&case, &clean_schedule);
        let deployed_us =
            clean.gates.iter().zip(&clean.gate_times_us).find(|(g, _)| g.robot.0 == 2).map(|(_, t)| *t);
        let Some(deployed_us) = deployed_us.filter(|&t| t > 500_000) else {
            panic!("{realtime:?}: robot 2 is deployed late in the clean run: {deployed_us:?} µs");
        };
        for forgery in [Foreign::GoalSeries { robot: 2, sent: 0 }, Foreign::RacesTheDeploy(2)] {
            let what = format!("{forgery:?} on the {realtime:?} clock");
            let mut s = clean_schedule.clone();
            s.foreign = vec![(deployed_us / 2, forgery)];
            let report = harness::run(&case, &s);
            harness::check(&report, &s).unwrap_or_else(|e| panic!("{what}: {e}"));
            same_run(&clean, &report, &what);
            assert!(report.bad >= 1, "{what}: refused and counted");
        }
    }
}

#[test]
fn a_stray_register_of_another_protocol_is_counted_and_never_fatal() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    let mut s = Schedule::clean(1, 3);
    s.foreign =
        vec![(clean.end_us / 10, Foreign::WrongVersion(1)), (clean.end_us / 5, Foreign::WrongVersion(3))];
    let report = harness::run(&case, &s);
    same_run(&clean, &report, "stray registers");
    assert_eq!(report.bad, 2);
}

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
    use bycoms_launch::core::{Core, Input, Output};
    use bycoms_launch::events::EventKind;
    use bycoms_protocol::msg::{FailsafeFired, FromAgent, Register, RobotKind};
    use bycoms_protocol::{RobotId, PROTOCOL_VERSION};

    let case = long_case();
    let mut schedule = Schedule::clean(1, 3);
    schedule.remote = true;
    let setup = harness::setup(&case, &schedule);
    let settings = setup.settings;
    let mut core = Core::new(setup);
    let mut t = 0;
    let mut outputs = Vec::new();
    let mut step = |core: &mut Core, input: Option<Input>, outputs: &mut Vec<Output>| {
        t += 1_000;
        if let Some(input) = input {
            core.handle(t, input);
        }
        core.advance(t);
        while let Some(o) = core.poll_output() {
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

/// Issue 31: lockstep with `[faults] drop = 0.05` took 114 s where the run
/// takes 0.15 s, silent, and ended otherwise than without faults. A lost
/// answer (a `TickDone`, or the moving robot's pose) costs a re-send after
/// a few answer times, not a second, and the tick waits for the moving
/// robot's pose, so the run is the one without faults, bit for bit.
#[test]
fn lost_answers_in_lockstep_cost_a_quick_resend_and_change_nothing() {
    let mut lost = 0;
    for seed in (0..432).step_by(9) {
        let case = Case::small(seed);
        // A robot never deployed may still be registering: not part of the run.
        let alike = |mut r: Report| {
            for robot in r.robots.iter_mut().filter(|r| r.0 == SlotState::Spawned) {
                robot.0 = SlotState::Registered;
            }
            r
        };
        let clean = alike(harness::run(
            &case,
            &Schedule { link: harness::Link::perfect(50), ..Schedule::clean(seed, case.robots) },
        ));
        for drop in [0.05, 0.3] {
            let what = format!("seed {seed}, drop {drop}");
            let lossy =
                Schedule { link: harness::Link::faults(50, drop), ..Schedule::clean(seed, case.robots) };
            let report = harness::run(&case, &lossy);
            harness::check(&report, &lossy).unwrap_or_else(|e| panic!("{what}: {e}"));
            let report = alike(report);
            same_run(&clean, &report, &what);
            assert_simulates(&case, &report, &what);
            // A lost registration costs a heartbeat (0.5 s); anything else
            // a re-send after a few answer times.
            let bound = clean.end_us + 1_000_000 + report.lost * 20_000;
            assert!(
                report.end_us <= bound,
                "{what}: {} µs, {} lost, clean {} µs",
                report.end_us,
                report.lost,
                clean.end_us
            );
            lost += report.lost;
        }
    }
    assert!(lost > 1000, "messages were lost: {lost}");
}

/// Issue 31: a launch that waited looked hung. What it waits for is said
/// in words (the terminal prints it when a wait lasts, `launch::progress`).
#[test]
fn the_launch_says_what_it_waits_for() {
    use bycoms_launch::core::{Core, Input};
    use bycoms_protocol::msg::{FromAgent, TickDone, ToAgent};
    use bycoms_protocol::RobotId;
    let case = Case::small(0);
    let mut core = Core::new(harness::setup(&case, &Schedule::clean(0, case.robots)));
    let waiting = |core: &Core| core.waiting().map(|w| (w.what, w.resent));
    core.advance(0);
    core.handle(0, Input::Started { robot: 1, pid: Some(7), how: "started".into() });
    core.advance(0);
    assert_eq!(waiting(&core), Some(("robot 1's agent to register".into(), 0)));
    let register = simulated_register(1);
    core.handle(1_000, Input::Report(FromAgent::Register(register)));
    core.advance(1_000);
    assert_eq!(waiting(&core), Some(("robot 1's answer to tick 1".into(), 0)));
    // Nothing comes: sent again after a tenth of a second (nothing timed yet).
    core.advance(101_000);
    assert_eq!(waiting(&core), Some(("robot 1's answer to tick 1".into(), 1)));
    while core.poll_output().is_some() {}
    core.handle(102_000, Input::Report(FromAgent::TickDone(TickDone { robot: RobotId(1), step: 1 })));
    core.advance(102_000);
    let deploy = std::iter::from_fn(|| core.poll_output())
        .any(|o| matches!(o, bycoms_launch::core::Output::Send(1, ToAgent::Deploy(_))));
    assert!(deploy, "robot 1 is told to deploy");
    assert_eq!(waiting(&core), Some(("robot 1's start pose".into(), 0)));
}

/// Issue 31: at `--speed 100000` every robot's agent was started twice: a
/// robot deployed and judged in one `advance` (its start pose and the poses
/// of its dwell arrived together) left its prespawned successor looking not
/// started, and the successor was started again.
#[test]
fn a_robot_deployed_and_judged_at_once_starts_its_successor_once() {
    use bycoms_launch::core::{Core, Input, Output};
    use bycoms_protocol::msg::{FromAgent, Pose, ToAgent};
    use bycoms_protocol::RobotId;
    let case = Case::small(0);
    let schedule = Schedule { realtime: Some(100_000.0), ..Schedule::clean(0, case.robots) };
    let mut core = Core::new(harness::setup(&case, &schedule));
    let mut starts = vec![0; case.robots as usize];
    let mut deployed = false;
    let mut drain = |core: &mut Core, starts: &mut Vec<u32>| {
        while let Some(out) = core.poll_output() {
            match out {
                Output::Start(id) => starts[id as usize - 1] += 1,
                Output::Send(1, ToAgent::Deploy(_)) => deployed = true,
                _ => {}
            }
        }
        deployed
    };
    core.advance(0);
    drain(&mut core, &mut starts);
    core.handle(0, Input::Started { robot: 1, pid: Some(7), how: "started".into() });
    let register = simulated_register(1);
    core.handle(10, Input::Report(FromAgent::Register(register)));
    let mut now = 10;
    while !drain(&mut core, &mut starts) {
        core.advance(now);
        now += 1;
        assert!(now < 1_000_000, "robot 1 is told to deploy");
    }
    // Its start pose and two simulated seconds of standing still, at once.
    let start = case.terrain.start();
    for step in 0..=20 {
        let pose =
            Pose { robot: RobotId(1), x: start.x, y: start.y, heading: 0.0, step, time_us: step * 100_000 };
        core.handle(now, Input::Pose { topic: 1, pose });
    }
    core.advance(now);
    drain(&mut core, &mut starts);
    assert_eq!(core.slots()[0].state(), SlotState::Stuck, "deployed and judged in one advance");
    assert_eq!(starts[..2], [1, 1], "each agent started once");
}

/// Issue 34: `orchestrator stop --now` at a seeded moment of a drawn
/// schedule (any clock, any faults): the launch ends interrupted, every
/// robot whose agent ran is told `Stop` at once, the agents (the real
/// sim-agent core and gateways) answer it and the launch ends once they
/// did (the harness's `check_stop`), and the summary's record names who
/// asked and why. A graceful stop tells no one (the agents get `Shutdown`
/// as after Ctrl-C).
#[test]
fn a_stop_at_a_seeded_moment_tells_every_running_robot_at_once_and_names_who() {
    use rand::{Rng, SeedableRng};
    let (mut told, mut answered) = (0usize, 0usize);
    for seed in 0..300u64 {
        let case = Case::small(seed);
        let mut schedule = Schedule::draw(seed, case.robots, TICKS);
        schedule.interrupt_at_us = None;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x5709);
        let at_once = seed % 4 != 0;
        schedule.stop_at_us = Some((rng.gen_range(0..3_000_000), at_once));
        let report = harness::run(&case, &schedule);
        harness::check(&report, &schedule).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let ending = report.ending.as_ref().expect("checked");
        let Some(stop) = report.stopped.as_ref() else {
            // The launch ended before the stop came.
            assert_ne!(ending.outcome, Outcome::Interrupted, "seed {seed}");
            continue;
        };
        if ending.outcome == Outcome::Error {
            continue;
        }
        assert_eq!(ending.outcome, Outcome::Interrupted, "seed {seed}");
        assert_eq!((stop.who.as_str(), stop.why.as_str()), (harness::STOP_WHO, harness::STOP_WHY));
        if at_once {
            for id in &report.running_at_end {
                assert!(stop.told.contains(id), "seed {seed}: robot {id} ran and was not told Stop");
            }
            told += stop.told.len();
            answered += stop.answered.len();
        } else {
            assert!(stop.told.is_empty(), "seed {seed}");
        }
    }
    assert!(told > 100, "too few robots were told to stop ({told}): the test tests too little");
    // Lossy buses and partitions silence some; most answer.
    assert!(answered * 4 > told * 3, "only {answered} of {told} robots told answered");
}

/// A robot revoked while it moves (`orchestrator revoke`, in virtual
/// time) is told `Stop` once and becomes a beacon where it stopped, like a
/// robot whose agent died; the launch goes on with the others, never
/// ending in an error for it, and the summary names who revoked it.
#[test]
fn a_robot_revoked_while_it_moves_is_a_beacon_and_the_others_go_on() {
    let case = long_case();
    let clean = harness::run(&case, &Schedule::clean(1, 3));
    let times = |kind: fn(GateKind) -> bool| {
        clean
            .gates
            .iter()
            .zip(&clean.gate_times_us)
            .find(|(g, _)| g.robot.0 == 1 && kind(g.kind))
            .map(|(_, t)| *t)
    };
    let deployed = times(|k| k == GateKind::Deployed).expect("robot 1 deployed");
    let decided = times(|k| k != GateKind::Deployed).expect("robot 1 judged");
    let mut s = Schedule::clean(1, 3);
    let at = (deployed + decided) / 2;
    s.revoke_at_us = Some((at, 1));
    let report = harness::run(&case, &s);
    harness::check(&report, &s).unwrap_or_else(|e| panic!("{e}"));
    let ending = report.ending.as_ref().expect("ended");
    assert_ne!(ending.outcome, Outcome::Error, "{:?}", ending.error);
    assert_eq!(report.robots[0].0, SlotState::Died, "a beacon where it stopped");
    assert_eq!(report.stop_log.iter().filter(|s| s.1 == 1).count(), 1, "told Stop once");
    assert!(report.stop_log.iter().any(|&(t, id)| id == 1 && t == at), "told at the revocation");
    let died = report.gates.iter().position(|g| g.robot.0 == 1 && g.kind == GateKind::Died);
    assert!(died.is_some_and(|i| report.gate_times_us[i] == at), "judged at once: {:?}", report.gates);
    assert!(report.gates.iter().any(|g| g.robot.0 == 2 && g.kind == GateKind::Deployed), "robot 2 went on");
    let decided = report.decided.as_ref().expect("summary");
    assert_eq!(decided.robots[0].end, bycoms_launch::RobotEnd::Died);
    let reason = report.deaths[0].as_deref().unwrap_or_default();
    assert_eq!(reason, format!("revoked by {}: {}", harness::STOP_WHO, harness::REVOKE_WHY));
    assert_eq!(report.revoked.iter().map(|r| r.robot).collect::<Vec<_>>(), [1]);
}

/// A revocation at a seeded moment, of a seeded robot, in schedules drawn
/// with every other fault: every property holds (`harness::check`'s
/// `check_revoke`: told `Stop` at most once, nothing from the robot changes
/// the launch afterwards).
#[test]
fn a_revocation_at_a_seeded_moment_keeps_the_properties() {
    use rand::{Rng, SeedableRng};
    let (mut taken, mut moving) = (0, 0);
    for seed in 0..150u64 {
        let case = Case::small(seed);
        let mut schedule = Schedule::draw(seed, case.robots, TICKS);
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x7e0c);
        let robot = rng.gen_range(1..=case.robots);
        schedule.revoke_at_us = Some((rng.gen_range(0..2_000_000), robot));
        let report = harness::run(&case, &schedule);
        harness::check(&report, &schedule).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        if report.revoked.iter().any(|r| r.robot == robot) {
            taken += 1;
            moving += usize::from(report.robots[robot as usize - 1].0 == SlotState::Died);
        }
    }
    assert!(taken > 50 && moving > 5, "too few revocations taken ({taken}) or of moving robots ({moving})");
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

/// A launch of real robots (their gateways' and firmware's own code) where
/// nothing goes wrong.
fn real_robots(seed: u64, change: impl FnOnce(&mut Schedule)) -> (Schedule, Report) {
    let case = Case::small(seed);
    let mut schedule = Schedule::clean(seed, case.robots).with_real_robots();
    change(&mut schedule);
    let report = harness::run(&case, &schedule);
    harness::check(&report, &schedule).unwrap_or_else(|e| panic!("seed {seed}: {e}\n{schedule:?}"));
    (schedule, report)
}

#[test]
fn real_robots_are_placed_then_deployed_drive_and_stop_when_stuck() {
    for seed in 0..4 {
        let (_, report) = real_robots(seed, |_| {});
        let ending = report.ending.as_ref().expect("checked");
        assert!(ending.error.is_none(), "seed {seed}: {ending:?}");
        assert!(report.asked_us[0].is_some(), "seed {seed}: the operator was asked to place robot 1");
        assert_eq!(report.deploys_sent[0], 1, "seed {seed}: robot 1 deployed once it was placed");
        assert!(report.drove.contains(&1), "seed {seed}: robot 1's telemetry never said Driving");
        assert!(report.forwarded > 0, "seed {seed}: motion capture's poses went to the gateways");
        assert!(report.stops_sent.iter().sum::<u64>() > 0, "seed {seed}: no stuck robot was told Stop");
    }
}

#[test]
fn a_robot_never_placed_or_moved_off_its_start_is_never_deployed_and_named() {
    use harness::Placing;
    for placing in [Placing::Never, Placing::OffStart(0), Placing::MovedOff(0)] {
        let (_, report) = real_robots(3, |s| s.placing[0] = placing);
        let ending = report.ending.as_ref().expect("checked");
        assert!(matches!(ending.error, Some(Fault::NotPlaced { robot: 1, .. })), "{placing:?}: {ending:?}");
        assert_eq!(report.deploys_sent.iter().sum::<u64>(), 0, "{placing:?}: nothing deployed");
        let asked = report.asked_us[0].expect("asked");
        let timeout = (harness::PLACEMENT.timeout * 1e6) as u64;
        assert!((asked + timeout..asked + timeout + 200_000).contains(&report.end_us), "{placing:?}");
    }
    let (_, late) = real_robots(3, |s| s.placing[0] = Placing::Prompt(2_000_000));
    assert!(late.ending.as_ref().expect("checked").error.is_none(), "placed late, within the timeout");
    assert_eq!(late.deploys_sent[0], 1);
}

#[test]
fn a_cut_robot_link_loses_the_robot_within_500_ms_and_its_firmware_stops_it() {
    let (_, report) = real_robots(0, |s| {
        s.robot_cuts.push(Partition { robot: 1, from_us: 1_500_000, until_us: 6_000_000 });
    });
    assert!(report.faults.iter().any(|f| f.0 == 1), "the cut was taken as a fault: {:?}", report.faults);
    let noticed = report.noticed.iter().find(|n| n.0 == 1).expect("robot 1's loss noticed");
    assert!((1_500_000..2_000_000).contains(&noticed.1), "noticed at {} µs", noticed.1);
    assert!(report.deaths[0].is_some(), "robot 1 is gone for the launch");
}

#[test]
fn a_gateway_cut_off_from_the_orchestrator_stops_its_robot_within_the_failsafe_grace() {
    let (_, report) = real_robots(0, |s| {
        s.remote = true;
        s.partitions.push(Partition { robot: 1, from_us: 1_500_000, until_us: 8_000_000 });
    });
    assert!(report.drove.contains(&1));
    assert_eq!(report.tripped, vec![1], "robot 1's gateway's failsafe fired");
}
