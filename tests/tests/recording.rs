//! `launch --record` writes every message and gate event to an MCAP file
//! that reads back with exactly the counts the launch reports, and whose
//! per-topic counts match what the run did.

use bycoms_record::recover;
use bycoms_tests::{swarm_name, Proc};
use std::time::Duration;

#[test]
fn the_recording_reads_back_with_what_the_launch_wrote() {
    let swarm = swarm_name("rec");
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("launch.mcap");
    let out = Proc::orchestrator(&[
        "launch",
        "--swarm",
        &swarm,
        "--json",
        "--record",
        path.to_str().expect("utf-8"),
    ])
    .wait(Duration::from_secs(60));
    assert_eq!(out.status.code(), Some(0), "{}", out.stderr);
    let j = out.json();
    let recovered = recover(&path).expect("readable MCAP");
    assert!(recovered.is_complete(), "{:?}", recovered.stopped_by);
    assert_eq!(j["recording"]["messages"], recovered.messages);
    let counts = &recovered.counts;
    for (topic, n) in counts {
        assert_eq!(j["recording"]["counts"][topic], *n, "{topic}");
    }
    let count = |leaf: &str| counts.get(&format!("bycoms/{swarm}/{leaf}")).copied().unwrap_or(0);
    // Gate: 3 deployments, 2 stuck, 1 arrival.
    assert_eq!(count("gate"), 6);
    assert_eq!(count("gate/json"), 6, "every gate event also as JSON");
    assert_eq!((count("run"), count("summary")), (1, 1));
    assert_eq!(count("events"), 3, "one spawn event per agent");
    // Each robot's pose topic: its start pose, then one pose per tick it
    // answered from then on, up to its verdict: a stuck robot froze and is
    // parked, so it is ticked no more once judged; the one that arrived
    // ended the run. A tick the launch sent again (an answer later than
    // usual on a loaded machine: `resends`) is answered again with the same
    // pose, never stepped twice: at most one more pose per re-send.
    let ticks = j["ticks"].as_u64().expect("ticks");
    let resends = j["resends"].as_u64().expect("resends");
    for (i, robot) in j["robots"].as_array().expect("robots").iter().enumerate() {
        let deployed = robot["deployed_tick"].as_u64().expect("deployed");
        let decided = robot["decided_tick"].as_u64().expect("decided");
        assert!(decided <= ticks);
        let poses = count(&format!("robot/{}/pose", i + 1));
        let answered = decided - deployed + 2;
        assert!(
            (answered..=answered + resends).contains(&poses),
            "robot {}: {poses} poses for {answered} answered ticks and {resends} re-sends",
            i + 1
        );
        assert!(count(&format!("robot/{}/to_agent", i + 1)) > robot["steps"].as_u64().expect("steps"));
    }
    let reports: u64 = (1..=3).map(|k| count(&format!("robot/{k}/from_agent"))).sum();
    assert!(reports > ticks, "TickDone, Status, Register, Heartbeat");
}
