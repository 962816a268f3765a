//! Loss detection across two hosts (network namespaces, see
//! `bycoms_tests::netns`): how long after a link is cut, or the agent's
//! process killed, the other side's liveliness watch reports it lost, and
//! how long after the link returns the agent is alive again. Medians of
//! several trials, each on fresh namespaces and processes, with
//! `Liveness::FAST` (lease 400 ms, 4 keep-alives) on both ends. Target of
//! issue 6: ≤ 500 ms.
//!
//! `cargo bench -p bycoms-tests --bench liveness` (root; `TRIALS=N`,
//! default 7). Prints a notice and nothing else where namespaces are not
//! permitted.

use bycoms_tests::netns::{mono_ns, not_permitted, Pair, TwoHosts};
use std::path::Path;
use std::time::Duration;

const PEER: &str = env!("CARGO_BIN_EXE_netns-peer");
const WAIT: Duration = Duration::from_secs(5);

fn ms_since(t0: u128, t: u128) -> f64 {
    t.saturating_sub(t0) as f64 / 1e6
}

struct Trial {
    cut_agent_lost: f64,
    cut_orchestrator_lost: f64,
    restored_alive: f64,
    killed_lost: f64,
}

fn trial(n: u32) -> Trial {
    let hosts = TwoHosts::create("bench").expect("namespaces");
    let swarm = format!("bench{}-{n}", std::process::id());
    let Pair { mut orchestrator, mut agent } = Pair::start(&hosts, Path::new(PEER), &swarm);
    let cut = mono_ns();
    hosts.cut().expect("cut");
    let lost = orchestrator.until(WAIT, |e| e.lost_of("1")).expect("agent lost after the cut");
    let lost_o = agent.until(WAIT, |e| e.lost_of("orchestrator")).expect("orchestrator lost after the cut");
    std::thread::sleep(Duration::from_millis(1000));
    let restored = mono_ns();
    hosts.restore().expect("restore");
    let back = orchestrator.until(WAIT * 2, |e| e.alive_of("1")).expect("agent alive after the restore");
    let killed = mono_ns();
    agent.kill();
    let gone = orchestrator.until(WAIT, |e| e.lost_of("1")).expect("killed agent lost");
    Trial {
        cut_agent_lost: ms_since(cut, lost),
        cut_orchestrator_lost: ms_since(cut, lost_o),
        restored_alive: ms_since(restored, back),
        killed_lost: ms_since(killed, gone),
    }
}

fn summary(name: &str, values: Vec<f64>) {
    use bycoms_runtime::stats::{median, quantile};
    let median = median(&values).unwrap_or(f64::NAN);
    let (min, max) = (quantile(&values, 0.0).unwrap_or(f64::NAN), quantile(&values, 1.0).unwrap_or(f64::NAN));
    println!("{name:<44} median {median:7.1} ms   min {min:7.1}   max {max:7.1}   (n = {})", values.len());
}

fn main() {
    if let Some(reason) = not_permitted() {
        println!("liveness bench skipped: {reason}");
        return;
    }
    let trials: u32 = std::env::var("TRIALS").ok().and_then(|t| t.parse().ok()).unwrap_or(7).max(1);
    let results: Vec<Trial> = (0..trials).map(trial).collect();
    println!("loss detection between two network namespaces, zenoh lease 400 ms, keep_alive 4");
    summary("cut link → orchestrator sees agent lost", results.iter().map(|t| t.cut_agent_lost).collect());
    summary(
        "cut link → agent sees orchestrator lost",
        results.iter().map(|t| t.cut_orchestrator_lost).collect(),
    );
    summary("link restored → agent alive again", results.iter().map(|t| t.restored_alive).collect());
    summary("agent killed (SIGKILL) → seen lost", results.iter().map(|t| t.killed_lost).collect());
}
