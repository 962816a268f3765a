//! `orchestrator launch --agents remote` with `sim-agent`s started by hand
//! (as on other hosts, here on loopback over zenoh):
//!
//! * a lockstep launch gives exactly the in-process `simulate` result, and
//!   every agent exits on `Shutdown` (none is reported as left behind):
//!   agents started with the launch's settings on their command line, and
//!   agents started with only where to connect, their swarm and robot id
//!   (they take the run's settings from the orchestrator);
//! * agents started before the orchestrator wait for it, then for its
//!   settings;
//! * an agent started with other settings (another ε) exits naming the
//!   first difference before it registers, and another agent takes its
//!   robot: the run is unchanged;
//! * a robot whose agent never comes ends the launch (exit 1) with an error
//!   naming it, within the registration timeout;
//! * an agent of a robot outside the launch is counted and refused, and the
//!   launch goes on undisturbed;
//! * a second agent for an already registered robot is refused (exit 3),
//!   counted, and never replaces the first;
//! * clock offsets: an agent whose host clock is 2 s ahead (the test-only
//!   `BYCOMS_TEST_CLOCK_SKEW_MS`) is refused (exit 3) with how to fix it,
//!   healthy ones are taken, and their offsets are in `status` and the
//!   summary;
//! * liveliness: a killed agent is reported lost (its link) within 500 ms;
//!   agents whose orchestrator is gone past `--orchestrator-grace` stop
//!   their robot and exit (status 4) or wait, by `--on-orchestrator-lost`.
//!
//! The orchestrator listens on `tcp/127.0.0.1:0`: it picks a free port and
//! logs it; the test reads the endpoint from that log line before starting
//! the agents.

use crate::SwarmLockFile;
use bycoms_sim::runner::RobotRunEnd;
use bycoms_sim::terrain::to_text;
use bycoms_sim::{run, RunConfig, RunResult};
use bycoms_study::scenario::{load, TerrainSource};
use bycoms_tests::{bin, simulate_differences, swarm_name, Finished, Proc};
use serde_json::Value;
use std::path::PathBuf;
use std::time::{Duration, Instant};

const EPS: &str = "3";
const TIME_LIMIT: &str = "10000";

/// The paper's three-robot case: the expected result and its terrain file.
struct World {
    expected: RunResult,
    dir: tempfile::TempDir,
}

impl World {
    fn long_obstacle() -> Self {
        let terrain =
            load(&TerrainSource::Scenario("long-obstacle".into())).expect("built-in scenario").terrain;
        let mut cfg = RunConfig::paper(3.0);
        cfg.max_robots = Some(3);
        cfg.time_limit = 10_000.0;
        let expected = run(&terrain, &cfg);
        let dir = tempfile::tempdir().expect("temp dir");
        std::fs::write(dir.path().join("terrain.txt"), to_text(&terrain)).expect("write terrain");
        Self { expected, dir }
    }

    fn terrain(&self) -> PathBuf {
        self.dir.path().join("terrain.txt")
    }
}

/// An orchestrator awaiting 3 remote agents, and the endpoint it listens on.
fn orchestrator(world: &World, swarm: &str, extra: &[&str]) -> (Proc, String) {
    orchestrator_on(world, swarm, "tcp/127.0.0.1:0", extra)
}

/// [`orchestrator`] listening on `listen`.
fn orchestrator_on(world: &World, swarm: &str, listen: &str, extra: &[&str]) -> (Proc, String) {
    let terrain = world.terrain();
    let mut args = vec!["launch", "--agents", "remote", "--transport", "zenoh", "--listen", listen];
    args.extend(["--clock", "lockstep", "--json", "--swarm", swarm, "--robots", "3", "--eps", EPS]);
    args.extend(["--terrain", terrain.to_str().expect("utf-8 path"), "--time-limit", TIME_LIMIT]);
    args.extend(extra);
    let orch = Proc::orchestrator(&args);
    let endpoint = orch.logged_endpoint("tcp/127.0.0.1:", Duration::from_secs(20));
    (orch, endpoint)
}

/// A hand-started agent of robot `robot` in a swarm of `size`.
fn agent(world: &World, endpoint: &str, swarm: &str, robot: u32, size: u32) -> Proc {
    agent_with(world, endpoint, swarm, robot, size, &[])
}

/// [`gateway`] with extra flags.
fn agent_with(world: &World, endpoint: &str, swarm: &str, robot: u32, size: u32, extra: &[&str]) -> Proc {
    let args: Vec<String> = [
        "--transport",
        "zenoh",
        "--connect",
        endpoint,
        "--swarm",
        swarm,
        "--swarm-size",
        &size.to_string(),
        "--robot",
        &robot.to_string(),
        "--terrain",
        world.terrain().to_str().expect("utf-8 path"),
        "--eps",
        EPS,
    ]
    .iter()
    .chain(extra)
    .map(|s| s.to_string())
    .collect();
    Proc::start(&bin("sim-agent"), &args)
}

/// An agent of robot `robot` started with only where to connect, its swarm
/// and its robot id (the README's remote example): the run's settings come
/// from the orchestrator.
fn bare_agent(endpoint: &str, swarm: &str, robot: u32) -> Proc {
    let robot = robot.to_string();
    let args = ["--transport", "zenoh", "--connect", endpoint, "--swarm", swarm, "--robot", &robot];
    Proc::start(&bin("sim-agent"), &args.map(String::from))
}

/// Waits for the orchestrator's line saying robot `id`'s agent registered.
fn registered(orch: &Proc, id: u32) {
    let needle = format!("robot {id}: agent registered");
    orch.stderr_line(Duration::from_secs(20), |l| l.contains(&needle).then_some(()))
        .unwrap_or_else(|| panic!("robot {id}'s agent did not register"));
}

/// The launch's summary equals the in-process run, robot by robot, bit for bit.
fn assert_same_as_simulate(out: &Finished, expected: &RunResult) {
    let j = out.json();
    assert_eq!(j["outcome"], "arrived", "stderr:\n{}", out.stderr);
    assert_eq!(out.status.code(), Some(0), "exit code; stderr:\n{}", out.stderr);
    assert_eq!(j["robots"].as_array().map(Vec::len), Some(expected.robots.len()));
    let differences = simulate_differences(expected, &j);
    assert!(differences.is_empty(), "{differences:#?}\nstderr:\n{}", out.stderr);
    assert!(
        !out.stderr.contains("did not exit after Shutdown"),
        "every remote agent exits on Shutdown and is seen to go:\n{}",
        out.stderr
    );
}

/// Each agent ends on its own (after `Shutdown`) with exit code 0.
fn assert_exit_cleanly(agents: Vec<Proc>) {
    for (i, a) in agents.into_iter().enumerate() {
        let out = a.wait(Duration::from_secs(20));
        assert_eq!(out.status.code(), Some(0), "agent #{i}: stderr:\n{}", out.stderr);
    }
}

fn bad(j: &Value, kind: &str) -> u64 {
    j["bad_traffic"][kind].as_u64().unwrap_or_else(|| panic!("bad_traffic.{kind} in {j}"))
}

#[test]
fn lockstep_with_remote_agents_gives_the_simulate_result() {
    let world = World::long_obstacle();
    let ends: Vec<RobotRunEnd> = world.expected.robots.iter().map(|r| r.end).collect();
    assert_eq!(ends, [RobotRunEnd::Stuck, RobotRunEnd::Stuck, RobotRunEnd::Arrived]);
    let swarm = swarm_name("remote");
    let (orch, endpoint) = orchestrator(&world, &swarm, &[]);
    let agents: Vec<Proc> = (1..=3).map(|k| agent(&world, &endpoint, &swarm, k, 3)).collect();
    let out = orch.wait(Duration::from_secs(180));
    assert_same_as_simulate(&out, &world.expected);
    let j = out.json();
    assert_eq!(j["endpoints"][0], endpoint.as_str(), "the summary names the endpoint");
    assert_eq!(bad(&j, "duplicate") + bad(&j, "unknown_robot") + bad(&j, "wrong_version"), 0, "{j}");
    assert_exit_cleanly(agents);
}

#[test]
fn agents_started_with_only_connect_swarm_and_robot_give_the_simulate_result() {
    let world = World::long_obstacle();
    let swarm = swarm_name("remote-bare");
    let (orch, endpoint) = orchestrator(&world, &swarm, &[]);
    let agents: Vec<Proc> = (1..=3).map(|k| bare_agent(&endpoint, &swarm, k)).collect();
    let out = orch.wait(Duration::from_secs(180));
    assert_same_as_simulate(&out, &world.expected);
    let j = out.json();
    assert_eq!(bad(&j, "duplicate") + bad(&j, "unknown_robot") + bad(&j, "wrong_version"), 0, "{j}");
    for (i, a) in agents.into_iter().enumerate() {
        let out = a.wait(Duration::from_secs(20));
        assert_eq!(out.status.code(), Some(0), "agent #{i}: stderr:\n{}", out.stderr);
        assert!(out.stderr.contains("got the run's settings from the orchestrator"), "{}", out.stderr);
    }
}

#[test]
fn agents_started_before_the_orchestrator_wait_for_it_and_its_settings() {
    let world = World::long_obstacle();
    let swarm = swarm_name("remote-early");
    // A free port for the orchestrator-to-be (the OS hands it out).
    let port =
        std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).expect("free port").port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let agents: Vec<Proc> = (1..=3).map(|k| bare_agent(&endpoint, &swarm, k)).collect();
    agents[0]
        .stderr_line(Duration::from_secs(20), |l| {
            l.contains("the orchestrator is not reachable yet").then_some(())
        })
        .expect("the agent says it waits for the orchestrator");
    let (orch, _) = orchestrator_on(&world, &swarm, &endpoint, &[]);
    let out = orch.wait(Duration::from_secs(180));
    assert_same_as_simulate(&out, &world.expected);
    assert_exit_cleanly(agents);
}

#[test]
fn an_agent_with_another_eps_exits_naming_it_and_another_takes_its_robot() {
    let world = World::long_obstacle();
    let swarm = swarm_name("remote-mismatch");
    let (orch, endpoint) = orchestrator(&world, &swarm, &[]);
    let mut agents = vec![bare_agent(&endpoint, &swarm, 1)];
    // Robot 2's agent started by hand with ε = 2 (the launch's is 3).
    let terrain = world.terrain();
    let other = ["--terrain", terrain.to_str().expect("utf-8 path"), "--eps", "2"];
    let wrong = {
        let args: Vec<String> = [
            "--transport",
            "zenoh",
            "--connect",
            &endpoint,
            "--swarm",
            &swarm,
            "--robot",
            "2",
            "--swarm-size",
            "3",
        ]
        .iter()
        .chain(&other)
        .map(|s| s.to_string())
        .collect();
        Proc::start(&bin("sim-agent"), &args).wait(Duration::from_secs(30))
    };
    assert_eq!(wrong.status.code(), Some(3), "refused as by the launch:\n{}", wrong.stderr);
    assert!(
        wrong.stderr.contains("epsilon (--eps): 2 here, 3 in the launch"),
        "the first difference is named:\n{}",
        wrong.stderr
    );
    // The launch goes on: another agent takes robot 2, and the run is the paper's.
    agents.extend((2..=3).map(|k| bare_agent(&endpoint, &swarm, k)));
    let out = orch.wait(Duration::from_secs(180));
    assert_same_as_simulate(&out, &world.expected);
    let j = out.json();
    assert_eq!(bad(&j, "duplicate") + bad(&j, "unknown_robot") + bad(&j, "wrong_version"), 0, "{j}");
    assert_exit_cleanly(agents);
}

#[test]
fn a_robot_whose_agent_never_comes_is_skipped_or_named_with_missing_fail() {
    let world = World::long_obstacle();
    // Skipped at its turn (the default), listed as absent with why.
    let swarm = swarm_name("remote-missing");
    let (orch, endpoint) = orchestrator(&world, &swarm, &["--register-timeout", "3"]);
    let agents: Vec<Proc> = (1..=2).map(|k| agent(&world, &endpoint, &swarm, k, 3)).collect();
    let out = orch.wait(Duration::from_secs(120));
    assert_eq!(out.status.code(), Some(3), "robots exhausted; stderr:\n{}", out.stderr);
    let j = out.json();
    assert_eq!(j["outcome"], "robots_exhausted", "{j}");
    assert_eq!(j["robots"][0]["end"], "stuck", "{j}");
    assert_eq!(j["robots"][2]["end"], "absent", "{j}");
    let why = j["robots"][2]["death"]["reason"].as_str().unwrap_or_default();
    assert!(why.contains("did not register in time"), "{j}");
    assert_exit_cleanly(agents);
    // `--missing fail`: every robot is awaited, and the missing one named.
    let swarm = swarm_name("remote-missing-fail");
    let started = Instant::now();
    let (orch, endpoint) = orchestrator(&world, &swarm, &["--register-timeout", "3", "--missing", "fail"]);
    let agents: Vec<Proc> = (1..=2).map(|k| agent(&world, &endpoint, &swarm, k, 3)).collect();
    let out = orch.wait(Duration::from_secs(60));
    let took = started.elapsed();
    assert_eq!(out.status.code(), Some(1), "stderr:\n{}", out.stderr);
    let j = out.json();
    assert_eq!(j["outcome"], "error");
    let error = j["error"].as_str().expect("an error");
    assert!(error.contains("of robot 3 never registered within 3 s"), "{error}");
    // The registration timeout (3 s) plus start-up and the shutdown grace.
    assert!(took < Duration::from_secs(20), "took {took:?}");
    assert_eq!(j["robots"][0]["end"], "not_deployed", "{j}");
    assert_exit_cleanly(agents);
}

/// Robot 9 when the launch has 3: its reports would go to robot 9's topic,
/// which the launch does not read, so the launch refuses it its settings
/// (the agent names its robot when it asks): the agent exits refused
/// (status 3) saying why, before it ever runs, and the launch counts it as
/// bad traffic (`unknown_robot`) and goes on undisturbed.
#[test]
fn an_agent_of_a_robot_outside_the_launch_is_counted_and_refused() {
    let world = World::long_obstacle();
    let swarm = swarm_name("remote-stranger");
    let (orch, endpoint) = orchestrator(&world, &swarm, &[]);
    let stranger = bare_agent(&endpoint, &swarm, 9).wait(Duration::from_secs(30));
    assert_eq!(stranger.status.code(), Some(3), "the stranger is refused:\n{}", stranger.stderr);
    let why = "refused by the orchestrator for robot 9: robot 9 is not one of the launch's robots \
               (it has robots 1 to 3)";
    assert!(stranger.stderr.contains(why), "{}", stranger.stderr);
    assert!(!stranger.stderr.contains("got the run's settings"), "it never runs:\n{}", stranger.stderr);
    let agents: Vec<Proc> = (1..=3).map(|k| agent(&world, &endpoint, &swarm, k, 3)).collect();
    let out = orch.wait(Duration::from_secs(180));
    assert_same_as_simulate(&out, &world.expected);
    assert!(bad(&out.json(), "unknown_robot") >= 1, "{}", out.json());
    assert!(out.stderr.contains("robot 9 is not one of the launch's robots"), "{}", out.stderr);
    assert_exit_cleanly(agents);
}

#[test]
fn a_second_agent_for_a_registered_robot_is_refused() {
    let world = World::long_obstacle();
    let swarm = swarm_name("remote-twice");
    let (orch, endpoint) = orchestrator(&world, &swarm, &[]);
    let first = agent(&world, &endpoint, &swarm, 1, 3);
    registered(&orch, 1);
    let second = agent(&world, &endpoint, &swarm, 1, 3).wait(Duration::from_secs(20));
    assert_eq!(second.status.code(), Some(3), "the second agent is refused:\n{}", second.stderr);
    assert!(
        second
            .stderr
            .contains("refused by the orchestrator for robot 1: another agent already holds this robot"),
        "{}",
        second.stderr
    );
    let mut agents = vec![first];
    agents.extend((2..=3).map(|k| agent(&world, &endpoint, &swarm, k, 3)));
    let out = orch.wait(Duration::from_secs(180));
    // The first agent stayed robot 1's: the run is the paper's, unchanged.
    assert_same_as_simulate(&out, &world.expected);
    assert!(bad(&out.json(), "duplicate") >= 1, "{}", out.json());
    assert!(out.stderr.contains("robot 1 registered again by another agent"), "{}", out.stderr);
    assert_exit_cleanly(agents);
}

/// A host whose clock is 2 s ahead is refused at registration with how
/// to fix it; healthy agents are taken, their measured offsets shown by
/// `orchestrator status` and in the summary, and the run is unchanged.
#[test]
fn an_agent_whose_clock_is_off_is_refused_and_offsets_are_reported() {
    let world = World::long_obstacle();
    let swarm = swarm_name("remote-clock");
    let (orch, endpoint) = orchestrator(&world, &swarm, &[]);
    let robot = ["--transport", "zenoh", "--connect", &endpoint, "--swarm", &swarm, "--robot", "1"];
    let skew = [(bycoms_protocol::bus::zenoh::clock::SKEW_ENV, "2000")];
    let skewed = Proc::start_with_env(&bin("sim-agent"), &robot.map(String::from), &skew);
    let skewed = skewed.wait(Duration::from_secs(30));
    assert_eq!(skewed.status.code(), Some(3), "refused:\n{}", skewed.stderr);
    let said = &skewed.stderr;
    assert!(said.contains("refused by the orchestrator for robot 1: this host's clock is"), "{said}");
    assert!(said.contains("ms ahead of the orchestrator's, past the launch's limit of 500 ms"), "{said}");
    assert!(said.contains("chrony"), "{said}");
    let mut agents = vec![bare_agent(&endpoint, &swarm, 1)];
    registered(&orch, 1);
    let asked = Proc::orchestrator(&["status", "--json", "--swarm", &swarm, "--connect", &endpoint])
        .wait(Duration::from_secs(20));
    let line: Value = serde_json::from_str(asked.stdout.lines().next().unwrap_or_default())
        .unwrap_or_else(|e| panic!("status --json: {e}\n{}\n{}", asked.stdout, asked.stderr));
    let shown = &line["status"]["robots"][0]["clock"];
    assert!(shown["offset_ms"].as_f64().is_some_and(|ms| ms.abs() < 100.0), "{line}");
    assert!(shown["round_trip_ms"].as_f64().is_some_and(|ms| ms >= 0.0), "{line}");
    agents.extend((2..=3).map(|k| bare_agent(&endpoint, &swarm, k)));
    let out = orch.wait(Duration::from_secs(180));
    assert_same_as_simulate(&out, &world.expected);
    let j = out.json();
    for r in j["robots"].as_array().expect("robots") {
        let clock = &r["clock"];
        assert!(clock["offset_ms"].as_f64().is_some_and(|ms| ms.abs() < 100.0), "{r}");
        assert!(clock["measured_unix_ms"].as_u64().is_some_and(|t| t <= unix_ms()), "{r}");
    }
    assert!(out.stderr.contains("refused: this host's clock is"), "{}", out.stderr);
    assert_exit_cleanly(agents);
}

fn unix_ms() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).expect("clock").as_millis() as u64
}

/// Waits for the orchestrator's line saying robot `id` was deployed.
fn deployed(orch: &Proc, id: u32) {
    let needle = format!("robot {id}: deployed at");
    orch.stderr_line(Duration::from_secs(30), |l| l.contains(&needle).then_some(()))
        .unwrap_or_else(|| panic!("robot {id} was not deployed"));
}

#[test]
fn a_killed_remote_agent_is_lost_within_half_a_second() {
    let world = World::long_obstacle();
    let swarm = swarm_name("remote-killed");
    // Heartbeats alone would take 5 s: only the liveliness token can be this fast.
    let (orch, endpoint) = orchestrator(&world, &swarm, &["--heartbeat-timeout", "5"]);
    let mut agents: Vec<Proc> = (1..=3).map(|k| agent(&world, &endpoint, &swarm, k, 3)).collect();
    deployed(&orch, 1);
    let killed_at = unix_ms();
    agents[0].kill();
    let out = orch.wait(Duration::from_secs(180));
    let j = out.json();
    let death = &j["robots"][0]["death"];
    assert!(
        death["reason"].as_str().is_some_and(|r| r.contains("link to the orchestrator was lost")),
        "{death}; stderr:\n{}",
        out.stderr
    );
    // Seen at once (the outage), treated as dead after the link grace
    // (default 2 s: it might have come back).
    let lost = j["robots"][0]["outages"][0]["lost_unix_ms"].as_u64().expect("the outage is recorded");
    let after = lost.saturating_sub(killed_at);
    assert!(after < 500, "robot 1's loss noticed {after} ms after the kill");
    let noticed = death["noticed_unix_ms"].as_u64().expect("noticed_unix_ms");
    assert!(noticed >= lost + 2000, "dead only after the 2 s grace: lost {lost}, dead {noticed}");
    assert!(death["reason"].as_str().is_some_and(|r| r.contains("within the 2 s link grace")), "{death}");
    // The gate's dead-robot policy (beacon where last seen) then applies.
    assert_eq!(j["robots"][0]["end"], "died", "{j}");
    assert_exit_cleanly(agents.split_off(1));
}

#[test]
fn agents_stop_their_robot_when_the_orchestrator_is_gone() {
    let world = World::long_obstacle();
    let swarm = swarm_name("remote-orphans");
    let _lock_file = SwarmLockFile::of(&swarm);
    // The agents' failsafe grace must be no shorter than the launch's link
    // grace, or the launch refuses them (an agent whose failsafe stops its
    // robot for good while the launch still waits for it).
    let (mut orch, endpoint) = orchestrator(&world, &swarm, &["--unreachable-grace", "0.5"]);
    let grace = ["--orchestrator-grace", "0.5"];
    let exiting: Vec<Proc> = (1..=2).map(|k| agent_with(&world, &endpoint, &swarm, k, 3, &grace)).collect();
    let wait = ["--orchestrator-grace", "0.5", "--on-orchestrator-lost", "wait"];
    let waiting = agent_with(&world, &endpoint, &swarm, 3, 3, &wait);
    // Robot 1 goes as soon as it is ready: wait until every agent has
    // registered (and so has seen the orchestrator) before killing it.
    let mut registered = std::collections::BTreeSet::new();
    let mut robot_1_deployed = false;
    orch.stderr_line(Duration::from_secs(30), |l| {
        if let Some(k) = (1..=3).find(|k| l.contains(&format!("robot {k}: agent registered"))) {
            registered.insert(k);
        }
        robot_1_deployed |= l.contains("robot 1: deployed at");
        (registered.len() == 3 && robot_1_deployed).then_some(())
    })
    .expect("every agent registered and robot 1 deployed");
    orch.kill();
    let lost_at = Instant::now();
    for (i, a) in exiting.into_iter().enumerate() {
        let out = a.wait(Duration::from_secs(10));
        assert_eq!(out.status.code(), Some(4), "agent {}: stderr:\n{}", i + 1, out.stderr);
        assert!(out.stderr.contains("robot stopped, exiting"), "{}", out.stderr);
    }
    // Lease (≤ 0.4 s, or at once: the socket closed) + grace (0.5 s) + slack.
    assert!(lost_at.elapsed() < Duration::from_secs(5), "took {:?}", lost_at.elapsed());
    waiting
        .stderr_line(Duration::from_secs(10), |l| l.contains("robot stopped, waiting").then_some(()))
        .expect("the waiting agent stopped its robot");
    // The `wait` agent stays (`--on-orchestrator-lost wait`: robot stopped,
    // process kept until the orchestrator is back or a signal ends it): it
    // is alive after its failsafe tripped, its loop still runs (it ends on
    // SIGTERM, exit 130 as every interrupted agent), and it never ended by itself for the lost
    // orchestrator (exit 4, "robot stopped, exiting").
    assert!(!bycoms_tests::is_zombie(waiting.pid()), "the `wait` agent stays");
    bycoms_tests::signal(waiting.pid(), nix::sys::signal::Signal::SIGTERM);
    let out = waiting.wait(Duration::from_secs(10));
    assert_eq!(
        out.status.code(),
        Some(130),
        "the `wait` agent ended by SIGTERM, not by itself: {}",
        out.stderr
    );
    assert!(!out.stderr.contains("robot stopped, exiting"), "{}", out.stderr);
}
