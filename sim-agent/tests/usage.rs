//! `sim-agent`'s usage errors exit 2 (bad values, like clap's own) before
//! anything is opened; see `sim_agent::cli` for every exit code.

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
