//! A closed stdout or stderr (`orchestrator launch 2>&1 | head -1`,
//! `simulate --json | true`) ends a command the way ripgrep ends: no panic,
//! and for `launch` the usual orderly end — agents shut down, the recording
//! finished, no iceoryx2 node of the swarm left behind.

use bycoms_record::recover;
use bycoms_runtime::child::{wait_or_kill, Kill};
use bycoms_tests::{agents_of, bin, swarm_name};
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Duration;

/// Runs the orchestrator with stdout and stderr on one pipe whose reader
/// reads `lines` lines and then closes it; returns the exit code.
fn run_into_closed_pipe(args: &[&str], lines: usize) -> Option<i32> {
    let (reader, writer) = std::io::pipe().expect("pipe");
    let mut child = Command::new(bin("orchestrator"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(writer.try_clone().expect("dup pipe"))
        .stderr(writer)
        .spawn()
        .expect("start orchestrator");
    let mut reader = BufReader::new(reader);
    for _ in 0..lines {
        let mut line = String::new();
        let _ = reader.read_line(&mut line);
    }
    drop(reader);
    let waited = wait_or_kill(&mut child, Duration::from_secs(60), Kill::Process).expect("wait");
    assert!(waited.in_time, "{args:?} did not end within 60 s with its output closed");
    waited.status.code()
}

/// Whether an iceoryx2 node of `swarm` (alive or dead) still exists.
fn nodes_of(swarm: &str) -> Vec<String> {
    use iceoryx2::node::NodeView;
    use iceoryx2::prelude::{ipc, CallbackProgression, Node, NodeState};
    let prefix = format!("bycoms-{swarm}-");
    let mut found = Vec::new();
    Node::<ipc::Service>::list(&bycoms_tests::iox_config(), |state| {
        let details = match &state {
            NodeState::Alive(view) => view.details().clone(),
            NodeState::Dead(view) => view.details().clone(),
            _ => None,
        };
        if let Some(name) = details.map(|d| d.name().to_string()) {
            if name.starts_with(&prefix) {
                found.push(name);
            }
        }
        CallbackProgression::Continue
    })
    .expect("list nodes");
    found
}

#[test]
fn launch_into_a_closed_pipe_ends_in_order() {
    for lines in [0, 1] {
        let swarm = swarm_name("pipe");
        let dir = tempfile::tempdir().expect("temp dir");
        let record = dir.path().join("run.mcap");
        let args = ["launch", "--swarm", &swarm, "--record", record.to_str().expect("utf-8")];
        let code = run_into_closed_pipe(&args, lines);
        // The run itself went on: the paper's three-robot launch arrives.
        assert_eq!(code, Some(0), "after reading {lines} lines (101 is a panic)");
        assert!(agents_of(&swarm).is_empty(), "every agent exited");
        assert_eq!(nodes_of(&swarm), Vec::<String>::new(), "iceoryx2 nodes left behind");
        let recovered = recover(&record).expect("the recording is MCAP");
        assert!(recovered.is_complete(), "the recording was finished: {:?}", recovered.stopped_by);
    }
}

#[test]
fn every_printing_command_survives_a_closed_pipe() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("terrains");
    let cases: [(&[&str], i32); 4] = [
        (&["simulate", "--json", "--no-svg"], 0),
        (&["simulate", "--no-svg"], 0),
        (&["terrain", "--width", "3", "--count", "1", "--out", out.to_str().expect("utf-8")], 0),
        (&["simulate", "--eps", "0", "--no-svg"], 2),
    ];
    for (args, expected) in cases {
        assert_eq!(run_into_closed_pipe(args, 0), Some(expected), "{args:?}");
    }
}
