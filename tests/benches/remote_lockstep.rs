//! Lockstep speed of the paper's `launch --robots 3` (long-obstacle, ε 3)
//! in three set-ups, in one run, side by side:
//!
//! * `ipc loopback` — the default: spawned agents over iceoryx2 shared memory;
//! * `zenoh loopback` — spawned agents over zenoh tcp on 127.0.0.1;
//! * `zenoh two hosts` — the orchestrator in one network namespace, three
//!   hand-started `--agents remote` agents in another, over a veth link
//!   (`bycoms_tests::netns`).
//!
//! Per set-up: median over the runs of the launch's `sim_speed` (simulated
//! seconds per wall second over the whole launch: ticks × 0.1 s / wall,
//! agent start-up and registration included) and of ticks per wall second.
//! Every run must end `arrived` with the same tick count (the lockstep
//! result does not depend on the transport).
//!
//! `cargo build --release --bins -p bycoms-orchestrator -p bycoms-sim &&
//! cargo bench -p bycoms-tests --bench remote_lockstep` (root for the
//! namespaces; `RUNS=N`, default 5). Without namespaces the two-host row is
//! left out with a notice.

use bycoms_runtime::{BusArgs, Transport};
use bycoms_sim::terrain::to_text;
use bycoms_sim_agent::AgentArgs;
use bycoms_study::scenario::{load, TerrainSource};
use bycoms_tests::netns::{not_permitted, TwoHosts};
use bycoms_tests::{swarm_name, Proc};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::time::Duration;

const WAIT: Duration = Duration::from_secs(300);

fn median(v: Vec<f64>) -> f64 {
    bycoms_runtime::stats::median(&v).unwrap_or(f64::NAN)
}

fn launch_args<'a>(swarm: &'a str, terrain: &'a str) -> Vec<&'a str> {
    let mut args = vec!["launch", "--clock", "lockstep", "--json", "--swarm", swarm, "--robots", "3"];
    args.extend(["--eps", "3", "--terrain", terrain, "--time-limit", "10000"]);
    args
}

/// One spawned-agents launch over `transport` on this host.
fn loopback(terrain: &str, zenoh: bool) -> Value {
    let swarm = swarm_name("bench");
    let mut args = launch_args(&swarm, terrain);
    if zenoh {
        args.extend(["--transport", "zenoh", "--listen", "tcp/127.0.0.1:0"]);
    }
    Proc::orchestrator(&args).wait(WAIT).json()
}

/// One remote-agents launch across two namespaces.
fn two_hosts(terrain: &str) -> Value {
    let hosts = TwoHosts::create("bench-lockstep").expect("namespaces");
    let swarm = swarm_name("bench");
    let listen = hosts.a.endpoint(0);
    let mut args = launch_args(&swarm, terrain);
    args.extend(["--agents", "remote", "--transport", "zenoh", "--listen", &listen]);
    let orch = hosts.a.start("orchestrator", &args);
    let endpoint = orch.logged_endpoint(&format!("tcp/{}:", hosts.a.addr), Duration::from_secs(30));
    let agents: Vec<Proc> = (1..=3)
        .map(|k| {
            let agent = AgentArgs {
                terrain: Some(terrain.into()),
                eps: Some(3.0),
                swarm_size: Some(3),
                bus: BusArgs {
                    transport: Transport::Zenoh,
                    connect: vec![endpoint.clone()],
                    zenoh_config: None,
                },
                ..AgentArgs::new(&swarm, k)
            };
            let flags = agent.to_flags();
            hosts.b.start("sim-agent", &flags.iter().map(String::as_str).collect::<Vec<_>>())
        })
        .collect();
    let j = orch.wait(WAIT).json();
    drop(agents);
    j
}

fn row(name: &str, runs: &[Value]) {
    for j in runs {
        assert_eq!(j["outcome"], "arrived", "{name}: {j}");
        assert_eq!(j["ticks"], runs[0]["ticks"], "{name}: the tick count depends on nothing");
    }
    let speed = median(runs.iter().map(|j| j["sim_speed"].as_f64().unwrap_or(f64::NAN)).collect());
    let ticks_per_s = median(
        runs.iter()
            .map(|j| j["ticks"].as_f64().unwrap_or(f64::NAN) / j["wall_s"].as_f64().unwrap_or(f64::NAN))
            .collect(),
    );
    let wall = median(runs.iter().map(|j| j["wall_s"].as_f64().unwrap_or(f64::NAN)).collect());
    println!(
        "{name:<16} sim_speed {speed:7.1}x   ticks/s {ticks_per_s:7.0}   wall {wall:6.2} s   ({} ticks, {} runs)",
        runs[0]["ticks"],
        runs.len()
    );
}

fn main() {
    let runs: usize = std::env::var("RUNS").ok().and_then(|s| s.parse().ok()).unwrap_or(5);
    let dir = tempfile::tempdir().expect("temp dir");
    let terrain = load(&TerrainSource::Scenario("long-obstacle".into())).expect("scenario").terrain;
    let path: PathBuf = dir.path().join("terrain.txt");
    std::fs::write(&path, to_text(&terrain)).expect("write terrain");
    let terrain = Path::new(&path).to_str().expect("utf-8 path");
    println!("lockstep launch --robots 3 (long-obstacle, eps 3), medians of {runs} runs each:");
    row("ipc loopback", &(0..runs).map(|_| loopback(terrain, false)).collect::<Vec<_>>());
    row("zenoh loopback", &(0..runs).map(|_| loopback(terrain, true)).collect::<Vec<_>>());
    match not_permitted() {
        Some(why) => println!("zenoh two hosts: left out ({why})"),
        None => row("zenoh two hosts", &(0..runs).map(|_| two_hosts(terrain)).collect::<Vec<_>>()),
    }
}
