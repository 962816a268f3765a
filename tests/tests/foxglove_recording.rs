//! A real launch's recording as other tools see it: the Python `mcap`
//! reader decodes every decoded channel with its schema (protobuf with
//! `foxglove-schemas-protobuf`, JSON checked against its JSON schema);
//! lockstep log times are simulated time; `launch --svg` and `orchestrator
//! draw FILE.mcap` draw the same picture; `--record` refuses to overwrite
//! what it must not; a recording cut by `kill -9` is completed by `record
//! recover` and then opens in Python's `make_reader`.
//!
//! The tests that need Python packages are `#[ignore = "needs …"]`: `cargo
//! test` leaves them out, `.ci/run` installs the packages and runs them
//! (`-- --include-ignored`), and there a missing package fails them.

use crate::SwarmLockFile;
use bycoms_record::recover;
use bycoms_tests::{agents_of, swarm_name, wait_for, Proc};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("python/decode_recording.py")
}

/// Fails the test unless python3 has the modules (`.ci/run` installs them;
/// the tests that need them are ignored unless asked for).
fn require_python(modules: &str) {
    let ok = Command::new("python3")
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(ok, "python3 lacks the modules {modules} (pip install them; see .ci/run)");
}

fn python(args: &[&str]) -> std::process::Output {
    Command::new("timeout").arg("60").arg("python3").args(args).output().expect("run python3")
}

fn launch(args: &[&str]) -> bycoms_tests::Finished {
    Proc::orchestrator(args).wait(Duration::from_secs(90))
}

#[test]
#[ignore = "needs python3 with mcap==1.6.0, foxglove-schemas-protobuf==0.4.0, jsonschema==4.26.0"]
fn every_decoded_channel_decodes_with_its_schema_and_lockstep_is_logged_at_simulated_time() {
    let swarm = swarm_name("fox");
    let dir = tempfile::tempdir().expect("temp dir");
    let rec = dir.path().join("run.mcap");
    let svg = dir.path().join("launch.svg");
    let (rec_arg, svg_arg) = (rec.to_str().expect("utf-8"), svg.to_str().expect("utf-8"));
    let out = launch(&["launch", "--swarm", &swarm, "--json", "--record", rec_arg, "--svg", svg_arg]);
    assert_eq!(out.status.code(), Some(0), "{}", out.stderr);
    let j = out.json();
    let recovered = recover(&rec).expect("readable");
    assert!(recovered.is_complete(), "{:?}", recovered.stopped_by);
    assert_eq!(j["recording"]["messages"], recovered.messages, "the summary counts the decoded channels too");

    // Lockstep: log times are simulated, the last one at the last tick.
    let bytes = std::fs::read(&rec).expect("read");
    let (mut min, mut max) = (u64::MAX, 0);
    for m in mcap::MessageStream::new(&bytes).expect("stream") {
        let m = m.expect("message");
        (min, max) = (min.min(m.log_time), max.max(m.log_time));
    }
    let ticks = j["ticks"].as_u64().expect("ticks");
    assert_eq!((min, max), (0, ticks * 100_000_000), "log time = tick × 0.1 s");

    // `draw` of the recording is the picture `--svg` drew.
    let drawn = dir.path().join("drawn.svg");
    let d = launch(&["draw", rec_arg, "--out", drawn.to_str().expect("utf-8")]);
    assert_eq!(d.status.code(), Some(0), "{}", d.stderr);
    let (a, b) =
        (std::fs::read_to_string(&svg).expect("--svg"), std::fs::read_to_string(&drawn).expect("draw"));
    assert!(a.starts_with("<svg") || a.starts_with("<?xml"), "{}", &a[..a.len().min(80)]);
    assert!(a.contains("robot 3 arrived"), "the verdict is in the title");
    assert_eq!(a, b, "launch --svg and draw FILE.mcap draw the same picture");

    require_python("mcap, jsonschema, foxglove_schemas_protobuf");
    let py = python(&[script().to_str().expect("utf-8"), rec_arg]);
    assert!(py.status.success(), "python: {}", String::from_utf8_lossy(&py.stderr));
    let r: Value = serde_json::from_slice(&py.stdout).expect("python printed JSON");
    let ch = &r["channels"];
    let topic = |leaf: &str| format!("bycoms/{swarm}/{leaf}");
    for (leaf, schema) in [
        ("scene", "foxglove.SceneUpdate"),
        ("tf", "foxglove.FrameTransforms"),
        ("log", "foxglove.Log"),
        ("gate/json", "bycoms.GateDecision"),
        ("robot/1/pose/json", "bycoms.RobotPose"),
        ("robot/3/mode", "bycoms.RobotMode"),
        ("robot/2/telemetry", "bycoms.Telemetry"),
        ("run", "bycoms.LaunchConfig"),
        ("events", "bycoms.LaunchEvent"),
        ("summary", "bycoms.LaunchSummary"),
    ] {
        assert_eq!(ch[topic(leaf)]["schema"], schema, "{leaf}: {ch}");
    }
    // Every JSON channel has a schema, and every message was validated
    // against it.
    for (name, c) in ch.as_object().expect("channels") {
        if c["schema_encoding"] == "jsonschema" {
            assert!(c["messages"].as_u64().is_some_and(|n| n > 0), "{name}: {c}");
            assert_eq!(c["validated"], c["messages"], "{name}");
        }
    }
    assert_eq!(ch[topic("events")]["validated"], 3, "one `spawned` event per robot");
    assert_eq!(ch[topic("summary")]["validated"], 1);
    assert_eq!(ch[topic("gate/json")]["validated"], 6);
    assert_eq!(ch[topic("log")]["messages"], 6, "one log line per gate decision");
    assert!(r["postcard"].as_u64().expect("postcard") > 0, "the raw bus bytes are kept");
    let ids: Vec<&str> = r["scene_ids"].as_array().expect("ids").iter().filter_map(Value::as_str).collect();
    for id in [
        "arena",
        "terrain",
        "start",
        "goal",
        "robot/1",
        "robot/1/path/0",
        "robot/1/beacon",
        "robot/2/beacon",
        "robot/3",
    ] {
        assert!(ids.contains(&id), "{id} in {ids:?}");
    }
    assert!(!ids.contains(&"robot/3/beacon"), "the arrived robot is no beacon");
    let logs = r["logs"].to_string();
    assert!(logs.contains("robot 1 stuck") && logs.contains("robot 3 arrived"), "{logs}");
    assert_eq!(r["metadata"]["bycoms.clock"]["clock"], "lockstep");
    assert!(r["metadata"]["bycoms.clock"]["log_time"].as_str().is_some_and(|s| s.starts_with("simulated")));
}

#[test]
fn record_refuses_to_overwrite_a_non_recording_and_a_recording_without_force() {
    let dir = tempfile::tempdir().expect("temp dir");
    let terrain = dir.path().join("terrain.txt");
    std::fs::write(&terrain, "precious terrain\n").expect("write");
    let t = terrain.to_str().expect("utf-8");
    for extra in [&[][..], &["--force"][..]] {
        let swarm = swarm_name("keep");
        let out = launch(&[&["launch", "--swarm", &swarm, "--record", t][..], extra].concat());
        assert_eq!(out.status.code(), Some(2), "{}", out.stderr);
        assert!(out.stderr.contains("not an MCAP recording"), "{}", out.stderr);
        assert!(agents_of(&swarm).is_empty(), "refused before any agent started");
    }
    assert_eq!(std::fs::read_to_string(&terrain).expect("read"), "precious terrain\n");

    let rec = dir.path().join("old.mcap");
    let r = rec.to_str().expect("utf-8");
    let first = launch(&["launch", "--swarm", &swarm_name("first"), "--record", r]);
    assert_eq!(first.status.code(), Some(0), "{}", first.stderr);
    let old = std::fs::read(&rec).expect("recording");
    let again = launch(&["launch", "--swarm", &swarm_name("again"), "--record", r]);
    assert_eq!(again.status.code(), Some(2), "{}", again.stderr);
    assert!(again.stderr.contains("--force"), "{}", again.stderr);
    assert_eq!(std::fs::read(&rec).expect("read"), old, "untouched");
    let forced = launch(&["launch", "--swarm", &swarm_name("forced"), "--record", r, "--force"]);
    assert_eq!(forced.status.code(), Some(0), "{}", forced.stderr);
}

#[test]
#[ignore = "needs python3 with mcap==1.6.0"]
fn a_recording_cut_by_kill_9_is_completed_by_record_recover() {
    let swarm = swarm_name("cut");
    // The killed launch cannot remove its lock file: the test does.
    let _lock_file = SwarmLockFile::of(&swarm);
    let dir = tempfile::tempdir().expect("temp dir");
    let rec = dir.path().join("cut.mcap");
    let r = rec.to_str().expect("utf-8");
    // Real time at 1×: the run would take minutes; it is killed after ~2 s.
    let mut run = Proc::orchestrator(&[
        "launch", "--clock", "realtime", "--speed", "1", "--swarm", &swarm, "--record", r,
    ]);
    wait_for(Duration::from_secs(20), || {
        agents_of(&swarm).iter().any(|&(_, robot)| robot == 1).then_some(())
    })
    .expect("robot 1's agent started");
    // Killed once some messages are on disk (the writer flushes every second).
    wait_for(Duration::from_secs(20), || recover(&rec).ok().filter(|c| c.messages > 0).map(|_| ()))
        .expect("messages flushed to disk");
    run.kill();
    drop(run);
    let cut = recover(&rec).expect("the cut recording streams");
    assert!(!cut.is_complete() && cut.messages > 0, "{cut:?}");
    require_python("mcap");
    const COUNT: &str = "import sys\nfrom mcap.reader import make_reader\nr = make_reader(open(sys.argv[1], 'rb'))\nprint(sum(1 for _ in r.iter_messages()))";
    let py = python(&["-c", COUNT, r]);
    assert!(!py.status.success(), "make_reader cannot open a cut recording (documented): it did");

    let fixed = dir.path().join("fixed.mcap");
    let f = fixed.to_str().expect("utf-8");
    let out = launch(&["record", "recover", r, "--out", f]);
    assert_eq!(out.status.code(), Some(0), "{}", out.stderr);
    assert!(out.stdout.contains(&format!("recovered {} messages", cut.messages)), "{}", out.stdout);
    let whole = recover(&fixed).expect("readable");
    assert!(whole.is_complete(), "{:?}", whole.stopped_by);
    assert_eq!(whole.counts, cut.counts, "every message of the cut file, nothing else");
    let again = launch(&["record", "recover", r, "--out", f]);
    assert_eq!(again.status.code(), Some(2), "an existing recording needs --force: {}", again.stderr);
    let py = python(&["-c", COUNT, f]);
    assert!(py.status.success(), "{}", String::from_utf8_lossy(&py.stderr));
    let n: u64 = String::from_utf8_lossy(&py.stdout).trim().parse().expect("a count");
    assert_eq!(n, cut.messages);
    // The default output sits beside the input.
    let out = launch(&["record", "recover", r]);
    assert_eq!(out.status.code(), Some(0), "{}", out.stderr);
    assert!(dir.path().join("cut.recovered.mcap").is_file());
}
