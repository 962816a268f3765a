//! Two launches under one swarm name: the second of a live swarm is refused
//! at once with a clear error and does not disturb the first; once the first
//! is dead (even by `kill -9`) the name is free again and the next launch
//! cleans what it left and runs normally.

use bycoms_tests::{agents_of, swarm_name, wait_for, Proc};
use std::time::Duration;

#[test]
fn a_second_launch_of_a_live_swarm_is_refused_and_a_dead_one_is_reused() {
    let swarm = swarm_name("twice");
    // Real time at 1×: the first launch runs for minutes unless stopped.
    let mut first =
        Proc::orchestrator(&["launch", "--clock", "realtime", "--speed", "1", "--swarm", &swarm, "--json"]);
    wait_for(Duration::from_secs(20), || (!agents_of(&swarm).is_empty()).then_some(()))
        .expect("the first launch started its agents");

    let second = Proc::orchestrator(&["launch", "--swarm", &swarm, "--json"]).wait(Duration::from_secs(20));
    assert_eq!(second.status.code(), Some(2), "a usage error: {}", second.stderr);
    let expected =
        format!("swarm \"{swarm}\" is in use by a running launch (orchestrator pid {})", first.pid());
    assert!(second.stderr.contains(&expected), "{}", second.stderr);
    assert!(second.stdout.is_empty(), "no summary of a run that never started: {}", second.stdout);
    // The first launch's agents were left alone: still exactly its robots.
    let robots: Vec<u32> = agents_of(&swarm).into_iter().map(|(_, r)| r).collect();
    assert!(!robots.is_empty() && robots.iter().all(|&r| r <= 3), "{robots:?}");

    // kill -9: no orderly end, the lock and iceoryx2 leftovers stay behind.
    first.kill();
    drop(first);
    wait_for(Duration::from_secs(5), || agents_of(&swarm).is_empty().then_some(()))
        .expect("the dead launch's agents exit (lifeline)");
    let third = Proc::orchestrator(&["launch", "--swarm", &swarm, "--json"]).wait(Duration::from_secs(60));
    assert_eq!(third.status.code(), Some(0), "{}", third.stderr);
    let j = third.json();
    assert_eq!(j["outcome"], "arrived");
    // The paper's three-robot result, not a corrupted one.
    assert_eq!(j["robots"][2]["end"], "arrived");
    assert_eq!(j["beacons"].as_array().map(Vec::len), Some(2));
}
