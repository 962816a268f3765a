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
//! `BYCOMS_SIM_SEED=<seed> cargo test -p bycoms-launch --test launch_sim -- one_seed --nocapture`.
//! `BYCOMS_SIM_SCHEDULES` sets how many schedules `schedules_keep_the_properties` draws
//! (default 10 000).

use bycoms_launch::agents::Gone;
use bycoms_launch::config::{Missing, OnDeath};
use bycoms_launch::core::{DiedWhen, Fault, SlotState};
use bycoms_launch::harness::{self, Case, Crash, Foreign, Partition, Report, Schedule};
use bycoms_launch::Outcome;
use bycoms_protocol::msg::GateKind;
use bycoms_sim::runner::RobotRunEnd;

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
        "replay: BYCOMS_SIM_SEED={seed} cargo test -p bycoms-launch --test launch_sim -- one_seed --nocapture"
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
type Played = (String, Option<String>, u64, u64, [bool; 7]);

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
                // The wind-down ended an agent that had not left (late or hung),
                // and let every running agent leave by itself within the grace.
                report.wound.as_ref().is_some_and(|w| !w.ended.is_empty()),
                report.wound.as_ref().is_some_and(|w| w.ended.is_empty() && !w.told.is_empty()),
                schedule.gateways && report.deploys_sent.iter().sum::<u64>() > 0,
                schedule.gateways && matches!(ending.error, Some(Fault::NotPlaced { .. })),
            ];
            (format!("{:?}", ending.outcome), error, report.bad, report.resends, covered)
        })
        .collect();
    let mut outcomes = std::collections::BTreeMap::new();
    let mut errors = std::collections::BTreeMap::new();
    let (mut bad, mut resends) = (0u64, 0u64);
    let mut covered = [0u64; 7];
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
         wind-downs that ended an agent, wind-downs that every agent left in time, \
         gateway agents deployed, robots never placed: {covered:?}"
    );
    // The schedules reach every kind of ending, or they test too little.
    if count >= 1000 {
        // Real robots are one schedule in 200 (they cost the most): their
        // kinds are required from 5 000 schedules on.
        let kinds = if count >= 5000 { covered.len() } else { 5 };
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

/// `report`'s launch ended as `simulate` runs `case`: outcome, budget, and
/// every robot's end, steps and position, bit for bit.
fn assert_simulates(case: &Case, report: &Report, what: &str) {
    let expected = bycoms_sim::run(&case.terrain, &case.run_config());
    let ending = report.ending.as_ref().unwrap_or_else(|| panic!("{what}: {:?}", report.failure));
    let outcome = match expected.outcome {
        bycoms_sim::RunOutcome::Arrived => Outcome::Arrived,
        bycoms_sim::RunOutcome::TimeLimit => Outcome::TimeLimit,
        bycoms_sim::RunOutcome::RobotsExhausted => Outcome::RobotsExhausted,
    };
    assert_eq!(ending.outcome, outcome, "{what}");
    assert_eq!(report.spent, expected.steps, "{what}: steps");
    for run in &expected.robots {
        let (state, steps, pose) = report.robots[run.id as usize - 1];
        let want = match run.end {
            RobotRunEnd::Stuck => SlotState::Stuck,
            RobotRunEnd::Arrived => SlotState::Arrived,
            RobotRunEnd::Moving => SlotState::Unfinished,
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

/// [`same_run`], and the views showed the same poses (those the core
/// applied, `Output::Moved`), whenever they came: what forged and foreign
/// traffic must not change either.
fn same_run_and_views(a: &Report, b: &Report, what: &str) {
    same_run(a, b, what);
    let shown = |r: &Report| {
        r.moved.iter().map(|(_, id, p)| (*id, p.step, p.x.to_bits(), p.y.to_bits())).collect::<Vec<_>>()
    };
    assert_eq!(shown(a), shown(b), "{what}: the poses shown");
}

/// The case where robot 1 moves for a while first (a wall far away).
fn long_case() -> Case {
    let mut case = Case::small(0);
    case.robots = 3;
    case
}

/// Stops and revocations at seeded moments.
#[path = "launch_sim/lab_day.rs"]
mod lab_day;
/// Parity with `simulate` and what a tick wakes.
#[path = "launch_sim/parity.rs"]
mod parity;
/// Real robots behind gateways.
#[path = "launch_sim/real_robots.rs"]
mod real_robots;
/// Agents that die, never come, come twice or late; crashes and cuts noticed.
#[path = "launch_sim/supervision.rs"]
mod supervision;
/// Forged and foreign traffic, partitions, hand-found defects.
#[path = "launch_sim/traffic.rs"]
mod traffic;
/// What lockstep waits for, and re-sends.
#[path = "launch_sim/waits.rs"]
mod waits;
