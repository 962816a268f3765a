//! The `ros2-robot` command line as a user meets it: its help, and every
//! unusable value refused with exit code 2 naming the flag, before the
//! agent joins anything.

use std::process::Command;

fn ros2_robot(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_ros2-robot")).args(args).output().expect("ros2-robot runs");
    let text = |b: Vec<u8>| String::from_utf8(b).expect("utf-8");
    (out.status.code(), text(out.stdout), text(out.stderr))
}

const BASE: [&str; 8] =
    ["--swarm", "lab", "--robot", "1", "--ros2-router", "tcp/127.0.0.1:9", "--eps", "0.3"];

#[test]
fn help_names_what_the_agent_does_and_its_flags() {
    let (code, out, _) = ros2_robot(&["--help"]);
    assert_eq!(code, Some(0));
    for words in
        ["cmd_vel", "--ros2-router", "--message", "twist-stamped", "--eps", "--max-linear", "--wheel-base"]
    {
        assert!(out.contains(words), "{words} missing from --help:\n{out}");
    }
}

#[test]
fn unusable_values_exit_2_naming_the_flag() {
    let cases: [(&[&str], &str); 5] = [
        (&["--eps", "-1"], "--eps"),
        (&["--max-linear", "0"], "--max-linear"),
        (&["--message", "Twist"], "twist-stamped"),
        (&["--pose-timeout-ms", "10"], "--pose-timeout-ms"),
        (&["--swarm", "a b"], "swarm"),
    ];
    for (extra, words) in cases {
        let mut args: Vec<&str> = BASE.to_vec();
        args.extend_from_slice(extra);
        let (code, _, err) = ros2_robot(&args);
        assert_eq!(code, Some(2), "{extra:?}: {err}");
        assert!(err.contains(words), "{extra:?}: {err}");
    }
}

#[test]
fn no_router_at_the_endpoint_is_an_error_naming_it() {
    // Port 9 (discard) on loopback: nothing listens.
    let (code, _, err) = ros2_robot(&BASE);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("no zenoh router answers at tcp/127.0.0.1:9") && err.contains("rmw_zenohd"),
        "{err}"
    );
}
