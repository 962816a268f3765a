//! A launch that spawns its agents over a secured `quic/` endpoint, with the lab's
//! certificates and access-control list from `orchestrator certs`: each
//! agent reads its own `robot-K.json5` (`--agent-zenoh-config
//! DIR/robot-{robot}.json5`) and the run gives the same result as the
//! same launch over iceoryx2 (and the ACL lets each agent ask for the
//! run's settings). Without the agents' configs the launch refuses to start (exit 2)
//! instead of spawning agents that cannot connect. Certificates are
//! generated into a temporary directory; the port is the kernel's.
//!
//! Live revocation (issue 34) over the same QUIC endpoint: remote agents
//! join with their certificates; `orchestrator revoke --robot 1 --certs
//! DIR` takes robot 1's voice away while it moves. zenoh checks no
//! revocation list and the running router keeps its ACL, so robot 1's
//! agent stays connected and keeps reporting: the launch answers within
//! 1 s, tells it `Stop`, counts its reports as dropped, refuses a new
//! agent of it as revoked, and the other robots finish the run; the ACL
//! file denies robot 1 from the next start.

use bycoms_tests::{bin, swarm_name, Proc};
use serde_json::Value;
use std::net::UdpSocket;
use std::time::Duration;

fn free_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0").and_then(|s| s.local_addr()).expect("free port").port()
}

#[test]
fn spawned_agents_join_a_secured_launch_with_their_own_certificates() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().to_str().expect("utf-8 path");
    let endpoint = format!("quic/127.0.0.1:{}", free_port());
    let certs = Proc::orchestrator(&[
        "certs",
        "--robots",
        "3",
        "--out",
        out,
        "--listen",
        &endpoint,
        "--connect",
        &endpoint,
    ])
    .wait(Duration::from_secs(30));
    assert_eq!(certs.status.code(), Some(0), "certs: {}", certs.stderr);
    let orchestrator_config = dir.path().join("orchestrator.json5");
    let agent_config = dir.path().join("robot-{robot}.json5");
    let (orchestrator_config, agent_config) =
        (orchestrator_config.to_str().expect("utf-8"), agent_config.to_str().expect("utf-8"));
    let common =
        ["launch", "--transport", "zenoh", "--listen", &endpoint, "--zenoh-config", orchestrator_config];

    // Without the agents' certificates: refused before anything starts.
    let swarm = swarm_name("quic-refused");
    let mut args = common.to_vec();
    args.extend(["--swarm", &swarm, "--json"]);
    let refused = Proc::orchestrator(&args).wait(Duration::from_secs(30));
    assert_eq!(refused.status.code(), Some(2), "{}", refused.stderr);
    assert!(refused.stderr.contains("agent_zenoh_config"), "{}", refused.stderr);

    // With them: the whole run of three robots over QUIC, as over iceoryx2
    // (about 3 s in a debug build).
    let swarm = swarm_name("quic");
    let mut args = common.to_vec();
    args.extend(["--agent-zenoh-config", agent_config, "--clock", "lockstep", "--swarm", &swarm, "--json"]);
    let run = Proc::orchestrator(&args).wait(Duration::from_secs(120));
    assert_eq!(run.status.code(), Some(0), "{}", run.stderr);
    let j = run.json();
    assert_eq!(j["transport"], "zenoh");
    assert_eq!(j["endpoints"][0], endpoint.as_str(), "{j}");
    assert_eq!(j["outcome"], "arrived", "{}", run.stderr);
    assert_eq!(j["bad_traffic"]["garbage"], 0, "{j}");
    // The ACL lets each robot ask for the run's settings, and each agent
    // found them the same as its own (spawned: flags and stdin).
    let checked = run.stderr.matches("got the run's settings from the orchestrator").count();
    assert_eq!(checked, 3, "every agent got the launch's settings over QUIC:\n{}", run.stderr);

    let swarm = swarm_name("plain");
    let plain = Proc::orchestrator(&["launch", "--clock", "lockstep", "--swarm", &swarm, "--json"])
        .wait(Duration::from_secs(120));
    let t = plain.json();
    for key in ["outcome", "steps", "ticks", "robots_used", "beacons"] {
        assert_eq!(j[key], t[key], "{key}: quic {} vs ipc {}", j[key], t[key]);
    }
}

/// `orchestrator certs` for `robots` robots at `endpoint` into `dir`.
fn certs_for(dir: &std::path::Path, robots: u32, endpoint: &str) {
    let out = dir.to_str().expect("utf-8 path");
    let robots = robots.to_string();
    let args = ["certs", "--robots", &robots, "--out", out, "--listen", endpoint, "--connect", endpoint];
    let certs = Proc::orchestrator(&args).wait(Duration::from_secs(30));
    assert_eq!(certs.status.code(), Some(0), "certs: {}", certs.stderr);
}

/// A remote agent of robot `robot`, started as on its own host: where to
/// connect, with its own certificate's config, its swarm and its id.
fn remote_agent(dir: &std::path::Path, endpoint: &str, swarm: &str, robot: u32) -> Proc {
    let config = dir.join(format!("robot-{robot}.json5"));
    let robot = robot.to_string();
    let config = config.to_str().expect("utf-8 path");
    let args = ["--transport", "zenoh", "--connect", endpoint, "--zenoh-config", config, "--swarm", swarm];
    let args: Vec<String> = args.iter().chain(&["--robot", robot.as_str()]).map(|s| s.to_string()).collect();
    Proc::start(&bin("sim-agent"), &args)
}

/// A real-time launch of 3 remote robots over QUIC with the lab's
/// `config`, at 10× so robot 1 moves long enough to be revoked.
fn revocable_launch(config: &std::path::Path, endpoint: &str, swarm: &str) -> Proc {
    Proc::orchestrator(&[
        "launch",
        "--agents",
        "remote",
        "--transport",
        "zenoh",
        "--listen",
        endpoint,
        "--zenoh-config",
        config.to_str().expect("utf-8 path"),
        "--clock",
        "realtime",
        "--speed",
        "10",
        "--robots",
        "3",
        "--time-limit",
        "300",
        "--swarm",
        swarm,
        "--json",
    ])
}

/// The launch's summary `j` records robot 1's revocation (who, why, its
/// reports dropped), robot 1 as a beacon where it was stopped, and robot 2
/// deployed after it.
fn assert_revoked_in_summary(j: &Value) {
    let record = &j["revoked"][0];
    assert_eq!((record["robot"].as_u64(), record["why"].as_str()), (Some(1), Some("e2e: stolen")), "{j}");
    assert!(record["who"].as_str().is_some_and(|w| w.starts_with("orchestrator revoke (")), "{record}");
    assert!(
        record["dropped"].as_u64().is_some_and(|d| d > 0),
        "its reports were counted as dropped: {record}"
    );
    assert_eq!(j["revoked"].as_array().map(Vec::len), Some(1), "{j}");
    eprintln!("outcome {}, revoked {record}", j["outcome"]);
    let robot1 = &j["robots"][0];
    assert_eq!(robot1["end"], "died", "a beacon where it was stopped: {robot1}");
    assert!(robot1["death"]["reason"].as_str().is_some_and(|r| r.contains("revoked by orchestrator revoke")));
    assert!(j["robots"][1]["deployed_tick"].is_u64(), "robot 2 went on: {j}");
}

#[test]
fn a_robot_revoked_mid_run_over_quic_is_stopped_dropped_refused_and_the_others_finish() {
    let dir = tempfile::tempdir().expect("temp dir");
    let endpoint = format!("quic/127.0.0.1:{}", free_port());
    certs_for(dir.path(), 3, &endpoint);
    let config = dir.path().join("orchestrator.json5");
    let swarm = swarm_name("revoke");
    let launch = revocable_launch(&config, &endpoint, &swarm);
    launch.logged_endpoint("quic/127.0.0.1:", Duration::from_secs(30));
    let agents: Vec<Proc> = (1..=3).map(|k| remote_agent(dir.path(), &endpoint, &swarm, k)).collect();
    launch
        .stderr_line(Duration::from_secs(60), |l| l.contains("robot 1: deployed at").then_some(()))
        .expect("robot 1 is deployed within 60 s");

    // Asked from another terminal of the orchestrator's host, where the
    // lab's certificates are.
    let certs = dir.path().to_str().expect("utf-8 path");
    let asked = std::time::Instant::now();
    let args = ["revoke", "--robot", "1", "--swarm", &swarm, "--certs", certs, "--why", "e2e: stolen"];
    let revoke = Proc::orchestrator(&args).wait(Duration::from_secs(20));
    let command_ms = asked.elapsed().as_millis();
    assert_eq!(revoke.status.code(), Some(0), "{}", revoke.stderr);
    let answered_ms: f64 = revoke
        .stdout
        .split("answered in ")
        .nth(1)
        .and_then(|t| t.split(" ms").next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no answer time in {:?}", revoke.stdout));
    eprintln!("revoke answered in {answered_ms:.1} ms (the whole command: {command_ms} ms)");
    assert!(answered_ms < 1000.0, "the launch answered within 1 s: {}", revoke.stdout);
    assert!(revoke.stdout.contains("told to stop"), "{}", revoke.stdout);
    // The ACL of the next start denies robot 1 everything.
    let acl = bycoms_orchestrator::certs::read_config(&config).expect("the rewritten config");
    assert!(bycoms_orchestrator::certs::revoked_in(&acl).contains(&1), "{acl}");
    // `certs --revoke` reaches the running launch of this lab too (robot
    // 1 again: already revoked, nothing changes).
    let again = Proc::orchestrator(&["certs", "--revoke", "1", "--out", certs]).wait(Duration::from_secs(20));
    assert_eq!(again.status.code(), Some(0), "{}", again.stderr);
    assert!(
        again.stderr.contains(&format!("taken live by the running launch of swarm {swarm}")),
        "{}",
        again.stderr
    );

    // Over QUIC with the orchestrator's own config, as from another
    // terminal of its host: the asker is a client and listens on nothing,
    // so it does not collide with the launch's port.
    let config_text = config.to_str().expect("utf-8 path");
    let args = ["status", "--json", "--swarm", &swarm, "--connect", &endpoint, "--zenoh-config", config_text];
    let status = Proc::orchestrator(&args).wait(Duration::from_secs(20));
    assert_eq!(status.status.code(), Some(0), "{}", status.stderr);
    let line: Value = serde_json::from_str(status.stdout.lines().next().unwrap_or_default())
        .unwrap_or_else(|e| panic!("status --json over QUIC ({e}): {}", status.stdout));
    assert_eq!(line["status"]["revoked"][0]["robot"], 1, "{line}");

    // A new agent for robot 1 is refused as revoked (exit 3).
    let second = remote_agent(dir.path(), &endpoint, &swarm, 1).wait(Duration::from_secs(30));
    assert_eq!(second.status.code(), Some(3), "{}", second.stderr);
    assert!(second.stderr.contains("revoked"), "{}", second.stderr);

    let ended = launch.wait(Duration::from_secs(120));
    let j: Value = ended.json();
    assert!(
        ["arrived", "robots_exhausted", "time_limit"].contains(&j["outcome"].as_str().unwrap_or("")),
        "{j}"
    );
    assert_revoked_in_summary(&j);
    for (i, a) in agents.into_iter().enumerate() {
        let out = a.wait(Duration::from_secs(20));
        assert_eq!(out.status.code(), Some(0), "agent of robot {}: {}", i + 1, out.stderr);
    }
}
