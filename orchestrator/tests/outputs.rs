//! The overwrite rule, end to end through the binary: an output never
//! replaces one of the command's inputs, another output of the same run or
//! a file of another kind, and replaces its own kind only with `--force`
//! (`crate::out::files`); "not a recording" is one error (exit 1) for every
//! command that reads recordings; `certs` never silently replaces a lab's CA.

use std::path::Path;
use std::process::{Command, Output};

use bycoms_orchestrator::record::Recorder;

fn orchestrator_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("spawn orchestrator")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A small finished recording with the run metadata `draw` needs.
fn launch_recording(path: &Path) {
    let mut recorder = Recorder::create(path).expect("create");
    let meta = serde_json::json!({
        "terrain": "tiny", "terrain_text": "S....\n.....\n....G\n",
        "start": { "x": 0.5, "y": 2.5 }, "goal": { "x": 4.5, "y": 0.5 }, "swarm": "t",
        "config": { "eps": 1.0, "clock": "lockstep" },
    });
    recorder.record_json("bycoms/t/run", "bycoms.LaunchConfig", 0, &meta).expect("run metadata");
    for i in 0..20u64 {
        recorder.record_bytes("bycoms/t/tick", "bycoms.Tick", i, i, &i.to_le_bytes()).expect("record");
    }
    recorder.finish().expect("finish");
}

/// Asserts a refusal: exit 2, the message contains `says`, every file in `kept` unchanged.
fn refused(out: &Output, says: &str, kept: &[(&Path, &[u8])]) {
    assert_eq!(out.status.code(), Some(2), "{}", stderr(out));
    assert!(stderr(out).contains(says), "expected {says:?} in: {}", stderr(out));
    for (path, bytes) in kept {
        assert_eq!(std::fs::read(path).expect("still there"), *bytes, "{} was changed", path.display());
    }
}

#[test]
fn record_recover_never_truncates_its_input_however_out_is_spelled() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = dir.path().join("X.mcap");
    launch_recording(&input);
    let bytes = std::fs::read(&input).expect("read");
    std::os::unix::fs::symlink(&input, dir.path().join("link.mcap")).expect("symlink");
    let absolute = input.to_str().expect("utf-8").to_string();
    for out in ["./X.mcap", absolute.as_str(), "link.mcap", "sub/../X.mcap"] {
        std::fs::create_dir_all(dir.path().join("sub")).expect("sub");
        let o = orchestrator_in(dir.path(), &["record", "recover", "X.mcap", "--out", out, "--force"]);
        refused(&o, "refusing to overwrite an input", &[(&input, &bytes)]);
    }
    // A good copy still works, and leaves no temporary file behind.
    let o = orchestrator_in(dir.path(), &["record", "recover", "X.mcap", "--out", "copy.mcap"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn draw_never_replaces_its_recording_or_another_recording() {
    let dir = tempfile::tempdir().expect("temp dir");
    let a = dir.path().join("a.mcap");
    let b = dir.path().join("b.mcap");
    launch_recording(&a);
    launch_recording(&b);
    let (a_bytes, b_bytes) = (std::fs::read(&a).expect("a"), std::fs::read(&b).expect("b"));
    let kept: [(&Path, &[u8]); 2] = [(&a, &a_bytes), (&b, &b_bytes)];
    for force in [&[][..], &["--force"][..]] {
        let o = orchestrator_in(dir.path(), &[&["draw", "a.mcap", "--out", "a.mcap"], force].concat());
        refused(&o, "refusing to overwrite an input", &kept);
        let o = orchestrator_in(dir.path(), &[&["draw", "a.mcap", "--out", "b.mcap"], force].concat());
        refused(&o, "is an MCAP recording, not an SVG picture", &kept);
    }
    // Its own kind: a new picture, then again only with --force.
    let o = orchestrator_in(dir.path(), &["draw", "a.mcap"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let svg = std::fs::read(dir.path().join("a.svg")).expect("a.svg");
    let o = orchestrator_in(dir.path(), &["draw", "a.mcap"]);
    refused(&o, "give --force to replace it", &[(&dir.path().join("a.svg"), &svg)]);
    let o = orchestrator_in(dir.path(), &["draw", "a.mcap", "--force"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn simulate_never_draws_over_its_terrain_or_its_other_picture() {
    let dir = tempfile::tempdir().expect("temp dir");
    let terrain = dir.path().join("t.txt");
    let text = b"S.......\n........\n.......G\n";
    std::fs::write(&terrain, text).expect("terrain");
    let o = orchestrator_in(dir.path(), &["simulate", "--terrain", "t.txt", "--svg", "t.txt", "--force"]);
    refused(&o, "refusing to overwrite an input", &[(&terrain, text)]);
    let o = orchestrator_in(
        dir.path(),
        &["simulate", "--terrain", "t.txt", "--svg", "s.svg", "--animate", "./s.svg"],
    );
    refused(&o, "are the same file", &[(&terrain, text)]);
    assert!(!dir.path().join("s.svg").exists(), "nothing was written");
    let o = orchestrator_in(dir.path(), &["simulate", "--terrain", "t.txt", "--svg", "s.svg"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let svg = std::fs::read(dir.path().join("s.svg")).expect("s.svg");
    let o = orchestrator_in(dir.path(), &["simulate", "--terrain", "t.txt", "--svg", "s.svg"]);
    refused(&o, "give --force to replace it", &[(&dir.path().join("s.svg"), &svg)]);
    assert!(stdout_is_empty(&o), "refused before the run: {}", String::from_utf8_lossy(&o.stdout));
    let o = orchestrator_in(dir.path(), &["simulate", "--terrain", "t.txt", "--svg", "s.svg", "--force"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

fn stdout_is_empty(o: &Output) -> bool {
    o.stdout.is_empty()
}

#[test]
fn launch_outputs_are_checked_before_anything_starts() {
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = format!("outputs-{}", std::process::id());
    // Two outputs, one file: refused before any agent starts (nothing is created).
    let o =
        orchestrator_in(dir.path(), &["launch", "--swarm", &swarm, "--record", "r.mcap", "--svg", "r.mcap"]);
    refused(&o, "are the same file", &[]);
    assert!(!dir.path().join("r.mcap").exists(), "nothing was written");
    // A picture over a recording: never, not even with --force.
    let old = dir.path().join("old.mcap");
    launch_recording(&old);
    let bytes = std::fs::read(&old).expect("old");
    for force in [&[][..], &["--force"][..]] {
        let o = orchestrator_in(
            dir.path(),
            &[&["launch", "--swarm", &swarm, "--svg", "old.mcap"], force].concat(),
        );
        refused(&o, "is an MCAP recording, not an SVG picture", &[(&old, &bytes)]);
    }
    // The recording over its own terrain.
    let terrain = dir.path().join("t.txt");
    std::fs::write(&terrain, b"S.......\n.......G\n").expect("terrain");
    let o = orchestrator_in(
        dir.path(),
        &["launch", "--swarm", &swarm, "--terrain", "t.txt", "--record", "t.txt", "--force"],
    );
    refused(&o, "refusing to overwrite an input", &[(&terrain, b"S.......\n.......G\n")]);
}

#[test]
fn a_file_that_is_not_a_recording_is_one_error_for_every_reader() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cases: [(&str, &[u8]); 4] = [
        ("empty.mcap", b""),
        ("text.mcap", b"just some text\n"),
        ("short.mcap", b"\x89MC"),
        ("garbage.mcap", &[0x13, 0x37, 0x00, 0xff, 0x42, 0x00, 0x01, 0x02, 0x03, 0x04, 0x05]),
    ];
    for (name, bytes) in cases {
        std::fs::write(dir.path().join(name), bytes).expect("write");
        for command in [&["record", "recover", name][..], &["draw", name][..], &["replay", name][..]] {
            let o = orchestrator_in(dir.path(), command);
            assert_eq!(o.status.code(), Some(1), "{command:?}: {}", stderr(&o));
            assert!(
                stderr(&o).contains(&format!("{name} is not an MCAP recording")),
                "{command:?}: {}",
                stderr(&o)
            );
        }
        let stem = name.trim_end_matches(".mcap");
        for made in [format!("{stem}.recovered.mcap"), format!("{stem}.svg")] {
            assert!(!dir.path().join(&made).exists(), "{made} was written for {name}");
        }
    }
}
