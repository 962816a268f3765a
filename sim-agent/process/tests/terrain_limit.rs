//! An agent refuses an oversized terrain (file or stdin) with the terrain
//! module's size limit, before reading it whole, like every other command.

use bycoms_sim::terrain::MAX_FILE_BYTES;
use std::io::Write;
use std::process::{Command, Stdio};

fn agent() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_sim-agent"));
    cmd.args(["--swarm", "terrainlimit", "--robot", "1", "--eps", "1"])
        .env_remove("RUST_LOG")
        .env_remove("BYCOMS_LOG_FORMAT")
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    cmd
}

#[test]
fn an_oversized_terrain_file_is_refused_by_its_size() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("huge.txt");
    let file = std::fs::File::create(&path).expect("create");
    // Sparse: the length says it all, nothing needs to be written.
    file.set_len(MAX_FILE_BYTES * 4).expect("grow");
    let out = agent().arg("--terrain").arg(&path).stdin(Stdio::null()).output().expect("run sim-agent");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("more than the limit"), "{err}");
    assert!(err.contains(&(MAX_FILE_BYTES * 4).to_string()), "names the size: {err}");
}

#[test]
fn an_oversized_terrain_on_stdin_is_refused_after_the_limit() {
    let mut child = agent().args(["--terrain", "-"]).stdin(Stdio::piped()).spawn().expect("spawn");
    let mut stdin = child.stdin.take().expect("stdin");
    let line = vec![b'.'; 1 << 20];
    // The agent stops reading after the limit; a broken pipe then is fine.
    for _ in 0..4 {
        if stdin.write_all(&line).is_err() {
            break;
        }
    }
    drop(stdin);
    let out = child.wait_with_output().expect("wait");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("more than the limit"), "{err}");
}
