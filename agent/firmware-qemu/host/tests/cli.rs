//! The binary as `.ci/esp32` runs it, on two seconds of lab time: `record`
//! writes the inputs and the live run's output, and `compare` finds the
//! host replay of those inputs equal to the live run, byte for byte; a
//! changed output is found and exits 1; a bad command line exits 2.
//!
//! Being an integration test also makes `cargo test --workspace` build
//! `target/debug/bycoms-fw-host` (Cargo builds a package's binaries for its
//! integration tests), the build `.ci/esp32` then uses as it is.

use std::path::Path;
use std::process::{Command, Output};

fn host(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bycoms-fw-host")).args(args).output().expect("run bycoms-fw-host")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn record_then_compare_finds_the_host_replay_equal_to_the_live_run() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let (input, live) = (dir.path().join("in.bin"), dir.path().join("live.txt"));
    let out = host(&[Path::new("record"), &input, &live, Path::new("2")]);
    assert!(out.status.success(), "record: {}{}", text(&out.stdout), text(&out.stderr));
    assert!(text(&out.stdout).contains("control periods) and"), "{}", text(&out.stdout));
    assert!(text(&out.stdout).contains("2.0 s of lab time"), "{}", text(&out.stdout));

    // The live run stands in for QEMU's output too.
    let out = host(&[Path::new("compare"), &input, &live, &live]);
    assert!(out.status.success(), "compare: {}{}", text(&out.stdout), text(&out.stderr));
    assert_eq!(text(&out.stdout).matches("equal byte for byte").count(), 2, "{}", text(&out.stdout));

    // One changed digit in the last line is a mismatch.
    let mut changed = std::fs::read_to_string(&live).expect("live output");
    let at = changed.trim_end().rfind(|c: char| c.is_ascii_digit()).expect("a digit");
    let digit = if &changed[at..=at] == "7" { "8" } else { "7" };
    changed.replace_range(at..=at, digit);
    let other = dir.path().join("other.txt");
    std::fs::write(&other, changed).expect("write");
    let out = host(&[Path::new("compare"), &input, &live, &other]);
    assert_eq!(out.status.code(), Some(1), "{}{}", text(&out.stdout), text(&out.stderr));
    assert!(text(&out.stdout).contains("host replay != QEMU (riscv32imc) at line"), "{}", text(&out.stdout));
}

#[test]
fn a_bad_command_line_prints_the_usage_and_exits_2() {
    let out = host(&[Path::new("compare"), Path::new("only-one")]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("usage: bycoms-fw-host record"), "{}", text(&out.stderr));
}
