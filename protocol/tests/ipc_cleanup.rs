//! Stale iceoryx2 resources of a crashed process are removed at start.
//!
//! The test re-runs this test binary as a child that opens a node with a
//! publisher and a subscriber, then kills it with SIGKILL so it cannot
//! clean up. The node must then show up as dead, and
//! `cleanup_stale_resources` must remove it; afterwards the topic still
//! works. Every wait is bounded. Parent and child use their own iceoryx2
//! root (an isolation tag), so no other run's leftovers are seen and
//! nothing is left behind.
#![cfg(feature = "ipc")]

use bycoms_protocol::bus::ipc::root::{self, Isolated, ISOLATION_ENV};
use bycoms_protocol::bus::ipc::{cleanup_stale_resources_in, IpcBus, IpcConfig};

use bycoms_protocol::bus::{Bus, Publish, Subscribe};
use bycoms_protocol::TopicName;
use core::time::Duration;
use iceoryx2::node::NodeView;
use iceoryx2::prelude::{ipc, CallbackProgression, Node, NodeState};
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::sync::mpsc;

const CHILD_ENV: &str = "BYCOMS_IPC_CLEANUP_CHILD_TOPIC";
const READY: &str = "BYCOMS-CHILD-READY";

/// Runs only as the child of `dead_nodes_are_cleaned_up`; a no-op otherwise.
#[test]
fn child_holds_a_node_until_killed() {
    let Ok(topic) = std::env::var(CHILD_ENV) else {
        return;
    };
    let topic = TopicName::parse(&topic).expect("topic from parent");
    // The tag comes from the parent through the environment (the default).
    assert!(root::tag_from_env().is_some(), "child without an isolation tag");
    let bus = IpcBus::new(IpcConfig::default()).expect("node");
    let _publisher = bus.publisher(&topic).expect("publisher");
    let _subscriber = bus.subscriber(&topic).expect("subscriber");
    println!("{READY}");
    // Held until the parent kills us; should the parent die first, its end
    // of our stdin closes and we end (no wall-time bound to guess).
    let _ = std::io::stdin().read_line(&mut String::new());
}

#[derive(Debug, PartialEq)]
enum Seen {
    Absent,
    Alive,
    Dead,
}

fn node_of(tag: &str, pid: u32) -> Seen {
    let mut seen = Seen::Absent;
    let config = root::config(Some(tag)).expect("isolated config");
    Node::<ipc::Service>::list(&config, |state| {
        let (details, dead) = match &state {
            NodeState::Alive(view) => (view.details().clone(), false),
            NodeState::Dead(view) => (view.details().clone(), true),
            _ => (None, false),
        };
        if details.is_some_and(|d| d.process_id().value() as u32 == pid) {
            seen = if dead { Seen::Dead } else { Seen::Alive };
        }
        CallbackProgression::Continue
    })
    .expect("list nodes");
    seen
}

#[test]
fn dead_nodes_are_cleaned_up() {
    let iso = Isolated::new("ipccleanup");
    let tag = iso.tag().to_string();
    let topic = format!("bycoms/t{}-cleanup/raw", std::process::id());
    let mut child = Command::new(std::env::current_exe().expect("test binary"))
        .args(["--exact", "ipc_cleanup::child_holds_a_node_until_killed", "--nocapture"])
        .env(CHILD_ENV, &topic)
        .env(ISOLATION_ENV, &tag)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("spawn child");
    // Kept open until the child is killed: the child waits on it.
    let _stdin = child.stdin.take().expect("child stdin");
    let stdout = child.stdout.take().expect("child stdout");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if line.contains(READY) {
                let _ = tx.send(());
            }
        }
    });
    let ready = rx.recv_timeout(Duration::from_secs(20));
    let pid = child.id();
    child.kill().expect("SIGKILL child");
    child.wait().expect("reap child");
    ready.expect("child opened its node in time");

    assert_eq!(node_of(&tag, pid), Seen::Dead, "a killed process leaves a dead node");
    let config = root::config(Some(&tag)).expect("isolated config");
    let report = cleanup_stale_resources_in::<ipc::Service>(&config).expect("cleanup");
    // Only this test's nodes live under its tag: exactly the child's.
    assert_eq!((report.cleaned, report.failed), (1, 0), "{report:?}");
    assert_eq!(node_of(&tag, pid), Seen::Absent, "cleanup removed the dead node");

    let topic = TopicName::parse(&topic).expect("topic");
    let bus = IpcBus::new(IpcConfig { isolation: Some(tag.clone()), ..IpcConfig::default() }).expect("node");
    let sub = bus.subscriber(&topic).expect("subscriber after cleanup");
    let publ = bus.publisher(&topic).expect("publisher after cleanup");
    publ.publish(b"alive").expect("publish");
    let got = sub.recv_timeout(Duration::from_secs(5)).expect("receive");
    assert_eq!(got.as_deref(), Some(&b"alive"[..]));
}
