//! A lab day (issue 34): `orchestrator status` and `orchestrator stop`
//! against a real launch, from another process, over this host's control
//! socket (iceoryx2 launch) and over zenoh (`--connect`), where a robot
//! is also revoked (`orchestrator revoke`) before the stop.
//!
//! `status --watch` is read line by line while the launch runs and after it
//! ends (it must say the launch is gone, and end with 0 on Ctrl-C).
//!
//! The launch runs in real time at 1×, so it is still running when asked;
//! every wait has a deadline. The stop's rule itself (every running robot
//! told `Stop` in one step, who and why recorded) is tested in virtual
//! time by `orchestrator/launch/tests/launch_sim.rs`; here the whole path: the
//! command, the launch's answer, its summary and exit code.

use bycoms_tests::{agents_of, bin, signal, swarm_name, wait_for, Proc};
use serde_json::Value;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

/// Runs `orchestrator ARGS` to its end (20 s at most).
fn orchestrator(args: &[&str]) -> bycoms_tests::Finished {
    Proc::orchestrator(args).wait(Duration::from_secs(20))
}

/// `status --json` until robot 1 moves: the status line of `swarm`.
fn status_when_moving(swarm: &str, via: &[&str]) -> Value {
    wait_for(Duration::from_secs(20), || {
        let args = [&["status", "--json", "--swarm", swarm][..], via].concat();
        let out = orchestrator(&args);
        let line: Value = serde_json::from_str(out.stdout.lines().next()?).ok()?;
        (line["status"]["robots"][0]["state"] == "moving").then_some(line)
    })
    .expect("status shows robot 1 moving within 20 s")
}

/// `orchestrator status --watch --json` of one swarm, read line by line as
/// it redraws; killed when dropped.
struct Watcher {
    child: Child,
    lines: Receiver<String>,
}

impl Watcher {
    fn start(swarm: &str) -> Watcher {
        let mut child = Command::new(bin("orchestrator"))
            .args(["status", "--watch", "--json", "--interval", "0.2", "--swarm", swarm])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("orchestrator starts");
        let lines = bycoms_tests::stdout_lines(&mut child);
        Watcher { child, lines }
    }

    /// The first line, within 20 s, that `accept` takes.
    fn line_where(&self, what: &str, accept: impl Fn(&Value) -> bool) -> Value {
        let deadline = Instant::now() + Duration::from_secs(20);
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            let Ok(line) = self.lines.recv_timeout(left) else { break };
            let v: Value = serde_json::from_str(&line).unwrap_or_else(|e| panic!("not JSON ({e}): {line}"));
            if accept(&v) {
                return v;
            }
        }
        panic!("status --watch printed no {what} within 20 s");
    }

    /// Ctrl-C: it ends with 0 within 10 s.
    fn interrupt(mut self) {
        signal(self.child.id(), nix::sys::signal::Signal::SIGINT);
        let status = wait_for(Duration::from_secs(10), || self.child.try_wait().expect("try_wait"))
            .expect("status --watch ends within 10 s of Ctrl-C");
        assert_eq!(status.code(), Some(0), "status --watch ends with 0 on Ctrl-C");
    }
}

impl Drop for Watcher {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Stops `launch` with `stop --now` through `via`, and checks its answer,
/// the launch's end and its summary's record of the stop.
fn stop_now(launch: Proc, swarm: &str, via: &[&str]) {
    let args = [&["stop", "--now", "--swarm", swarm, "--why", "e2e lab day"][..], via].concat();
    let stop = orchestrator(&args);
    assert_eq!(stop.status.code(), Some(0), "{}", stop.stderr);
    assert!(stop.stdout.starts_with(&format!("stopping swarm {swarm} (orchestrator pid {})", launch.pid())));
    // Answered once the robots answered: the simulated agents say they stopped.
    assert!(stop.stdout.contains(" robots said they stopped (the last after "), "{}", stop.stdout);
    let ended = launch.wait(Duration::from_secs(20));
    assert_eq!(ended.status.code(), Some(130), "a stopped launch exits 130: {}", ended.stderr);
    let summary = ended.json();
    assert_eq!(summary["outcome"], "interrupted");
    let record = &summary["stop"];
    assert_eq!(record["now"], true);
    assert_eq!(record["why"], "e2e lab day");
    assert!(record["who"].as_str().is_some_and(|w| w.starts_with("orchestrator stop (")), "{record}");
    // Robot 1 (moving) and robot 2 (started, waiting its turn) were told.
    let told: Vec<u64> = record["told"].as_array().expect("told").iter().filter_map(Value::as_u64).collect();
    assert!(told.starts_with(&[1]) && told.len() >= 2, "{record}");
    assert!(ended.stderr.contains("every running robot was told to stop"), "{}", ended.stderr);
    // Each agent told answered that its robot stopped, in well under the wait.
    let answered: Vec<u64> =
        record["answered"].as_array().expect("answered").iter().filter_map(|a| a["robot"].as_u64()).collect();
    let mut sorted = answered.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, told, "{record}");
    assert_eq!(record["unanswered"].as_array().map(Vec::len), Some(0), "{record}");
    let slowest =
        record["answered"].as_array().into_iter().flatten().filter_map(|a| a["after_us"].as_u64()).max();
    assert!(slowest.is_some_and(|us| us < 1_000_000), "{record}");
    assert!(ended.stderr.contains("every robot told answered that it stopped"), "{}", ended.stderr);
}

#[test]
fn status_and_stop_now_from_another_terminal() {
    let swarm = swarm_name("labday");
    let launch =
        Proc::orchestrator(&["launch", "--clock", "realtime", "--speed", "1", "--swarm", &swarm, "--json"]);
    let line = status_when_moving(&swarm, &[]);
    let s = &line["status"];
    assert_eq!((s["swarm"].as_str(), s["clock"].as_str()), (Some(swarm.as_str()), Some("realtime")));
    assert_eq!(s["pid"].as_u64(), Some(u64::from(launch.pid())));
    assert!(s["robots"][0]["pose_age_s"].as_f64().is_some_and(|a| a < 2.0), "{s}");
    assert!(!agents_of(&swarm).is_empty());
    // Another swarm asked for: the one that runs is named.
    let other = orchestrator(&["status", "--swarm", "no_such_swarm"]);
    assert_eq!(other.status.code(), Some(1), "{}", other.stdout);
    assert!(other.stderr.contains("no launch of swarm \"no_such_swarm\" runs"), "{}", other.stderr);
    let running = other.stderr.split("running: ").nth(1).and_then(|r| r.lines().next()).unwrap_or_default();
    assert!(running.split(", ").any(|s| s == swarm), "{}", other.stderr);
    // A watcher redraws the launch, then says it is gone once it ends.
    let watcher = Watcher::start(&swarm);
    watcher.line_where("status of the swarm", |v| v["status"]["swarm"] == swarm.as_str());
    stop_now(launch, &swarm, &[]);
    let gone = watcher.line_where("line saying the launch is gone", |v| v["gone"].is_string());
    assert_eq!(gone["swarm"], swarm.as_str(), "{gone}");
    watcher.interrupt();
    // Gone: no launch of that swarm answers any more.
    let after = orchestrator(&["status", "--swarm", &swarm]);
    assert_eq!(after.status.code(), Some(1), "{}", after.stdout);
    assert!(
        after.stderr.contains(&format!("no launch of swarm \"{swarm}\" runs on this host")),
        "{}",
        after.stderr
    );
    let again = orchestrator(&["stop", "--swarm", &swarm]);
    assert_eq!(again.status.code(), Some(1));
    assert!(again.stderr.contains(&format!("no launch of swarm \"{swarm}\" runs")), "{}", again.stderr);
}

#[test]
fn status_and_stop_now_over_zenoh() {
    let swarm = swarm_name("labdayz");
    let launch = Proc::orchestrator(&[
        "launch",
        "--clock",
        "realtime",
        "--speed",
        "1",
        "--transport",
        "zenoh",
        "--listen",
        "tcp/127.0.0.1:0",
        "--swarm",
        &swarm,
        "--json",
    ]);
    let endpoint = launch.logged_endpoint("tcp/127.0.0.1:", Duration::from_secs(20));
    let via = ["--connect", endpoint.as_str()];
    let line = status_when_moving(&swarm, &via);
    assert_eq!(line["status"]["transport"], "zenoh");
    // `revoke` over the same queryable: robot 3, not started yet (robots
    // 1 and 2 run on, and are the ones `stop --now` tells).
    let revoke = orchestrator(&[&["revoke", "--robot", "3", "--swarm", &swarm][..], &via].concat());
    assert_eq!(revoke.status.code(), Some(0), "{}", revoke.stderr);
    assert!(revoke.stdout.contains("its agent was not running"), "{}", revoke.stdout);
    eprintln!("{}", revoke.stdout.trim());
    stop_now(launch, &swarm, &via);
}
