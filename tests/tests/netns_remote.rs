//! `orchestrator launch --agents remote` across two "hosts" (network
//! namespaces joined by a veth link, `bycoms_tests::netns`): the
//! orchestrator in `a`, the three `sim-agent`s in `b`.
//!
//! * lockstep over the link gives exactly the in-process `simulate` result;
//! * a short cut during a lockstep run (within the link grace): the
//!   orchestrator records each agent's outage, the clock waits, and once the
//!   link is back the run resumes and still gives exactly the `simulate`
//!   result, every robot deployed once;
//! * a cut longer than the link grace: every loss is recorded, then the
//!   gate's dead-robot policy applies (the moving robot is a beacon where
//!   last seen, the others are never deployed), no robot is deployed twice,
//!   the launch ends with a clear outcome instead of hanging, and the
//!   agents, past their `--orchestrator-grace`, stop their robots.
//!
//! * a short cut during a real-time run: recorded, ridden out, a clear
//!   outcome (real time is not exact).
//!
//! Each test is `#[ignore = "needs root …"]`; asked for where namespaces
//! are not permitted (not root, no `ip`), it fails, saying why.

use bycoms_sim::terrain::to_text;
use bycoms_sim::{run, RunConfig, RunResult};
use bycoms_study::scenario::{load, TerrainSource};
use bycoms_tests::netns::{two_hosts, Host, TwoHosts};
use bycoms_tests::{simulate_differences, swarm_name, Finished, Proc};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The paper's three-robot case (long-obstacle, ε 3): expected result and terrain file.
fn world(dir: &Path) -> (RunResult, PathBuf) {
    let terrain = load(&TerrainSource::Scenario("long-obstacle".into())).expect("built-in scenario").terrain;
    let mut cfg = RunConfig::paper(3.0);
    cfg.max_robots = Some(3);
    cfg.time_limit = 10_000.0;
    let path = dir.join("terrain.txt");
    std::fs::write(&path, to_text(&terrain)).expect("write terrain");
    (run(&terrain, &cfg), path)
}

/// The clock of a lockstep launch (the agents' default).
const LOCKSTEP: &[&str] = &["--clock", "lockstep"];

/// The orchestrator in `host`, listening on its address (free port), on
/// `clock`, and the endpoint it logged.
fn orchestrator_in(
    host: &Host,
    swarm: &str,
    terrain: &Path,
    clock: &[&str],
    extra: &[&str],
) -> (Proc, String) {
    let listen = host.endpoint(0);
    let terrain = terrain.to_str().expect("utf-8 path");
    let mut args = vec!["launch", "--agents", "remote", "--transport", "zenoh", "--listen", &listen];
    args.extend(clock);
    args.extend(["--json", "--swarm", swarm, "--robots", "3", "--eps", "3"]);
    args.extend(["--terrain", terrain, "--time-limit", "10000"]);
    args.extend(extra);
    let orch = host.start("orchestrator", &args);
    let endpoint = orch.logged_endpoint(&format!("tcp/{}:", host.addr), Duration::from_secs(20));
    (orch, endpoint)
}

/// Robot `robot`'s agent in `host`, connecting to `endpoint`. Its exit
/// notes (debug: ticks stepped on a stale goal bearing) are on its stderr.
fn agent_in(host: &Host, endpoint: &str, swarm: &str, terrain: &Path, robot: u32, extra: &[&str]) -> Proc {
    let robot = robot.to_string();
    let terrain = terrain.to_str().expect("utf-8 path");
    let mut args = vec!["--transport", "zenoh", "--connect", endpoint, "--swarm", swarm, "--swarm-size", "3"];
    args.extend(["--robot", &robot, "--terrain", terrain, "--eps", "3"]);
    args.extend(extra);
    host.start_with_env("sim-agent", &args, &[("RUST_LOG", "info,bycoms_sim_agent::cli=debug")])
}

#[test]
#[ignore = "needs root and iproute2 (network namespaces)"]
fn lockstep_across_two_hosts_gives_the_simulate_result() {
    let hosts = two_hosts("remote-parity");
    let dir = tempfile::tempdir().expect("temp dir");
    let (expected, terrain) = world(dir.path());
    let swarm = swarm_name("netns-parity");
    let (orch, endpoint) = orchestrator_in(&hosts.a, &swarm, &terrain, LOCKSTEP, &[]);
    let agents: Vec<Proc> =
        (1..=3).map(|k| agent_in(&hosts.b, &endpoint, &swarm, &terrain, k, &[])).collect();
    let out = orch.wait(Duration::from_secs(180));
    assert_simulate_result(&expected, &out.json(), &out.stderr);
    assert_eq!(out.status.code(), Some(0));
    for (i, a) in agents.into_iter().enumerate() {
        let done = a.wait(Duration::from_secs(20));
        assert_eq!(done.status.code(), Some(0), "agent {}: {}", i + 1, done.stderr);
    }
}

/// The launch's summary `j` is the in-process result, bit for bit.
fn assert_simulate_result(expected: &RunResult, j: &serde_json::Value, stderr: &str) {
    assert_eq!(j["outcome"], "arrived", "stderr:\n{stderr}");
    let differences = simulate_differences(expected, j);
    assert!(differences.is_empty(), "{differences:#?}\nstderr:\n{stderr}");
}

#[test]
#[ignore = "needs root and iproute2 (network namespaces)"]
fn a_short_cut_is_ridden_out_and_the_run_still_gives_the_simulate_result() {
    let hosts = two_hosts("remote-heal");
    let dir = tempfile::tempdir().expect("temp dir");
    let (expected, terrain) = world(dir.path());
    let swarm = swarm_name("netns-heal");
    let (orch, agents) = ride_out_a_short_cut(&hosts, &swarm, &terrain, LOCKSTEP);
    let out = orch.out;
    let j = out.json();
    assert_simulate_result(&expected, &j, &out.stderr);
    assert_eq!(out.status.code(), Some(0), "stderr:\n{}", out.stderr);
    assert_outages_ended_after_the_link(&j, &out.stderr, &orch.cut);
    assert!(j["resends"].as_u64().expect("resends") >= 1, "what was lost in the cut was sent again: {j}");
    assert_deployed_at_most_once(&out.stderr);
    for (i, done) in agents_done(agents).iter().enumerate() {
        assert_eq!(done.status.code(), Some(0), "agent {}: {}", i + 1, done.stderr);
        // The re-sends after the cut left no tick stepped on a stale bearing.
        assert!(
            !done.stderr.contains("stepped on an earlier tick's goal bearing"),
            "agent {}: {}",
            i + 1,
            done.stderr
        );
    }
}

/// When the link was cut and restored, unix ms.
struct Cut {
    at_ms: u64,
    restored_ms: u64,
}

/// A finished launch and its cut.
struct CutRun {
    out: Finished,
    cut: Cut,
}

/// The orchestrator in `a` and three agents in `b` on `clock`, both sides
/// riding out 20 s; once robot 1 is deployed the link is cut until the
/// orchestrator has seen every agent's link go (within its 2 s heartbeat
/// timeout at worst), then restored. The finished launch and the still
/// running agents.
fn ride_out_a_short_cut(
    hosts: &TwoHosts,
    swarm: &str,
    terrain: &Path,
    clock: &[&str],
) -> (CutRun, Vec<Proc>) {
    let (orch, endpoint) = orchestrator_in(&hosts.a, swarm, terrain, clock, &["--unreachable-grace", "20"]);
    let mut flags = vec!["--orchestrator-grace", "20"];
    flags.extend(clock);
    let agents: Vec<Proc> =
        (1..=3).map(|k| agent_in(&hosts.b, &endpoint, swarm, terrain, k, &flags)).collect();
    registered_and_deployed(&orch, 3);
    let at_ms = unix_ms();
    hosts.cut().expect("cut");
    every_robot_logged(&orch, "link lost", Duration::from_secs(10));
    hosts.restore().expect("restore");
    let restored_ms = unix_ms();
    let out = orch.wait(Duration::from_secs(180));
    (CutRun { out, cut: Cut { at_ms, restored_ms } }, agents)
}

/// Outages were seen and recorded, each after the cut, and each ended
/// after the link did.
fn assert_outages_ended_after_the_link(j: &serde_json::Value, stderr: &str, cut: &Cut) -> usize {
    let robots = j["robots"].as_array().expect("robots");
    let outages: Vec<&serde_json::Value> =
        robots.iter().flat_map(|r| r["outages"].as_array().expect("outages")).collect();
    assert!(!outages.is_empty(), "no outage recorded:\n{stderr}");
    for o in &outages {
        let lost = o["lost_unix_ms"].as_u64().expect("lost");
        let back = o["back_unix_ms"].as_u64().expect("every outage ended");
        println!(
            "outage noticed {} ms after the cut, over {} ms after the link was restored",
            lost.saturating_sub(cut.at_ms),
            back.saturating_sub(cut.restored_ms)
        );
        assert!(lost >= cut.at_ms && back >= cut.restored_ms, "{o}");
    }
    outages.len()
}

fn assert_deployed_at_most_once(stderr: &str) {
    for k in 1..=3 {
        let deployed = stderr.matches(&format!("robot {k}: deployed at")).count();
        assert!(deployed <= 1, "robot {k} deployed {deployed} times:\n{stderr}");
    }
}

/// Each agent, once it ended (20 s at most).
/// Waits until every one of `robots` agents has registered (and so has
/// seen the orchestrator's liveliness token: its failsafe is armed) and
/// robot 1 is deployed. Robot 1 goes as soon as it is ready, before the
/// others; a cut before an agent ever saw the orchestrator would test
/// something else (that agent then waits for an orchestrator to come).
fn registered_and_deployed(orch: &Proc, robots: u32) {
    let mut registered = std::collections::BTreeSet::new();
    let mut deployed = false;
    orch.stderr_line(Duration::from_secs(30), |l| {
        if let Some(k) = (1..=robots).find(|k| l.contains(&format!("robot {k}: agent registered"))) {
            registered.insert(k);
        }
        deployed |= l.contains("robot 1: deployed at");
        (registered.len() == robots as usize && deployed).then_some(())
    })
    .expect("every agent registered and robot 1 deployed");
}

/// Waits until the orchestrator has logged `what` ("robot K: WHAT …") for
/// each of the three robots; panics after `timeout`.
fn every_robot_logged(orch: &Proc, what: &str, timeout: Duration) {
    let mut left: Vec<u32> = vec![1, 2, 3];
    orch.stderr_line(timeout, |l| {
        left.retain(|k| !l.contains(&format!("robot {k}: {what}")));
        left.is_empty().then_some(())
    })
    .unwrap_or_else(|| panic!("no \"robot K: {what}\" line within {timeout:?} for robots {left:?}"));
}

fn agents_done(agents: Vec<Proc>) -> Vec<Finished> {
    agents.into_iter().map(|a| a.wait(Duration::from_secs(20))).collect()
}

#[test]
#[ignore = "needs root and iproute2 (network namespaces)"]
fn a_cut_longer_than_the_grace_is_recorded_and_ends_the_run_cleanly() {
    let hosts = two_hosts("remote-cut");
    let dir = tempfile::tempdir().expect("temp dir");
    let (_, terrain) = world(dir.path());
    let swarm = swarm_name("netns-cut");
    let (orch, endpoint) =
        orchestrator_in(&hosts.a, &swarm, &terrain, LOCKSTEP, &["--unreachable-grace", "0.5"]);
    let grace = ["--orchestrator-grace", "0.5"];
    let agents: Vec<Proc> =
        (1..=3).map(|k| agent_in(&hosts.b, &endpoint, &swarm, &terrain, k, &grace)).collect();
    registered_and_deployed(&orch, 3);
    let cut_at = Instant::now();
    let cut_unix_ms = unix_ms();
    hosts.cut().expect("cut");
    // The link stays cut until the orchestrator has given every robot up:
    // its own verdict that the cut outlasted its 0.5 s link grace (the loss
    // is seen within the 2 s heartbeat timeout at worst: zenoh may close a
    // dead transport late). The run's outcome is then settled. (Left cut,
    // the launch still ends, but zenoh's session close waits out its
    // timeout, 20 to 30 s here, on the transports it still holds open.)
    every_robot_logged(&orch, "agent lost", Duration::from_secs(20));
    hosts.restore().expect("restore");
    let out = orch.wait(Duration::from_secs(60));
    println!("launch ended {:?} after the cut", cut_at.elapsed());
    let j = out.json();
    // A clear outcome: every agent was lost, no robot is left to deploy.
    assert_eq!(j["outcome"], "robots_exhausted", "stderr:\n{}", out.stderr);
    for (i, robot) in j["robots"].as_array().expect("robots").iter().enumerate() {
        let death = &robot["death"];
        let reason = death["reason"].as_str().unwrap_or_default();
        assert!(reason.contains("link to the orchestrator was lost"), "robot {}: {death}", i + 1);
        let lost = robot["outages"][0]["lost_unix_ms"].as_u64().expect("the outage is recorded");
        assert!(robot["outages"][0]["back_unix_ms"].is_null(), "robot {}: {robot}", i + 1);
        let after = lost.saturating_sub(cut_unix_ms);
        println!("robot {}: loss noticed {after} ms after the cut", i + 1);
        // The lease is 400 ms (the heartbeat timeout 2 s when zenoh is late).
        assert!(after < 2500, "robot {}: noticed {after} ms after the cut", i + 1);
    }
    assert_eq!(j["robots"][0]["end"], "died", "the moving robot is a beacon where last seen: {j}");
    assert_deployed_at_most_once(&out.stderr);
    for (i, done) in agents_done(agents).iter().enumerate() {
        // Past its grace an agent stops its robot and exits (4). One whose
        // own side did not see the link go (zenoh closing late) is shut
        // down by the orchestrator once the link is back (0).
        let code = done.status.code();
        println!("agent {}: exit {code:?}", i + 1);
        assert!(matches!(code, Some(4) | Some(0)), "agent {}: {code:?} {}", i + 1, done.stderr);
        if code == Some(4) {
            assert!(done.stderr.contains("robot stopped, exiting"), "agent {}: {}", i + 1, done.stderr);
        }
        // The re-sends after the cut left no tick stepped on a stale bearing.
        assert!(
            !done.stderr.contains("stepped on an earlier tick's goal bearing"),
            "agent {}: {}",
            i + 1,
            done.stderr
        );
    }
}

/// Real time (at 10×) across a short cut: the agents drive on by
/// themselves meanwhile, with the last bearing they had; the orchestrator
/// records each outage, judges the poses that come once the link is back,
/// and the run still ends with a clear outcome, every robot deployed at
/// most once, every agent shut down cleanly. (Real time is not exact, so
/// the outcome is not compared with `simulate`.)
#[test]
#[ignore = "needs root and iproute2 (network namespaces)"]
fn a_short_cut_in_real_time_is_ridden_out() {
    let hosts = two_hosts("remote-rt");
    let dir = tempfile::tempdir().expect("temp dir");
    let (_, terrain) = world(dir.path());
    let swarm = swarm_name("netns-rt");
    let (run, agents) =
        ride_out_a_short_cut(&hosts, &swarm, &terrain, &["--clock", "realtime", "--speed", "10"]);
    let out = run.out;
    let j = out.json();
    let outcome = j["outcome"].as_str().unwrap_or_default();
    assert!(matches!(outcome, "arrived" | "robots_exhausted"), "outcome {outcome}:\n{}", out.stderr);
    assert_eq!(out.status.code(), Some(if outcome == "arrived" { 0 } else { 3 }), "{}", out.stderr);
    let outages = assert_outages_ended_after_the_link(&j, &out.stderr, &run.cut);
    println!(
        "real time across a cut: {outcome}, {} steps, {} robots, {outages} outages",
        j["steps"], j["robots_used"]
    );
    for (i, robot) in j["robots"].as_array().expect("robots").iter().enumerate() {
        assert!(robot["death"].is_null(), "robot {} died: {robot}", i + 1);
    }
    assert_deployed_at_most_once(&out.stderr);
    for (i, done) in agents_done(agents).iter().enumerate() {
        assert_eq!(done.status.code(), Some(0), "agent {}: {}", i + 1, done.stderr);
    }
}

fn unix_ms() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).expect("clock").as_millis() as u64
}
