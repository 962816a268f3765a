//! `sim-agent`'s usage errors exit 2 (bad values, like clap's own) before
//! anything is opened; see `bycoms_sim_agent::cli` for every exit code.

use std::process::{Command, Output, Stdio};

fn sim_agent(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sim-agent"))
        .args(args)
        .env_remove("RUST_LOG")
        .env_remove("BYCOMS_LOG_FORMAT")
        .stdin(Stdio::null())
        .output()
        .expect("run sim-agent")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn agent_args<'a>(swarm: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec!["--swarm", swarm, "--robot", "1", "--terrain", "/nonexistent/t.txt", "--eps", "1"];
    v.extend_from_slice(extra);
    v
}

#[test]
fn a_bad_swarm_name_is_a_usage_error_before_the_terrain_is_read() {
    let o = sim_agent(&agent_args("a/b", &[]));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("bad swarm name"), "{}", stderr(&o));
}

#[test]
fn a_bad_connect_endpoint_is_a_usage_error() {
    let o = sim_agent(&agent_args("ok", &["--transport", "zenoh", "--connect", "foo/bar"]));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("bad --connect endpoint \"foo/bar\""), "{}", stderr(&o));
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn help_lists_the_lab_and_the_lab_has_its_own_usage_line() {
    let top = sim_agent(&["--help"]);
    assert_eq!(top.status.code(), Some(0), "{}", stderr(&top));
    let text = stdout(&top);
    assert!(text.lines().any(|l| l.trim_start().starts_with("lab ")), "`lab` listed: {text}");
    let lab = sim_agent(&["lab", "--help"]);
    assert_eq!(lab.status.code(), Some(0), "{}", stderr(&lab));
    let text = stdout(&lab);
    assert!(text.contains("Usage: sim-agent lab [OPTIONS] --scenario <SCENARIO>"), "{text}");
    // A lab flag missing: the error's usage line is the lab's too (exit 2).
    let missing = sim_agent(&["lab", "--swarm", "x"]);
    assert_eq!(missing.status.code(), Some(2));
    assert!(stderr(&missing).contains("Usage: sim-agent lab "), "{}", stderr(&missing));
}

/// The logging flags go in any position (README, "Logs and shell
/// completions"), before the `lab` subcommand too; the robot's own flags
/// do not go with it.
#[test]
fn the_logging_flags_go_before_or_after_the_subcommand() {
    for args in [["--log-format", "json", "lab", "--help"], ["lab", "--log-format", "json", "--help"]] {
        let o = sim_agent(&args);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    }
    let o =
        sim_agent(&["--robot", "1", "lab", "--scenario", "exp-short", "--robots", "r.toml", "--swarm", "s"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("cannot be used with '--robot <ROBOT>'"), "{}", stderr(&o));
}

/// Seconds past any run (`1e300`, `1e20`), NaN or negative: the flag and its
/// range in a usage error (exit 2), never a panic (exit 101) where they
/// become a `Duration` (issue 31).
#[test]
fn huge_or_undefined_seconds_are_usage_errors_naming_the_flag_and_its_range() {
    for value in ["1e300", "1e20", "NaN", "inf"] {
        let o = sim_agent(&agent_args("ok", &["--settings-timeout", value]));
        assert_eq!(o.status.code(), Some(2), "--settings-timeout {value}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("--settings-timeout must be a number of seconds in (0, 100000000]"),
            "{}",
            stderr(&o)
        );
        let o = sim_agent(&agent_args("ok", &["--orchestrator-grace", value]));
        assert_eq!(o.status.code(), Some(2), "--orchestrator-grace {value}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("--orchestrator-grace must be a number of seconds in [0, "),
            "{}",
            stderr(&o)
        );
        let lab = ["lab", "--scenario", "exp-short", "--robots", "/nonexistent/r.toml", "--swarm", "x"];
        let o = sim_agent(&[&lab[..], &["--duration", value]].concat());
        assert_eq!(o.status.code(), Some(2), "lab --duration {value}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("--duration must be a number of seconds in [0, 100000000]"),
            "{}",
            stderr(&o)
        );
        let rate = if value == "inf" { "1e300" } else { "1e-300" };
        let o = sim_agent(&[&lab[..], &["--natnet-rate", rate]].concat());
        assert_eq!(o.status.code(), Some(2), "lab --natnet-rate {rate}: {}", stderr(&o));
        assert!(stderr(&o).contains("--natnet-rate must be a number of Hz in [1, 10000]"), "{}", stderr(&o));
    }
}

/// Milliseconds take the one range of seconds in their unit (issue 49):
/// a heartbeat of u64::MAX ms was no heartbeat at all; and no agent is the
/// child of pid 0 or 1 (it exited at once, "parent gone").
#[test]
fn milliseconds_and_the_parent_pid_are_checked_naming_the_flag() {
    let lab = ["lab", "--scenario", "exp-short", "--robots", "/nonexistent/r.toml", "--swarm", "x"];
    for ms in ["18446744073709551615", "0"] {
        for flag in ["--heartbeat-ms", "--parked-heartbeat-ms"] {
            let o = sim_agent(&agent_args("ok", &[flag, ms]));
            assert_eq!(o.status.code(), Some(2), "{flag} {ms}: {}", stderr(&o));
            assert!(stderr(&o).contains(flag) && stderr(&o).contains("(0, 100000000000]"), "{}", stderr(&o));
        }
        let o = sim_agent(&[&lab[..], &["--mocap-ms", ms]].concat());
        assert_eq!(o.status.code(), Some(2), "lab --mocap-ms {ms}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("--mocap-ms") && stderr(&o).contains("(0, 100000000000]"),
            "{}",
            stderr(&o)
        );
        let doctor =
            ["doctor", "--connect", "tcp/127.0.0.1:7447", "--swarm", "s", "--robot", "1", "--timeout-ms", ms];
        let o = sim_agent(&doctor);
        assert_eq!(o.status.code(), Some(2), "doctor --timeout-ms {ms}: {}", stderr(&o));
        assert!(stderr(&o).contains("--timeout-ms"), "{}", stderr(&o));
    }
    for pid in ["0", "1"] {
        for args in [agent_args("ok", &["--parent-pid", pid]), [&lab[..], &["--parent-pid", pid]].concat()] {
            let o = sim_agent(&args);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
            assert!(
                stderr(&o).contains("--parent-pid") && stderr(&o).contains("(2 or more)"),
                "{}",
                stderr(&o)
            );
        }
    }
}

/// A lab scenario's arena is bounded as terrain files are: `width = 1e300`
/// asked the launch for a grid past any memory (issue 31).
#[test]
fn a_lab_scenario_larger_than_any_terrain_is_refused() {
    let dir = tempfile::tempdir().expect("temp dir");
    let text = bycoms_lab::scenario::EXP_SHORT.replace("width = 3.0", "width = 1e300");
    let file = dir.path().join("huge.toml");
    std::fs::write(&file, text).expect("scenario");
    let robots = dir.path().join("r.toml");
    let args =
        ["lab", "--scenario", file.to_str().expect("utf-8"), "--robots", robots.to_str().expect("utf-8")];
    let o = sim_agent(&[&args[..], &["--swarm", "x", "--duration", "0"]].concat());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("at most 1000 m"), "{}", stderr(&o));
}
