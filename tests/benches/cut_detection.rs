//! How soon a launch sees a cut link, over many cuts (issue 19): the
//! orchestrator in one network namespace, three remote agents in the other
//! (`bycoms_tests::netns`), one real-time launch with a 20 s link grace,
//! and `CUTS` (default 30) cuts of the veth link while it runs. Each cut
//! lasts until the orchestrator has logged every robot's link lost (or
//! 5 s), then the link is restored and the next cut waits until every link
//! is back. The launch's summary records each outage's `lost_unix_ms`; the
//! bench prints, per robot and cut, how long after the cut the loss was
//! seen, and the distribution against the 500 ms target.
//!
//! `cargo bench -p bycoms-tests --bench cut_detection` (root; release
//! binaries first: `cargo build --release --bins`). Prints a notice and
//! nothing else where namespaces are not permitted.

use bycoms_runtime::failsafe::FailsafeArgs;
use bycoms_runtime::{BusArgs, Transport};
use bycoms_sim_agent::{AgentArgs, Clock};
use bycoms_tests::netns::{not_permitted, TwoHosts};
use bycoms_tests::{swarm_name, Proc};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// The launch's and the agents' real-time speed-up: slow, so the run
/// outlasts every cut.
const SPEED: f64 = 0.05;

fn unix_ms() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).expect("clock").as_millis() as u64
}

/// Waits until the orchestrator has logged "robot K: `what`" for robots
/// 1..=3; whether it did within `timeout`.
fn every_robot_logged(orch: &Proc, what: &str, timeout: Duration) -> bool {
    let mut left: Vec<u32> = vec![1, 2, 3];
    orch.stderr_line(timeout, |l| {
        left.retain(|k| !l.contains(&format!("robot {k}: {what}")));
        left.is_empty().then_some(())
    })
    .is_some()
}

fn main() {
    if let Some(why) = not_permitted() {
        println!("cut_detection: skipped, network namespaces are not permitted here: {why}");
        return;
    }
    let cuts: usize = std::env::var("CUTS").ok().and_then(|s| s.parse().ok()).unwrap_or(30);
    let hosts = TwoHosts::create("cuts").expect("namespaces");
    let dir = tempfile::tempdir().expect("temp dir");
    let terrain = dir.path().join("terrain.txt");
    let world = bycoms_study::scenario::load(&bycoms_study::scenario::TerrainSource::Scenario(
        "long-obstacle".into(),
    ))
    .expect("built-in scenario");
    std::fs::write(&terrain, bycoms_sim::terrain::to_text(&world.terrain)).expect("terrain");
    let terrain = terrain.to_str().expect("utf-8");
    let swarm = swarm_name("cuts");
    let listen = hosts.a.endpoint(0);
    // Slow real time: the run must outlast every cut.
    let speed = SPEED.to_string();
    let clock = ["--clock", "realtime", "--speed", speed.as_str()];
    let mut args = vec!["launch", "--agents", "remote", "--transport", "zenoh", "--listen", &listen];
    args.extend(clock);
    args.extend(["--json", "--swarm", &swarm, "--robots", "3", "--eps", "3", "--terrain", terrain]);
    args.extend(["--time-limit", "100000", "--unreachable-grace", "20"]);
    let orch = hosts.a.start("orchestrator", &args);
    let endpoint = orch.logged_endpoint(&format!("tcp/{}:", hosts.a.addr), Duration::from_secs(20));
    let agents: Vec<Proc> = (1..=3u32)
        .map(|k| {
            let agent = AgentArgs {
                terrain: Some(terrain.into()),
                eps: Some(3.0),
                swarm_size: Some(3),
                clock: Clock::Realtime,
                speed: SPEED,
                bus: BusArgs {
                    transport: Transport::Zenoh,
                    connect: vec![endpoint.clone()],
                    zenoh_config: None,
                },
                failsafe: FailsafeArgs { grace_s: 20.0, ..FailsafeArgs::default() },
                ..AgentArgs::new(&swarm, k)
            };
            let flags = agent.to_flags();
            hosts.b.start("sim-agent", &flags.iter().map(String::as_str).collect::<Vec<_>>())
        })
        .collect();
    orch.stderr_line(Duration::from_secs(30), |l| l.contains("robot 1: deployed at").then_some(()))
        .expect("robot 1 deployed");
    let mut cut_at = Vec::new();
    for i in 0..cuts {
        cut_at.push(unix_ms());
        hosts.cut().expect("cut");
        let seen = every_robot_logged(&orch, "link lost", Duration::from_secs(5));
        hosts.restore().expect("restore");
        let back = every_robot_logged(&orch, "link back", Duration::from_secs(20));
        eprintln!("cut {}: every loss seen {seen}, every link back {back}", i + 1);
    }
    nix::sys::signal::kill(nix::unistd::Pid::from_raw(orch.pid() as i32), nix::sys::signal::Signal::SIGINT)
        .expect("SIGINT");
    let out = orch.wait(Duration::from_secs(60));
    drop(agents);
    let j = out.json();
    let mut seen_ms: Vec<u64> = Vec::new();
    let mut unmatched = 0;
    for (k, robot) in j["robots"].as_array().expect("robots").iter().enumerate() {
        let lost: Vec<u64> = robot["outages"]
            .as_array()
            .map(|o| o.iter().filter_map(|o| o["lost_unix_ms"].as_u64()).collect())
            .unwrap_or_default();
        // Each outage belongs to the last cut before it.
        for l in &lost {
            match cut_at.iter().rev().find(|&&c| c <= *l) {
                Some(c) => seen_ms.push(l - c),
                None => unmatched += 1,
            }
        }
        println!("robot {}: {} outages for {} cuts", k + 1, lost.len(), cut_at.len());
    }
    seen_ms.sort_unstable();
    if seen_ms.is_empty() {
        println!("no outage recorded:\n{}", out.stderr);
        return;
    }
    let q = |p: f64| bycoms_runtime::stats::quantile(&seen_ms, p).unwrap_or_default();
    let over = seen_ms.iter().filter(|&&ms| ms > 500).count();
    println!(
        "cut seen after (ms, n = {}): min {}  p50 {}  p90 {}  max {};  over 500 ms: {over};  outages before any cut: {unmatched}",
        seen_ms.len(),
        q(0.0),
        q(0.5),
        q(0.9),
        q(1.0)
    );
}
