//! The `agent` binary's command line: bad inputs end with a clear message
//! and a non-zero exit before anything is opened. (Also what makes
//! `cargo test --workspace` build the `agent` executable that the
//! end-to-end tests in `tests/` start.)

use std::process::{Command, Stdio};

fn agent(args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_agent"))
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
        "127.0.0.1:0",
        "--key-file",
        "/nonexistent/robot-1.key",
    ]);
    assert_ne!(code, Some(0), "{err}");
    assert!(err.contains("/nonexistent/robot-1.key"), "names the file: {err}");
}

#[test]
fn robot_zero_and_a_bad_address_are_usage_errors() {
    let (code, err) =
        agent(&["--swarm", "gwcli", "--robot", "0", "--bind", "127.0.0.1:0", "--key-file", "k"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--robot"), "{err}");
    let (code, err) = agent(&["--swarm", "gwcli", "--robot", "1", "--bind", "nowhere", "--key-file", "k"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--bind"), "{err}");
}

#[test]
fn a_bad_swarm_name_is_a_usage_error() {
    let (code, err) =
        agent(&["--swarm", "a/b", "--robot", "1", "--bind", "127.0.0.1:0", "--key-file", "/nonexistent/k"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("bad swarm name"), "{err}");
}
