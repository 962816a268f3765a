//! Error texts through the binary: each cause said once, no source paths of
//! our dependencies, values named as the user wrote them (flag or config
//! key), and usage errors (a bad name, a bad endpoint) exit 2 before
//! anything starts.

use std::path::Path;
use std::process::{Command, Output};

fn orchestrator_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .args(args)
        .current_dir(dir)
        .env("RUST_LOG", "error")
        .output()
        .expect("spawn orchestrator")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `args` in a fresh directory; checks the exit code and that every
/// fragment of `once` occurs exactly once on stderr.
fn check(args: &[&str], code: i32, once: &[&str]) -> String {
    let dir = tempfile::tempdir().expect("tempdir");
    let o = orchestrator_in(dir.path(), args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
    for fragment in once {
        assert_eq!(err.matches(fragment).count(), 1, "{args:?}: {fragment:?} once in: {err}");
    }
    err
}

#[test]
fn an_os_error_is_said_once() {
    check(
        &["draw", "/nonexistent/run.mcap", "--out", "x.svg"],
        1,
        &["cannot open recording /nonexistent/run.mcap", "No such file or directory (os error 2)"],
    );
    check(
        &["simulate", "--terrain", "/nonexistent/t.txt", "--no-svg"],
        1,
        &["No such file or directory (os error 2)"],
    );
}

#[test]
fn a_parse_error_position_is_said_once() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("bad.txt");
    std::fs::write(&bad, "x\n").expect("write");
    let err =
        check(&["simulate", "--terrain", bad.to_str().expect("utf-8"), "--no-svg"], 1, &["line 1, column 1"]);
    assert!(err.contains("unknown character 'x'"), "{err}");
}

#[test]
fn a_run_parameter_is_named_as_the_user_wrote_it() {
    check(&["simulate", "--success-radius", "0", "--no-svg"], 2, &["bad --success-radius: "]);
    check(&["simulate", "--eps", "0", "--no-svg"], 2, &["bad --eps: "]);
    let dir = tempfile::tempdir().expect("tempdir");
    for (text, key) in
        [("eps = -1\n", "eps"), ("goal_radius = -1\n", "goal_radius"), ("time_limit = 0\n", "time_limit")]
    {
        let config = dir.path().join("launch.toml");
        std::fs::write(&config, text).expect("write");
        let err =
            check(&["launch", "--config", config.to_str().expect("utf-8")], 2, &[&format!("bad {key} (--")]);
        assert!(!err.contains("bad the"), "{err}");
    }
    check(&["launch", "--goal-radius", "0"], 2, &["bad goal_radius (--goal-radius): "]);
}

#[test]
fn a_bad_swarm_name_is_a_usage_error() {
    let err = check(&["launch", "--swarm", "a/b"], 2, &["bad swarm name \"a/b\""]);
    assert!(!err.contains("starting"), "refused before anything starts: {err}");
    check(&["bridge", "--swarm", "a/b"], 2, &["bad swarm name \"a/b\""]);
}

#[test]
fn a_bad_zenoh_endpoint_is_a_usage_error() {
    for endpoint in ["foo/bar", "tcp/", "udp/127.0.0.1:7447", "tcp/127.0.0.1:99999", "tcp/127.0.0.1"] {
        check(
            &["launch", "--transport", "zenoh", "--listen", endpoint],
            2,
            &[&format!("bad transport.listen endpoint {endpoint:?}")],
        );
        check(
            &["launch", "--transport", "zenoh", "--listen", "tcp/127.0.0.1:0", "--connect", endpoint],
            2,
            &[&format!("bad transport.connect endpoint {endpoint:?}")],
        );
        check(
            &["bridge", "--swarm", "s", "--listen", endpoint],
            2,
            &[&format!("bad --listen endpoint {endpoint:?}")],
        );
    }
}

#[test]
fn zenoh_errors_carry_no_source_path_of_zenoh() {
    let dir = tempfile::tempdir().expect("tempdir");
    let config = dir.path().join("zenoh.json5");
    std::fs::write(&config, "{bad").expect("write");
    let args = ["launch", "--transport", "zenoh", "--listen", "tcp/127.0.0.1:0", "--zenoh-config"];
    let mut args = args.to_vec();
    args.push(config.to_str().expect("utf-8"));
    let err = check(&args, 1, &["bus failed to read zenoh config"]);
    assert!(!err.contains(".rs:"), "no source location: {err}");
    assert!(!err.contains("registry/src"), "no cargo registry path: {err}");
}
