//! The open files a launch needs, through the binary: under a hard limit
//! too low for its ports a launch is refused before anything starts (exit
//! 2, the limit and the fix named); under a low soft limit it raises its own
//! and runs. The shell's `ulimit` sets the limits of the process it starts.

use std::process::Command;

fn launch_under(ulimit: &str, robots: &str) -> std::process::Output {
    let dir = tempfile::tempdir().expect("tempdir");
    let swarm = format!("files-{}-{robots}", std::process::id());
    let script = format!("{ulimit} && exec \"$0\" launch --robots {robots} --swarm {swarm} --dwell 1",);
    Command::new("sh")
        .args(["-c", &script, env!("CARGO_BIN_EXE_orchestrator")])
        .current_dir(dir.path())
        .env("RUST_LOG", "error")
        .env("BYCOMS_IPC_ISOLATION", format!("files{}", std::process::id()))
        .output()
        .expect("spawn sh")
}

#[test]
fn a_launch_beyond_the_hard_limit_is_refused_before_anything_starts() {
    // 20 robots over iceoryx2 need about 544 open files per process.
    let o = launch_under("ulimit -n 200", "20");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("open files") && err.contains("200") && err.contains("ulimit"), "{err}");
    assert!(!err.contains("robot 1:"), "nothing started: {err}");
}

#[test]
fn a_launch_under_a_low_soft_limit_raises_it_and_runs() {
    // Soft 100, hard as it is: 3 robots need about 136.
    let o = launch_under("ulimit -Sn 100", "3");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(matches!(o.status.code(), Some(0 | 3)), "{err}");
}
