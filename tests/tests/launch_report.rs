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

#[test]
fn a_realtime_run_that_cannot_keep_up_says_so() {
    let swarm = swarm_name("fast");
    let args = ["launch", "--json", "--swarm", &swarm, "--clock", "realtime", "--speed", "100000"];
    let out = Proc::orchestrator(&args).wait(Duration::from_secs(60));
    assert!(matches!(out.status.code(), Some(0 | 3)), "{}", out.stderr);
    let j = out.json();
    let rt = &j["realtime"];
    let missed = rt["missed_periods"].as_u64().expect("missed periods");
    let periods = rt["periods"].as_u64().expect("periods");
    // The whole summary and the log on failure: seen once in 20 runs on a
    // heavily loaded machine (64 periods, none missed), not understood yet.
    assert!(missed > periods / 100 && periods > 0, "{rt}\nsummary: {j}\nstderr:\n{}", out.stderr);
    assert_eq!(rt["faithful"], false, "{rt}");
    let achieved = rt["achieved_speed"].as_f64().expect("achieved speed");
    assert!(achieved < 100_000.0 && achieved == j["sim_speed"].as_f64().expect("sim speed"), "{j}");
    assert!(out.stderr.contains("could not keep up with 100000× real time"), "{}", out.stderr);
}
