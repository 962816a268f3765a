//! `sim-agent` logs through `tracing`: `--log-format json` with
//! `RUST_LOG=debug` gives JSON lines on stderr, each tagged with the robot.

use std::process::{Command, Stdio};

#[test]
fn json_log_lines_carry_the_robot_span() {
    let out = Command::new(env!("CARGO_BIN_EXE_sim-agent"))
        .args(["--log-format", "json", "--swarm", "logtest", "--robot", "4", "--eps", "1"])
        .args(["--terrain", "/nonexistent/terrain.txt"])
        .env("RUST_LOG", "debug")
        .env_remove("BYCOMS_LOG_FORMAT")
        .stdin(Stdio::null())
        .output()
        .expect("run sim-agent");
    assert_eq!(out.status.code(), Some(1), "an unreadable terrain is an error");
    let err = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<serde_json::Value> = err
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON ({e}): {l}")))
        .collect();
    let error = lines.iter().find(|v| v["level"] == "ERROR").unwrap_or_else(|| panic!("no error: {err}"));
    let message = error["fields"]["message"].as_str().unwrap_or_default();
    assert!(message.contains("cannot read terrain /nonexistent/terrain.txt"), "{message}");
    assert_eq!(error["span"]["name"], "sim-agent");
    assert_eq!(error["span"]["robot"], 4);
}

#[test]
fn text_log_lines_name_the_robot() {
    let out = Command::new(env!("CARGO_BIN_EXE_sim-agent"))
        .args(["--swarm", "logtest", "--robot", "4", "--eps", "1", "--terrain", "/nonexistent/terrain.txt"])
        .env_remove("RUST_LOG")
        .env_remove("BYCOMS_LOG_FORMAT")
        .stdin(Stdio::null())
        .output()
        .expect("run sim-agent");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("ERROR sim-agent{robot=4}: cannot read terrain"), "{err}");
}
