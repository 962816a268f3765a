//! A bounded soak test: many launches with random bus faults (drop, delay,
//! duplicate, reorder on the orchestrator's side) and random `kill -9` of
//! agents, each checked for the invariants of a trustworthy run:
//!
//! * it ends within its timeout with a clear outcome, and the exit code is
//!   the one that outcome promises;
//! * no robot is deployed twice, and each robot's gate decisions come in
//!   order (deployed, then at most one verdict, steps never going back);
//! * no agent process and no iceoryx2 node of the swarm is left behind;
//! * the recording is complete and readable, with exactly the gate events
//!   the summary reports.
//!
//! Everything random is drawn from one seed (`BYCOMS_SOAK_SEED`, default 1)
//! through the product's own seed mixing, so a failing launch is reproduced
//! by its number. `BYCOMS_SOAK_LAUNCHES` sets how many (default 100; the
//! closing note of the operations issue reports a longer run) and
//! `BYCOMS_SOAK_PARALLEL` how many run at once (default 3).

use bycoms_runtime::exit;
use bycoms_sim::seed::mix;
use bycoms_tests::{agents_of, signal, swarm_name, wait_for, Proc};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

fn env_u64(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// A uniform draw in `0..1` from (seed, launch, what).
fn unit(seed: u64, launch: u64, what: u64) -> f64 {
    (mix(mix(seed, launch), what) >> 11) as f64 / (1u64 << 53) as f64
}

struct Plan {
    config: String,
    /// Kill one agent (robot, after ms) with SIGKILL.
    kill: Option<(u32, u64)>,
}

fn plan(seed: u64, i: u64) -> Plan {
    let r = |what| unit(seed, i, what);
    let config = format!(
        "robots = 3\n\
         [faults]\ndrop = {:.4}\nduplicate = {:.4}\ndelay = {:.4}\ndelay_ms = {}\nreorder = {:.4}\nseed = {}\n\
         [supervision]\ntick_timeout = 0.5\nheartbeat_timeout = 1.0\nregister_timeout = 10.0\n",
        // Half the launches lose messages: in lockstep a lost TickDone costs
        // the agent (killed after tick_timeout), so those rarely arrive.
        if r(9) < 0.5 { 0.0 } else { 0.005 * r(1) },
        0.05 * r(2),
        0.05 * r(3),
        1 + (20.0 * r(4)) as u64,
        0.05 * r(5),
        mix(seed, i),
    );
    let kill = (r(6) < 0.5).then(|| (1 + (3.0 * r(7)) as u32, (400.0 * r(8)) as u64));
    Plan { config, kill }
}

/// The gate events of a recording's JSON gate channel, in file order.
fn gate_events(path: &Path, swarm: &str) -> Vec<Value> {
    let bytes = std::fs::read(path).expect("read recording");
    let topic = format!("bycoms/{swarm}/gate/json");
    let mut events = Vec::new();
    for message in mcap::MessageStream::new(&bytes).expect("MCAP header") {
        let message = message.expect("a readable message");
        if message.channel.topic == topic {
            events.push(serde_json::from_slice(&message.data).expect("gate event JSON"));
        }
    }
    events
}

fn check_gate_order(events: &[Value], what: &str) {
    let mut per_robot: BTreeMap<u64, Vec<(String, u64)>> = BTreeMap::new();
    for e in events {
        let robot = e["robot"].as_u64().unwrap_or_else(|| panic!("{what}: no robot in {e}"));
        let kind = e["decision"].as_str().unwrap_or_else(|| panic!("{what}: no decision in {e}")).to_string();
        let step = e["step"].as_u64().unwrap_or_else(|| panic!("{what}: no step in {e}"));
        per_robot.entry(robot).or_default().push((kind, step));
    }
    for (robot, seq) in per_robot {
        assert_eq!(seq.first().map(|(k, _)| k.as_str()), Some("deployed"), "{what}: robot {robot}: {seq:?}");
        let deployed = seq.iter().filter(|(k, _)| k == "deployed").count();
        assert_eq!(deployed, 1, "{what}: robot {robot} deployed {deployed} times: {seq:?}");
        assert!(seq.len() <= 2, "{what}: robot {robot} judged more than once: {seq:?}");
        assert!(seq.windows(2).all(|w| w[0].1 <= w[1].1), "{what}: robot {robot} steps go back: {seq:?}");
    }
}

#[test]
fn launches_survive_random_faults_and_kills() {
    let seed = env_u64("BYCOMS_SOAK_SEED", 1);
    let launches = env_u64("BYCOMS_SOAK_LAUNCHES", 100);
    // Launches mostly wait (on ticks, timeouts, kills), so several run at
    // once; each has its own swarm, files and plan, so which run together
    // changes no draw. The invariants hold whatever the machine's load
    // (an agent starved past its tick timeout is one more fault).
    let parallel = env_u64("BYCOMS_SOAK_PARALLEL", 3).max(1);
    let dir = tempfile::tempdir().expect("temp dir");
    let outcomes: std::sync::Mutex<BTreeMap<String, u32>> = std::sync::Mutex::new(BTreeMap::new());
    std::thread::scope(|scope| {
        for worker in 0..parallel {
            let (dir, outcomes) = (dir.path(), &outcomes);
            scope.spawn(move || {
                for i in (worker..launches).step_by(parallel as usize) {
                    let outcome = one_launch(seed, i, dir);
                    *outcomes
                        .lock()
                        .unwrap_or_else(std::sync::PoisonError::into_inner)
                        .entry(outcome)
                        .or_default() += 1;
                }
            });
        }
    });
    let outcomes = outcomes.into_inner().unwrap_or_else(std::sync::PoisonError::into_inner);
    println!("soak: {launches} launches ({parallel} at a time), seed {seed}: {outcomes:?}");
    assert_eq!(outcomes.values().sum::<u32>() as u64, launches);
}

/// Launch `i` of the soak with `seed`, in `dir`: checked; its outcome.
fn one_launch(seed: u64, i: u64, dir: &Path) -> String {
    let plan = plan(seed, i);
    let what = format!("launch {i} (seed {seed})");
    let swarm = swarm_name(&format!("soak{i}"));
    let config = dir.join(format!("soak{i}.toml"));
    let record = dir.join(format!("soak{i}.mcap"));
    std::fs::write(&config, &plan.config).expect("write config");
    let args = ["launch", "--json", "--swarm", &swarm, "--config"];
    let mut args: Vec<&str> = args.to_vec();
    args.extend([config.to_str().expect("utf-8"), "--record", record.to_str().expect("utf-8")]);
    let proc = Proc::orchestrator(&args);
    if let Some((robot, after_ms)) = plan.kill {
        // The fault's own timing (a seeded moment of the run), not a wait for something.
        std::thread::sleep(Duration::from_millis(after_ms));
        let pid = wait_for(Duration::from_secs(2), || {
            agents_of(&swarm).into_iter().find(|&(_, r)| r == robot).map(|(p, _)| p)
        });
        if let Some(pid) = pid {
            signal(pid, nix::sys::signal::Signal::SIGKILL);
        }
    }
    let out = proc.wait(Duration::from_secs(90));
    let j = out.json();
    let outcome = j["outcome"].as_str().unwrap_or_else(|| panic!("{what}: no outcome: {j}")).to_string();
    let expected = match outcome.as_str() {
        "arrived" => exit::SUCCESS,
        "robots_exhausted" | "time_limit" => exit::NOT_ARRIVED,
        "error" => exit::ERROR,
        other => panic!("{what}: unexpected outcome {other}"),
    };
    assert_eq!(out.status.code(), Some(expected), "{what}: {outcome}\n{}", out.stderr);
    if outcome == "error" {
        assert!(j["error"].as_str().is_some_and(|e| !e.is_empty()), "{what}: an error says why: {j}");
    }
    let left = wait_for(Duration::from_secs(5), || agents_of(&swarm).is_empty().then_some(()));
    assert!(left.is_some(), "{what}: agents left behind: {:?}", agents_of(&swarm));
    let recovered = bycoms_record::recover(&record).expect("readable MCAP");
    assert!(recovered.is_complete(), "{what}: {:?}", recovered.stopped_by);
    let events = gate_events(&record, &swarm);
    assert_eq!(
        j["recording"]["counts"][format!("bycoms/{swarm}/gate/json")].as_u64().unwrap_or(0),
        events.len() as u64,
        "{what}"
    );
    check_gate_order(&events, &what);
    let _ = std::fs::remove_file(&record);
    outcome
}
