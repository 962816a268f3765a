//! Without faults a lockstep launch is `simulate`'s run, bit for bit, and a tick
//! wakes only the agents that must step.

use super::*;
use bycoms_sim::terrain::Terrain;

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
/// costs it nothing: it is ticked only while it settles, never merely
/// because the robot before it moves (issue 35: a prespawned agent used to
/// be ticked every tick, then every tick that sent it a beacon). With
/// fewer beacons than one send holds, as here, that is one tick per
/// deployment (and its re-sends); the results are unchanged (the parity
/// tests above).
#[test]
fn an_agent_whose_robot_is_not_deployed_is_ticked_only_while_it_settles() {
    let (mut idle, mut moving) = (0, 0);
    for seed in 0..120 {
        let case = Case::small(seed);
        let report = harness::run(&case, &Schedule::clean(seed, case.robots));
        assert!(report.ending.is_some(), "seed {seed}: {:?}", report.failure);
        let idle_ticks: u64 = report.idle_ticks.iter().sum();
        let deployed = report.deploys_sent.iter().filter(|&&d| d > 0).count() as u64;
        let bound = deployed + report.resends;
        assert!(idle_ticks <= bound, "seed {seed}: {idle_ticks} idle ticks, at most {bound} expected");
        idle += idle_ticks;
        moving += report.ticks;
    }
    assert!(idle > 0, "settling robots are ticked");
    assert!(idle * 4 < moving, "{idle} idle ticks in {moving} ticks");
}

/// The harness's agents are built as the launch's spawned agents are:
/// from how they join it and its run settings (no restated periods: they
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

/// More beacons than one send holds, and agents that register at
/// different times, change nothing: a settling agent is sent what its
/// settling tick's send did not hold with the last tick again, to it
/// alone, so when its robot is deployed does not depend on how fast its
/// agent started, or whether every agent was there from the start (remote
/// agents). Issue 35: it was sent them with ticks of their own, which
/// stepped every creeping robot, and `launch --robots 120` on the all-stuck
/// terrain ended after 1383 to 1399 steps in three runs. (Turning is
/// ignored, as `bench crowd` does, so every robot sticks at once; `simulate`
/// has no such rule, so the runs are compared with each other.)
#[test]
fn how_soon_agents_register_changes_nothing_with_many_beacons() {
    // The start walled in: every robot sticks at once and stays a beacon.
    let terrain: Terrain = ".....\n..G..\n.###.\n.#S#.\n.###.\n".parse().expect("terrain");
    let case =
        Case { terrain, robots: 45, time_limit: 300.0, noise: None, stop_turn_rate: 0.0, ..Case::small(0) };
    let mut runs = Vec::new();
    let starts =
        [("at once", 1, false), ("late", 20_000, false), ("very late", 400_000, false), ("remote", 1, true)];
    for (what, delay_us, remote) in starts {
        let mut schedule = Schedule::clean(0, case.robots);
        schedule.register_delay_us = vec![Some(delay_us); case.robots as usize];
        // Remote agents are all there from the start, waiting their turn.
        schedule.remote = remote;
        let report = harness::run(&case, &schedule);
        harness::check(&report, &schedule).unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(report.ending.as_ref().map(|e| e.outcome), Some(Outcome::RobotsExhausted), "{what}");
        runs.push((what, report));
    }
    // Every robot a beacon: robot 34 on settles with more than one send holds.
    let stuck = runs[0].1.robots.iter().filter(|r| r.0 == SlotState::Stuck).count();
    assert_eq!(stuck, 45, "every robot sticks");
    for (what, report) in &runs[1..] {
        same_run(&runs[0].1, report, what);
    }
}

/// The walled crowd of 45 robots and every `every`-th small case below
/// `below`, with turning ignored: robots turning in place are judged, and
/// the next ones deployed, within a few ticks, as in a crowd.
fn crowd_cases(below: u64, every: usize) -> Vec<Case> {
    let walled: Terrain = ".....\n..G..\n.###.\n.#S#.\n.###.\n".parse().expect("terrain");
    let crowd = Case { terrain: walled, robots: 45, time_limit: 300.0, noise: None, ..Case::small(0) };
    let mut cases = vec![crowd];
    cases.extend((0..below).step_by(every).map(Case::small));
    cases.into_iter().map(|case| Case { stop_turn_rate: 0.0, ..case }).collect()
}

/// What a run's summary states of its robots: their last modes, the
/// beacons' last positions, the steps and the ticks.
fn summary_of(r: &Report) -> (Vec<u8>, Vec<(u64, u64)>, u64, u64) {
    let d = r.decided.as_ref().expect("a summary");
    let modes: Vec<u8> = d.robots.iter().map(|s| s.mode).collect();
    let beacons: Vec<(u64, u64)> = d.beacons.iter().map(|v| (v.x.to_bits(), v.y.to_bits())).collect();
    (modes, beacons, d.steps, d.ticks)
}

/// Issue 35: a robot judged stuck that still creeps is stepped many
/// periods per message (`ToAgent::Ticks`), and what its agent sends for a
/// later step is held until that step's tick: the run is the one with a
/// `Tick` a period, bit for bit, the beacons' last positions and the
/// robots' last modes included. (Turning is ignored, so robots turning in
/// place are judged stuck and creep on; `simulate` has no such rule, so
/// the runs are compared with each other. The parity tests above run
/// ahead too: the harness's spawned agents are the launch's own.)
#[test]
fn creeping_robots_run_ahead_and_the_run_is_the_same() {
    let (mut runs, mut periods) = (0, 0);
    for (k, case) in crowd_cases(108, 3).into_iter().enumerate() {
        let ahead = Schedule::clean(k as u64, case.robots);
        let one = Schedule { one_tick_a_period: true, ..ahead.clone() };
        let (a, b) = (harness::run(&case, &ahead), harness::run(&case, &one));
        harness::check(&a, &ahead).unwrap_or_else(|e| panic!("case {k}: {e}"));
        same_run(&b, &a, &format!("case {k}, runs ahead"));
        assert_eq!(summary_of(&b), summary_of(&a), "case {k}: modes, beacons, steps, ticks");
        assert!(b.runs_sent.iter().all(|r| r.0 == 0), "case {k}: one tick a period");
        runs += a.runs_sent.iter().map(|r| r.0).sum::<u64>();
        periods += a.runs_sent.iter().map(|r| r.1).sum::<u64>();
    }
    assert!(runs > 100, "only {runs} runs ahead");
    // Runs end at multiples of 32: all but a robot's first are 32 long.
    assert!(periods > runs * 16, "{periods} periods in {runs} runs");
}

/// Lockstep starts agents `STARTS_AHEAD` robots ahead of the one that
/// moves (issue 35: a crowd used to wait for each next agent to register),
/// and that changes when they start, nothing else: the same gate events,
/// robots, modes, beacons and ticks as with one ahead, on the walled crowd
/// and small cases. The agents started two or more turns early show the
/// setting is used (none are with one ahead).
#[test]
fn agents_started_further_ahead_change_only_when_they_start() {
    // Robots whose agent was started before the robot two turns before it
    // was deployed.
    let early = |r: &Report| -> usize {
        let deployed: Vec<u64> = r
            .gates
            .iter()
            .zip(&r.gate_times_us)
            .filter(|(g, _)| g.kind == GateKind::Deployed)
            .map(|(_, &t)| t)
            .collect();
        deployed.iter().zip(r.started_us.iter().skip(2)).filter(|(&d, s)| s.is_some_and(|s| s < d)).count()
    };
    let (mut early_ahead, mut early_one) = (0, 0);
    for (k, case) in crowd_cases(60, 5).into_iter().enumerate() {
        let ahead = Schedule::clean(k as u64, case.robots);
        let one = Schedule { starts_ahead: Some(1), ..ahead.clone() };
        let (a, b) = (harness::run(&case, &ahead), harness::run(&case, &one));
        harness::check(&a, &ahead).unwrap_or_else(|e| panic!("case {k}: {e}"));
        assert_eq!((&a.ending, &a.gates), (&b.ending, &b.gates), "case {k}: ending, gate events");
        // A robot never deployed ends as its agent was left: started
        // (registered) or not.
        let ends = |r: &Report| -> Vec<_> {
            let waiting = |s: SlotState| if s == SlotState::Registered { SlotState::Waiting } else { s };
            r.robots
                .iter()
                .map(|(s, n, p)| (waiting(*s), *n, p.map(|p| (p.x.to_bits(), p.y.to_bits()))))
                .collect()
        };
        assert_eq!(ends(&a), ends(&b), "case {k}: robots");
        assert_eq!(summary_of(&b), summary_of(&a), "case {k}: modes, beacons, steps, ticks");
        (early_ahead, early_one) = (early_ahead + early(&a), early_one + early(&b));
    }
    assert!(early_ahead > 30, "only {early_ahead} agents started two turns early");
    assert_eq!(early_one, 0, "one ahead: no agent starts two turns early");
}
