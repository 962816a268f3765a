//! Supervision end to end: a dead agent is noticed within 500 ms and its
//! robot becomes a beacon; no agent outlives a `kill -9`ed orchestrator by
//! more than 2 s (and the recording survives it); Ctrl-C ends a launch in
//! order with a finished recording; an agent that never registers ends the
//! launch with a clear error.
//!
//! Every process started here is killed and reaped on drop ([`Proc`]);
//! every wait has a deadline; swarm names are unique per test.

use crate::SwarmLockFile;
use bycoms_record::{read_counts, recover};
use bycoms_tests::{agents_of, is_zombie, signal, swarm_name, wait_for, wait_for_pose, Proc};
use iceoryx2::node::NodeView;
use nix::sys::signal::Signal;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

fn unix_ms() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).expect("clock").as_millis() as u64
}

/// Waits until robot `robot`'s agent of `swarm` runs; returns its pid.
fn agent_pid(swarm: &str, robot: u32) -> u32 {
    wait_for(Duration::from_secs(20), || {
        agents_of(swarm).into_iter().find(|(_, r)| *r == robot).map(|(p, _)| p)
    })
    .unwrap_or_else(|| panic!("robot {robot}'s agent of {swarm} never appeared"))
}

#[test]
fn a_killed_agent_is_noticed_within_500_ms_and_becomes_a_beacon() {
    let swarm = swarm_name("dead");
    // Real time, 10× speed: robot 1 needs ~2 s of wall time to reach the
    // obstacle; it is killed on the way.
    let args = ["launch", "--clock", "realtime", "--speed", "10", "--robots", "2", "--time-limit", "60"];
    let launch = Proc::orchestrator(&[&args[..], &["--json", "--swarm", &swarm]].concat());
    let victim = agent_pid(&swarm, 1);
    // Kill it once it is on its way (its pose has left the start).
    wait_for_pose(&swarm, 2, 1, Duration::from_secs(30), |p| p.x > 20.0).expect("robot 1 moves");
    let killed_at = unix_ms();
    signal(victim, Signal::SIGKILL);
    let out = launch.wait(Duration::from_secs(60));
    let j = out.json();
    assert!(matches!(out.status.code(), Some(0 | 3)), "{}", out.stderr);
    let r1 = &j["robots"][0];
    assert_eq!(r1["end"], "died", "{}", out.stderr);
    let noticed = r1["death"]["noticed_unix_ms"].as_u64().expect("death time");
    let latency = noticed.saturating_sub(killed_at);
    assert!(latency < 500, "death noticed after {latency} ms");
    assert!(r1["death"]["reason"].as_str().is_some_and(|r| r.contains("signal: 9")), "{r1}");
    // Where it was last seen is a beacon, and the next robot went on.
    let (x, y) = (r1["x"].as_f64().expect("x"), r1["y"].as_f64().expect("y"));
    assert!(x > 20.0 && y > 20.0, "robot 1 had left the start: ({x}, {y})");
    assert_eq!(j["beacons"][0]["x"], r1["x"]);
    assert!(j["robots"][1]["deployed_tick"].is_u64(), "robot 2 was deployed after the death: {j}");
}

#[test]
fn killing_the_orchestrator_leaves_no_agent_and_a_readable_recording() {
    let swarm = swarm_name("orphans");
    // The killed launch cannot remove its lock file: the test does.
    let _lock_file = SwarmLockFile::of(&swarm);
    let dir = tempfile::tempdir().expect("temp dir");
    let record = dir.path().join("run.mcap");
    let record_arg = record.to_str().expect("utf-8 path");
    // Real time at 1×: the run would take minutes.
    let mut launch = Proc::orchestrator(&[
        "launch", "--clock", "realtime", "--speed", "1", "--swarm", &swarm, "--record", record_arg,
    ]);
    agent_pid(&swarm, 1);
    agent_pid(&swarm, 2); // the prespawned next robot
                          // Until the recording has flushed five of robot 1's poses (it flushes
                          // once a second; how many poses a flush holds depends on the load).
    let pose_topic = format!("bycoms/{swarm}/robot/1/pose");
    let flushed = wait_for(Duration::from_secs(20), || {
        read_counts(&record).ok().filter(|c| c.get(&pose_topic).is_some_and(|&n| n >= 5)).map(|_| ())
    });
    assert!(flushed.is_some(), "the recording flushed five of robot 1's poses within 20 s");
    let agents: Vec<u32> = agents_of(&swarm).into_iter().map(|(p, _)| p).collect();
    assert_eq!(agents.len(), 2, "robot 1 moving and robot 2 waiting");
    launch.kill();
    let orphans = wait_for(Duration::from_secs(2), || {
        let left: Vec<u32> = agents.iter().copied().filter(|&p| !is_zombie(p)).collect();
        left.is_empty().then_some(())
    });
    let left: Vec<u32> = agents.iter().copied().filter(|&p| !is_zombie(p)).collect();
    assert!(orphans.is_some(), "agents {left:?} outlived the orchestrator by 2 s");
    let orchestrator = launch.pid();
    drop(launch);
    let recovered = recover(&record).expect("the recording is MCAP");
    assert!(!recovered.is_complete(), "killed: no footer");
    let poses = recovered.counts.get(&pose_topic).copied().unwrap_or(0);
    assert!(poses >= 5, "robot 1's poses up to the last flush are readable: {:?}", recovered.counts);

    // The killed orchestrator left its iceoryx2 node behind; the next
    // launch cleans it up at start (another test's launch may have already).
    let next = Proc::orchestrator(&["launch", "--swarm", &swarm_name("after")]).wait(Duration::from_secs(60));
    assert_eq!(next.status.code(), Some(0), "{}", next.stderr);
    assert!(!has_dead_node(orchestrator), "the dead orchestrator's node was cleaned");
}

/// The terrain where every robot gets stuck at once: the start walled in
/// (`bench crowd`'s).
const ALL_STUCK: &str = ".....\n..G..\n.###.\n.#S#.\n.###.\n";

/// Issue 49: agents asleep on their commands until their next heartbeat
/// (a parked robot's: up to 0.5 s between beats) exit within milliseconds
/// of a `kill -9` of the orchestrator: their parent-death signal cuts the
/// sleep short and sets the flag in its handler, so they find it set (set
/// by another thread, it often came after they looked, and they slept on:
/// 1.5 to 1.95 s). Asserted: the documented 2 s; the figure is printed.
#[test]
fn agents_asleep_until_their_next_heartbeat_exit_at_once_when_the_orchestrator_is_killed() {
    let swarm = swarm_name("asleep");
    let _lock_file = SwarmLockFile::of(&swarm);
    let dir = tempfile::tempdir().expect("temp dir");
    let terrain = dir.path().join("all-stuck.txt");
    std::fs::write(&terrain, ALL_STUCK).expect("terrain");
    let terrain = terrain.to_str().expect("utf-8");
    let args = ["launch", "--terrain", terrain, "--clock", "realtime", "--speed", "1", "--robots", "6"];
    let stuck = ["--dwell", "1", "--stop-turn-rate", "0", "--time-limit", "1e7", "--swarm", &swarm];
    let mut launch = Proc::orchestrator(&[&args[..], &stuck[..]].concat());
    // Robots 1 and 2 stuck at once (parked, asleep between beats), robot 3 deployed.
    launch
        .stderr_line(Duration::from_secs(60), |l| l.contains("robot 3: deployed at").then_some(()))
        .expect("robot 3 deployed after robots 1 and 2 stuck");
    let agents: Vec<u32> = agents_of(&swarm).into_iter().map(|(p, _)| p).collect();
    assert!(agents.len() >= 3, "robots 1 and 2 parked, robot 3 moving: {agents:?}");
    let killed = std::time::Instant::now();
    launch.kill();
    let mut gone = vec![None; agents.len()];
    let all_gone = wait_for(Duration::from_secs(2), || {
        for (pid, at) in agents.iter().zip(gone.iter_mut()) {
            if at.is_none() && is_zombie(*pid) {
                *at = Some(killed.elapsed());
            }
        }
        gone.iter().all(Option::is_some).then_some(())
    });
    let slowest = gone.iter().flatten().max().copied().unwrap_or_default();
    println!(
        "{} agents of a killed orchestrator gone after at most {:.3} s",
        agents.len(),
        slowest.as_secs_f64()
    );
    assert!(all_gone.is_some(), "agents outlived the orchestrator by 2 s: {agents:?} {gone:?}");
}

fn has_dead_node(pid: u32) -> bool {
    use iceoryx2::prelude::{ipc, CallbackProgression, Node, NodeState};
    let mut found = false;
    Node::<ipc::Service>::list(&bycoms_tests::iox_config(), |state| {
        if let NodeState::Dead(view) = &state {
            found |= view.details().as_ref().is_some_and(|d| d.process_id().value() as u32 == pid);
        }
        CallbackProgression::Continue
    })
    .expect("list nodes");
    found
}

#[test]
fn ctrl_c_shuts_down_in_order_and_finishes_the_recording() {
    interrupted_in_order(Signal::SIGINT);
}

/// SIGQUIT (Ctrl-\\) is an interrupt like Ctrl-C: it used to end the launch
/// at once, with no summary, no finished recording and its lock file left.
#[test]
fn sigquit_shuts_down_in_order_as_ctrl_c_does() {
    interrupted_in_order(Signal::SIGQUIT);
}

/// A launch that gets `signal` while robot 1 moves ends in order: exit
/// 130, the summary, every agent gone, the recording finished.
fn interrupted_in_order(signal_sent: Signal) {
    let swarm = swarm_name("ctrlc");
    let dir = tempfile::tempdir().expect("temp dir");
    let record = dir.path().join("run.mcap");
    let record_arg = record.to_str().expect("utf-8 path");
    let launch = Proc::orchestrator(&[
        "launch", "--clock", "realtime", "--speed", "1", "--swarm", &swarm, "--record", record_arg, "--json",
    ]);
    agent_pid(&swarm, 1);
    // Interrupted while robot 1 moves.
    launch
        .stderr_line(Duration::from_secs(20), |l| l.contains("robot 1: deployed at").then_some(()))
        .expect("robot 1 deployed");
    signal(launch.pid(), signal_sent);
    let out = launch.wait(Duration::from_secs(10));
    assert_eq!(out.status.code(), Some(130), "{signal_sent}: {}", out.stderr);
    let j = out.json();
    assert_eq!(j["outcome"], "interrupted");
    assert!(agents_of(&swarm).is_empty(), "every agent exited");
    let recovered = recover(&record).expect("the recording is MCAP");
    assert!(recovered.is_complete(), "finished with summary and footer: {:?}", recovered.stopped_by);
    assert_eq!(j["recording"]["messages"], recovered.messages);
}

fn fake_agent(dir: &std::path::Path, body: &str) -> String {
    use std::os::unix::fs::PermissionsExt;
    let path = dir.join("fake-agent");
    std::fs::write(&path, format!("#!/bin/sh\n{body}\n")).expect("write script");
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    path.to_str().expect("utf-8 path").to_string()
}

#[test]
fn an_agent_that_never_registers_ends_the_launch_with_a_clear_error() {
    let dir = tempfile::tempdir().expect("temp dir");
    for (body, why) in [("exec sleep 30", "did not register in time"), ("exit 0", "process ended")] {
        let agent = fake_agent(dir.path(), body);
        let swarm = swarm_name("noreg");
        let out = Proc::orchestrator(&[
            "launch",
            "--agent-bin",
            &agent,
            "--register-timeout",
            "1",
            "--swarm",
            &swarm,
            "--json",
        ])
        .wait(Duration::from_secs(20));
        assert_eq!(out.status.code(), Some(1), "{}", out.stderr);
        let j = out.json();
        let error = j["error"].as_str().unwrap_or_default();
        assert!(error.contains("robot 1's agent never registered") && error.contains(why), "{error}");
        let pid = j["robots"][0]["pid"].as_u64().expect("pid") as u32;
        assert!(is_zombie(pid), "the fake agent {pid} was killed and reaped");
    }
}

/// Whether process `pid` has a handler for `sig` (its `SigCgt` mask).
fn catches(pid: u32, sig: Signal) -> bool {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    let mask = status.lines().find_map(|l| l.strip_prefix("SigCgt:")).map(str::trim);
    mask.and_then(|m| u64::from_str_radix(m, 16).ok()).is_some_and(|m| m & (1 << (sig as i32 - 1)) != 0)
}

/// `sim-agent` interrupted exits 130, as `gateway` and `orchestrator` do (it
/// exited 0). Started by hand over iceoryx2, it waits for a launch that
/// never comes until the signal.
#[test]
fn an_interrupted_sim_agent_exits_130() {
    let dir = tempfile::tempdir().expect("temp dir");
    let terrain = dir.path().join("t.txt");
    std::fs::write(&terrain, "..........\n.......G..\n..........\n.S........\n").expect("terrain");
    let terrain = terrain.to_str().expect("utf-8 path");
    for sent in [Signal::SIGINT, Signal::SIGTERM, Signal::SIGQUIT] {
        let swarm = swarm_name("sigagent");
        let agent = Proc::start(
            &bycoms_tests::bin("sim-agent"),
            &["--swarm", &swarm, "--robot", "1", "--terrain", terrain, "--eps", "3"].map(String::from),
        );
        // Its handler is installed first thing: signalled before, it would
        // die of the signal, not exit.
        let ready = wait_for(Duration::from_secs(10), || catches(agent.pid(), sent).then_some(()));
        ready.unwrap_or_else(|| panic!("sim-agent never handled {sent}"));
        signal(agent.pid(), sent);
        let out = agent.wait(Duration::from_secs(10));
        assert_eq!(out.status.code(), Some(130), "{sent}: {}", out.stderr);
    }
}
