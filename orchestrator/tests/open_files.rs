//! The open files a launch needs, through the binary: under a hard limit
//! too low for its ports a launch is refused before anything starts (exit
//! 2, the limit and the fix named); under a low soft limit it raises its own
//! and runs. The shell's `ulimit` sets the limits of the process it starts.

use bycoms_protocol::bus::ipc::root;
use std::process::Command;

/// This test's own iceoryx2 root (the launches run under a shell with
/// other limits), removed with everything in it when the test ends: the
/// root's folder and its files in shared memory.
struct Root(String);

impl Root {
    fn new(robots: &str) -> Self {
        Root(format!("files{}-{robots}", std::process::id()))
    }
}

impl Drop for Root {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(root::root_dir(&self.0));
        let prefix = root::prefix(&self.0);
        for entry in std::fs::read_dir("/dev/shm").into_iter().flatten().flatten() {
            if entry.file_name().to_string_lossy().starts_with(&prefix) {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
}

fn launch_under(ulimit: &str, robots: &str) -> std::process::Output {
    let root = Root::new(robots);
    let dir = tempfile::tempdir().expect("tempdir");
    let swarm = format!("files-{}-{robots}", std::process::id());
    let script = format!("{ulimit} && exec \"$0\" launch --robots {robots} --swarm {swarm} --dwell 1",);
    Command::new("sh")
        .args(["-c", &script, env!("CARGO_BIN_EXE_orchestrator")])
        .current_dir(dir.path())
        .env("RUST_LOG", "error")
        .env(root::ISOLATION_ENV, &root.0)
        .output()
        .expect("spawn sh")
}

#[test]
fn a_launch_beyond_the_hard_limit_is_refused_before_anything_starts() {
    // 20 robots over iceoryx2 need about 444 open files in the orchestrator.
    let o = launch_under("ulimit -n 200", "20");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("open files") && err.contains("200") && err.contains("ulimit"), "{err}");
    assert!(!err.contains("robot 1:"), "nothing started: {err}");
}

#[test]
fn a_launch_under_a_low_soft_limit_raises_it_and_runs() {
    // Soft 100, hard as it is: 3 robots need about 121.
    let o = launch_under("ulimit -Sn 100", "3");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(matches!(o.status.code(), Some(0 | 3)), "{err}");
}
