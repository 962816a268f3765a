//! The `gateway` binary's command line: bad inputs end with a clear message
//! and a non-zero exit before anything is opened. (Also what makes
//! `cargo test --workspace` build the `gateway` executable that the
//! end-to-end tests in `tests/` start.)

use std::process::{Command, Stdio};

fn agent(args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_gateway"))
        .args(args)
        .env_remove("RUST_LOG")
        .env_remove("BYCOMS_LOG_FORMAT")
        .stdin(Stdio::null())
        .output()
        .expect("run agent");
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn a_missing_key_file_is_a_clear_error() {
    let (code, err) = agent(&[
        "--swarm",
        "gwcli",
        "--robot",
        "1",
        "--bind",
        "127.0.0.1:47001",
        "--key-file",
        "/nonexistent/robot-1.key",
    ]);
    assert_ne!(code, Some(0), "{err}");
    assert!(err.contains("/nonexistent/robot-1.key"), "names the file: {err}");
}

#[test]
fn robot_zero_and_a_bad_address_are_usage_errors() {
    let (code, err) =
        agent(&["--swarm", "gwcli", "--robot", "0", "--bind", "127.0.0.1:47001", "--key-file", "k"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--robot"), "{err}");
    let (code, err) = agent(&["--swarm", "gwcli", "--robot", "1", "--bind", "nowhere", "--key-file", "k"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--bind"), "{err}");
}

/// A robot's gateway address is fixed (flashed into the robot): port 0 is
/// refused, naming the flag and the value, as is no parent (pid 0) or
/// init (pid 1) for `--parent-pid` (issue 49).
#[test]
fn port_0_and_a_parent_pid_of_0_or_1_are_usage_errors() {
    let base = ["--swarm", "gwcli", "--robot", "1", "--key-file", "/nonexistent/k"];
    let (code, err) = agent(&[&base[..], &["--bind", "127.0.0.1:0"]].concat());
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--bind") && err.contains("127.0.0.1:0 has port 0"), "{err}");
    let (code, err) = agent(&[
        "doctor",
        "--connect",
        "tcp/127.0.0.1:7447",
        "--swarm",
        "s",
        "--robot",
        "1",
        "--bind",
        "127.0.0.1:0",
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--bind") && err.contains("has port 0"), "{err}");
    for pid in ["0", "1"] {
        let (code, err) = agent(&[&base[..], &["--bind", "127.0.0.1:47001", "--parent-pid", pid]].concat());
        assert_eq!(code, Some(2), "{pid}: {err}");
        assert!(err.contains("--parent-pid") && err.contains(&format!("got \"{pid}\"")), "{err}");
    }
}

/// Every span in milliseconds takes the one range of seconds (issue 49):
/// a heartbeat of u64::MAX ms (none at all) and of 0 are usage errors,
/// and so is the doctor's timeout of either.
#[test]
fn millisecond_flags_take_the_one_range() {
    let base =
        ["--swarm", "gwcli", "--robot", "1", "--bind", "127.0.0.1:47001", "--key-file", "/nonexistent/k"];
    for ms in ["18446744073709551615", "0"] {
        let (code, err) = agent(&[&base[..], &["--heartbeat-ms", ms]].concat());
        assert_eq!(code, Some(2), "{ms}: {err}");
        assert!(err.contains("--heartbeat-ms") && err.contains("(0, 100000000000]"), "{err}");
        let doctor =
            ["doctor", "--connect", "tcp/127.0.0.1:7447", "--swarm", "s", "--robot", "1", "--timeout-ms", ms];
        let (code, err) = agent(&doctor);
        assert_eq!(code, Some(2), "{ms}: {err}");
        assert!(err.contains("--timeout-ms") && err.contains("milliseconds in (0, 100000000000]"), "{err}");
    }
}

/// A key file that is a device without end is refused at the cap of a key
/// file, naming the file, instead of being read until memory runs out
/// (issue 49: `--key-file /dev/zero` grew to 24 GB).
#[test]
fn a_key_file_without_end_is_refused_at_its_cap() {
    let (code, err) =
        agent(&["--swarm", "gwcli", "--robot", "1", "--bind", "127.0.0.1:47001", "--key-file", "/dev/zero"]);
    assert_ne!(code, Some(0), "{err}");
    assert!(err.contains("bad key file /dev/zero: more than the limit of 1024 bytes"), "{err}");
}

#[test]
fn a_bad_swarm_name_is_a_usage_error() {
    let (code, err) = agent(&[
        "--swarm",
        "a/b",
        "--robot",
        "1",
        "--bind",
        "127.0.0.1:47001",
        "--key-file",
        "/nonexistent/k",
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("bad swarm name"), "{err}");
}

/// Ctrl-C ends a gateway as it ends the orchestrator: exit 130 (interrupted).
#[test]
fn sigint_exits_130_like_the_orchestrator() {
    use bycoms_runtime::child::{wait_or_kill, Kill};
    use std::io::{BufRead, BufReader};
    use std::time::Duration;
    let dir = tempfile::tempdir().expect("tempdir");
    let key = dir.path().join("robot-1.key");
    std::fs::write(&key, "ab".repeat(32)).expect("key file");
    let swarm = format!("gwsigint{}", std::process::id());
    // The gateway's fixed port (0 is refused): one free a moment ago.
    let bind = std::net::UdpSocket::bind("127.0.0.1:0").and_then(|s| s.local_addr()).expect("free port");
    let bind = bind.to_string();
    let mut child = Command::new(env!("CARGO_BIN_EXE_gateway"))
        .args(["--swarm", &swarm, "--robot", "1", "--bind", &bind, "--key-file"])
        .arg(&key)
        .env("RUST_LOG", "info")
        .env_remove("BYCOMS_LOG_FORMAT")
        .stdin(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn agent");
    // Wait (10 s at most) for the gateway to say it listens: its handler is in place.
    let (tx, rx) = std::sync::mpsc::channel();
    let stderr = child.stderr.take().expect("stderr");
    let reader = std::thread::spawn(move || {
        let mut seen = Vec::new();
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if line.contains("gateway listening") {
                let _ = tx.send(());
            }
            seen.push(line);
        }
        seen
    });
    let listening = rx.recv_timeout(Duration::from_secs(10));
    let pid = child.id().to_string();
    let sent = Command::new("kill").args(["-INT", &pid]).status().expect("run kill");
    assert!(sent.success());
    let waited = wait_or_kill(&mut child, Duration::from_secs(10), Kill::Process).expect("wait");
    let lines = reader.join().expect("reader");
    assert!(listening.is_ok(), "the gateway started: {lines:?}");
    assert!(waited.in_time, "the gateway ended within 10 s of SIGINT: {lines:?}");
    assert_eq!(waited.status.code(), Some(130), "{lines:?}");
}

/// The logging flags go in any position (README, "Logs and shell
/// completions"), before the `bench` subcommand too; the gateway's own
/// flags do not go with it.
#[test]
fn the_logging_flags_go_before_or_after_the_subcommand() {
    for args in [["--log-format", "json", "bench", "--help"], ["bench", "--log-format", "json", "--help"]] {
        let (code, err) = agent(&args);
        assert_eq!(code, Some(0), "{args:?}: {err}");
    }
    let (code, err) = agent(&["--swarm", "s", "bench"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("cannot be used with '--swarm <SWARM>'"), "{err}");
}

/// `gateway bench --frames 0` measures nothing: a usage error naming the
/// flag, before any socket or bus is opened (it printed NaN and exited 0).
#[test]
fn a_bench_of_no_frames_is_a_usage_error() {
    let (code, err) = agent(&["bench", "--frames", "0"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("'--frames <FRAMES>'") && err.contains("0 is not in 1.."), "{err}");
}

/// `gateway doctor`: a bad endpoint is a usage error (2) before anything is
/// checked; an orchestrator that is not there is an error finding (1) in
/// the JSON report, with its fix.
#[test]
fn the_doctor_exits_2_for_a_usage_error_and_1_for_an_error_finding() {
    let (code, err) = agent(&["doctor", "--connect", "nowhere", "--swarm", "gwcli", "--robot", "1"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("bad --connect endpoint \"nowhere\""), "{err}");
    // A port nobody listens on: refused at once.
    let port = std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).expect("port").port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let args = [
        "doctor",
        "--json",
        "--timeout-ms",
        "2000",
        "--connect",
        &endpoint,
        "--swarm",
        "gwcli",
        "--robot",
        "1",
    ];
    let out =
        Command::new(env!("CARGO_BIN_EXE_gateway")).args(args).stdin(Stdio::null()).output().expect("run");
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("the JSON report");
    let zenoh = report["findings"].as_array().expect("findings").iter().find(|f| f["check"] == "zenoh");
    let zenoh = zenoh.expect("a zenoh finding");
    assert_eq!(zenoh["level"], "error", "{report}");
    assert!(zenoh["cause"].as_str().is_some_and(|c| c.contains("not reached")), "{report}");
    assert!(zenoh["fix"].as_str().is_some_and(|f| f.contains("firewall")), "{report}");
    assert_eq!(report["errors"], 1, "{report}");
}
