//! A real `orchestrator launch` over iceoryx2, republished on zenoh by
//! `orchestrator bridge`, watched by `deploy/clients/watch.py` (PyPI
//! `eclipse-zenoh`): the Python client, decoding the wire format by hand,
//! prints what the launch reports about the same run.
//!
//! Needs `python3 -c "import zenoh"`: `#[ignore = "needs …"]`, run by
//! `.ci/run` (which installs it) with `--include-ignored`; asked for without
//! it the test fails, saying so.

use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::bus::BusExt;
use bycoms_protocol::msg::{GateEvent, GateKind};
use bycoms_protocol::{RobotId, Swarm};
use bycoms_runtime::child::{wait_or_kill, Kill};
use bycoms_runtime::ipc_config;
use bycoms_tests::{swarm_name, Proc};
use std::net::TcpListener;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// A probe robot id no launch uses: its gate event proves the path works.
const PROBE: u32 = 999_999;

fn python_has_zenoh() -> bool {
    Command::new("python3")
        .args(["-c", "import zenoh"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// `python3 watch.py ...` with its stdout lines on a channel; killed and
/// reaped on drop.
struct Watch {
    child: Child,
    lines: mpsc::Receiver<String>,
    seen: Vec<String>,
}

impl Watch {
    fn start(args: &[&str]) -> Watch {
        let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../deploy/clients/watch.py");
        let mut child = Command::new("python3")
            .arg(&script)
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("python3 starts");
        let lines = bycoms_tests::stdout_lines(&mut child);
        Watch { child, lines, seen: Vec::new() }
    }

    /// Waits up to `timeout` for a line containing `needle`.
    fn wait_for(&mut self, needle: &str, timeout: Duration) -> bool {
        let deadline = Instant::now() + timeout;
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    let hit = line.contains(needle);
                    self.seen.push(line);
                    if hit {
                        return true;
                    }
                }
                Err(_) => return false,
            }
        }
        false
    }

    /// Waits up to `timeout` for the process to exit; returns its code
    /// and every line it printed.
    fn finish(mut self, timeout: Duration) -> (Option<i32>, Vec<String>) {
        let waited = wait_or_kill(&mut self.child, timeout, Kill::Process).expect("wait");
        let status = waited.in_time.then_some(waited.status);
        // The reader thread ends at EOF once the process is gone.
        while let Ok(line) = self.lines.recv_timeout(Duration::from_secs(2)) {
            self.seen.push(line);
        }
        (status.and_then(|s| s.code()), std::mem::take(&mut self.seen))
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
#[ignore = "needs python3 with eclipse-zenoh==1.10.2"]
fn python_client_watches_a_launch_through_the_bridge() {
    assert!(python_has_zenoh(), "python3 cannot import zenoh (pip install eclipse-zenoh==1.10.2)");
    let swarm = swarm_name("watch");
    let port = TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).expect("free port").port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let _bridge = Proc::orchestrator(&[
        "bridge",
        "--swarm",
        &swarm,
        "--robots",
        "3",
        "--listen",
        &endpoint,
        "--duration",
        "180",
    ]);
    let mut watch = Watch::start(&[
        "--connect",
        &endpoint,
        "--swarm",
        &swarm,
        "--until-arrived",
        "--timeout",
        "150",
        "--pose-every",
        "10",
    ]);

    // Until the watcher prints a probe gate event published on iceoryx2,
    // the bridge or the watcher may not be up yet: publish it again.
    {
        let bus = IpcBus::new(ipc_config(3)).expect("iceoryx2 node");
        let gate = bus.typed_publisher(&Swarm::new(&swarm).expect("swarm").gate()).expect("publisher");
        let probe = GateEvent { robot: RobotId(PROBE), kind: GateKind::Timeout, x: 1.5, y: -2.0, step: 7 };
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            gate.publish(&probe).expect("publish probe");
            if watch.wait_for(
                &format!("gate robot={PROBE} timeout x=1.500 y=-2.000 step=7"),
                Duration::from_millis(200),
            ) {
                break;
            }
            assert!(Instant::now() < deadline, "the probe never reached the watcher: {:?}", watch.seen);
        }
    }

    // Real time (20×), as a lab watches a run: in lockstep the swarm runs
    // thousands of periods a second, and on a loaded machine the bridge's
    // iceoryx2 queues overwrite most poses before it forwards them (the
    // bus keeps the latest, by contract), so a robot might show none.
    let out = Proc::orchestrator(&[
        "launch", "--swarm", &swarm, "--robots", "3", "--clock", "realtime", "--speed", "20", "--json",
    ])
    .wait(Duration::from_secs(120));
    assert_eq!(out.status.code(), Some(0), "{}", out.stderr);
    let summary = out.json();
    let (code, lines) = watch.finish(Duration::from_secs(60));
    assert_eq!(code, Some(0), "watch.py did not see an arrival; it printed:\n{}", lines.join("\n"));

    let robots = summary["robots"].as_array().expect("robots");
    assert_eq!(robots.len(), 3);
    for robot in robots {
        let id = robot["id"].as_u64().expect("id");
        let has = |prefix: &str| lines.iter().any(|l| l.starts_with(prefix));
        assert!(has(&format!("gate robot={id} deployed ")), "robot {id} deployed:\n{}", lines.join("\n"));
        assert!(has(&format!("pose robot={id} ")), "a pose of robot {id}");
        let end = robot["end"].as_str().expect("end");
        let arrived = match end {
            "arrived" => "true",
            "stuck" => "false",
            other => panic!("unexpected end {other} of robot {id}"),
        };
        assert!(has(&format!("gate robot={id} stopped arrived={arrived} ")), "robot {id} {end}");
        // Status reports (mode changes) are decoded. Which one is printed
        // last is not asserted: they share the busy `from_agents` topic with
        // every agent's TickDone and heartbeats, and the bridge's iceoryx2
        // subscriber drops its oldest samples past 64 when it falls behind
        // under load (by design, see commands/bridge.rs), so the final
        // change of a robot can be lost to the watcher.
        let modes: Vec<u64> = lines
            .iter()
            .filter_map(|l| l.strip_prefix(&format!("mode robot={id} mode=")))
            .filter_map(|rest| rest.split(' ').next()?.parse().ok())
            .collect();
        assert!(!modes.is_empty(), "no mode line of robot {id}:\n{}", lines.join("\n"));
        assert!(modes.iter().all(|m| [1, 2].contains(m)), "modes of robot {id}: {modes:?}");
    }
    let gate_lines =
        lines.iter().filter(|l| l.starts_with("gate ") && !l.contains(&PROBE.to_string())).count();
    assert_eq!(gate_lines, 6, "3 deployments, 2 stuck, 1 arrival:\n{}", lines.join("\n"));
}
