//! What a launch reports about itself: lockstep tick numbers that do not
//! depend on how fast agents start, and real-time runs that say when the
//! agents could not keep up.

use bycoms_tests::{swarm_name, Proc};
use serde_json::Value;
use std::time::Duration;

fn launch(extra: &[&str]) -> Value {
    let swarm = swarm_name("report");
    let out = Proc::orchestrator(&[&["launch", "--json", "--swarm", &swarm], extra].concat())
        .wait(Duration::from_secs(60));
    assert_eq!(out.status.code(), Some(0), "{extra:?}: {}", out.stderr);
    out.json()
}

/// Every robot's deployment and decision tick, and the ticks of the run.
fn tick_numbers(j: &Value) -> Vec<Option<u64>> {
    let robots = j["robots"].as_array().expect("robots");
    let mut v: Vec<Option<u64>> =
        robots.iter().flat_map(|r| [r["deployed_tick"].as_u64(), r["decided_tick"].as_u64()]).collect();
    v.push(j["ticks"].as_u64());
    v
}

#[test]
fn lockstep_tick_numbers_do_not_depend_on_when_agents_register() {
    // With prespawn the next agent has usually registered long before the
    // gate opens; without it, it registers only then. Same ticks either way.
    let prespawned = tick_numbers(&launch(&[]));
    let late = tick_numbers(&launch(&["--no-prespawn"]));
    assert!(prespawned.iter().all(Option::is_some), "{prespawned:?}");
    assert_eq!(prespawned, late);
    assert_eq!(prespawned, tick_numbers(&launch(&[])), "run to run");
}

/// At the fastest speed-up allowed the agents may or may not keep up; the
/// summary says which, consistently, and a run that could not keep up says
/// so on the terminal. (Speeds beyond what any machine keeps up with, such
/// as 100000, are refused: `orchestrator/tests/cli.rs`.)
#[test]
fn a_realtime_run_at_the_fastest_speed_says_whether_it_kept_up() {
    let swarm = swarm_name("fast");
    let speed = bycoms_runtime::MAX_SPEED.to_string();
    let args = ["launch", "--json", "--swarm", &swarm, "--clock", "realtime", "--speed", &speed];
    let out = Proc::orchestrator(&args).wait(Duration::from_secs(60));
    assert!(matches!(out.status.code(), Some(0 | 3)), "{}", out.stderr);
    let j = out.json();
    let rt = &j["realtime"];
    let missed = rt["missed_periods"].as_u64().expect("missed periods");
    let periods = rt["periods"].as_u64().expect("periods");
    assert!(periods > 0, "{rt}");
    let faithful = rt["faithful"].as_bool().expect("faithful");
    assert_eq!(faithful, missed as f64 <= 0.01 * (periods + missed) as f64, "{rt}");
    let achieved = rt["achieved_speed"].as_f64().expect("achieved speed");
    assert!(
        achieved <= bycoms_runtime::MAX_SPEED && achieved == j["sim_speed"].as_f64().expect("sim speed"),
        "{j}"
    );
    let said = out.stderr.contains(&format!("could not keep up with {speed}× real time"));
    assert_eq!(said, !faithful, "{}", out.stderr);
    // Every robot's agent was started once.
    assert!(out.stderr.matches("robot 2: agent started").count() <= 1, "{}", out.stderr);
}
