//! Logging through `tracing`: `RUST_LOG` filters, `--log-format json` (or
//! `BYCOMS_LOG_FORMAT=json`) makes every stderr line a JSON object, also
//! the lines of the agents a launch starts and iceoryx2's own, while stdout
//! keeps the result.

use bycoms_runtime::child::{wait_or_kill, Kill};
use serde_json::Value;
use std::io::Read;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

/// Runs the orchestrator with `args`, `RUST_LOG=rust_log` (unset if None)
/// and no inherited format; kills it after 60 s.
fn orchestrator(args: &[&str], rust_log: Option<&str>) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_orchestrator"));
    cmd.args(args).env_remove("BYCOMS_LOG_FORMAT").env_remove("RUST_LOG");
    if let Some(filter) = rust_log {
        cmd.env("RUST_LOG", filter);
    }
    run(cmd)
}

fn run(mut cmd: Command) -> Output {
    let mut child =
        cmd.stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("spawn");
    let (stdout, stderr) = (drain(child.stdout.take()), drain(child.stderr.take()));
    let waited = wait_or_kill(&mut child, Duration::from_secs(60), Kill::Process).expect("wait");
    let stdout = stdout.join().expect("stdout reader");
    let stderr = stderr.join().expect("stderr reader");
    Output { status: waited.status, stdout, stderr }
}

/// Reads `pipe` to its end on a thread of its own (a full pipe would stall
/// the process being waited for).
fn drain(pipe: Option<impl Read + Send + 'static>) -> std::thread::JoinHandle<Vec<u8>> {
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(mut pipe) = pipe {
            let _ = pipe.read_to_end(&mut bytes);
        }
        bytes
    })
}

/// Every stderr line as JSON; panics on a line that is not a JSON object
/// with a timestamp, a level and a message.
fn json_lines(o: &Output) -> Vec<Value> {
    let text = String::from_utf8_lossy(&o.stderr);
    assert!(!text.trim().is_empty(), "no log lines at all");
    text.lines()
        .map(|line| {
            let v: Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("not JSON ({e}): {line}"));
            assert!(v["timestamp"].is_string() && v["level"].is_string(), "{line}");
            assert!(v["fields"]["message"].is_string(), "{line}");
            v
        })
        .collect()
}

fn has(lines: &[Value], level: &str, message_part: &str) -> bool {
    lines.iter().any(|v| {
        v["level"] == level && v["fields"]["message"].as_str().is_some_and(|m| m.contains(message_part))
    })
}

#[test]
fn json_format_with_rust_log_debug_gives_json_lines_only() {
    let o =
        orchestrator(&["--log-format", "json", "simulate", "--terrain", "/nonexistent/t.txt"], Some("debug"));
    assert_eq!(o.status.code(), Some(1));
    assert!(o.stdout.is_empty(), "stdout is for results only");
    let lines = json_lines(&o);
    assert!(has(&lines, "DEBUG", "orchestrator starts"), "{lines:?}");
    assert!(has(&lines, "ERROR", "cannot read terrain file /nonexistent/t.txt"), "{lines:?}");
}

#[test]
fn the_flag_is_global_and_the_environment_variable_works_too() {
    let after = orchestrator(&["simulate", "--terrain", "/nonexistent/t.txt", "--log-format", "json"], None);
    assert!(has(&json_lines(&after), "ERROR", "cannot read terrain"));
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_orchestrator"));
    cmd.args(["simulate", "--terrain", "/nonexistent/t.txt"]).env("BYCOMS_LOG_FORMAT", "json");
    cmd.env_remove("RUST_LOG");
    assert!(has(&json_lines(&run(cmd)), "ERROR", "cannot read terrain"));
}

#[test]
fn default_is_text_at_info_level_and_rust_log_filters() {
    let o = orchestrator(&["simulate", "--terrain", "/nonexistent/t.txt"], None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("ERROR cannot read terrain file"), "{err}");
    assert!(!err.contains("orchestrator starts"), "debug is off by default: {err}");
    assert!(!err.trim_start().starts_with('{'), "text by default: {err}");
    // A directive for another target keeps the default level for ours.
    let o = orchestrator(&["simulate", "--terrain", "/nonexistent/t.txt"], Some("iceoryx2=trace"));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot read terrain"));
    // `off` silences the logs (the exit code still tells).
    let o = orchestrator(&["simulate", "--terrain", "/nonexistent/t.txt"], Some("off"));
    assert_eq!(o.status.code(), Some(1));
    assert!(o.stderr.is_empty(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn an_unknown_format_is_a_usage_error() {
    let o = orchestrator(&["--log-format", "yaml", "simulate"], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("yaml"));
}

#[test]
fn a_launch_in_json_format_logs_json_from_orchestrator_and_agents() {
    let swarm = format!("logjson{}", std::process::id());
    let args = [
        "--log-format",
        "json",
        "launch",
        "--robots",
        "2",
        "--time-limit",
        "30",
        "--json",
        "--swarm",
        &swarm,
    ];
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_orchestrator"));
    cmd.args(args).env("RUST_LOG", "debug").env_remove("BYCOMS_LOG_FORMAT");
    // iceoryx2's own warnings (no config file) must come through as JSON too.
    cmd.env("IOX2_LOG_LEVEL", "warn");
    let o = run(cmd);
    assert!(matches!(o.status.code(), Some(0) | Some(3)), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: Value = serde_json::from_slice(&o.stdout).expect("stdout is the JSON summary");
    assert!(summary["outcome"].is_string());
    let lines = json_lines(&o);
    // The agents inherited the format and the filter: their debug events,
    // tagged with their robot by the `sim-agent` span.
    for robot in [1, 2] {
        let agent = lines.iter().any(|v| {
            v["span"]["name"] == "sim-agent" && v["span"]["robot"] == robot && v["level"] == "DEBUG"
        });
        assert!(agent, "no JSON debug line of robot {robot}'s agent: {lines:?}");
    }
    // iceoryx2's lines, from the orchestrator and from the agents.
    let iceoryx2 = |agent: bool| {
        lines
            .iter()
            .any(|v| v["target"] == "iceoryx2" && v["level"] == "WARN" && v["span"].is_object() == agent)
    };
    assert!(iceoryx2(false) && iceoryx2(true), "iceoryx2 warnings as JSON from both: {lines:?}");
    // The launch's plain progress lines became status events.
    assert!(lines.iter().any(|v| v["target"] == "status"
        && v["fields"]["message"].as_str().is_some_and(|m| m.starts_with("robot 1: deployed"))));
}
