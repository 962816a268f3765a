//! `orchestrator replay FILE.mcap` on real lockstep launch recordings: the
//! gate re-run from the recorded poses reaches every recorded decision at
//! the same step and position (exit 0); a recording whose decision was
//! moved by one step is a mismatch (exit 1, the line named), and so is one
//! whose recorded poses are not what its core log handed the core.

use bycoms_protocol::msg::{GateEvent, GateKind, Pose};
use bycoms_protocol::{decode, encode, MAX_MESSAGE_LEN};
use bycoms_tests::{swarm_name, Proc};
use std::borrow::Cow;
use std::path::Path;
use std::time::Duration;

fn record_launch(path: &Path, extra: &[&str]) {
    let swarm = swarm_name("replay");
    let mut args = vec!["launch", "--swarm", &swarm, "--record", path.to_str().expect("utf-8")];
    args.extend_from_slice(extra);
    let out = Proc::orchestrator(&args).wait(Duration::from_secs(90));
    assert!(matches!(out.status.code(), Some(0 | 3)), "{}", out.stderr);
}

fn replay(path: &Path) -> bycoms_tests::Finished {
    Proc::orchestrator(&["replay", path.to_str().expect("utf-8")]).wait(Duration::from_secs(60))
}

/// Copies a recording, moving the first "stuck" gate event one step later.
fn tamper(from: &Path, to: &Path) -> GateEvent {
    let mut moved = None;
    rewrite(from, to, |schema, data| {
        if schema != "bycoms.GateEvent" || moved.is_some() {
            return None;
        }
        let mut event: GateEvent = decode(data).expect("gate event");
        if event.kind != (GateKind::Stopped { arrived: false }) {
            return None;
        }
        event.step += 1;
        moved = Some(event);
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        Some(encode(&event, &mut buf).expect("encode").to_vec())
    });
    moved.expect("the run has a stuck robot")
}

/// Copies a recording, moving robot 1's 100th recorded pose by 1 mm.
fn tamper_pose(from: &Path, to: &Path) {
    let mut seen = 0;
    rewrite(from, to, |schema, data| {
        if schema != "bycoms.Pose" {
            return None;
        }
        let mut pose: Pose = decode(data).expect("pose");
        if pose.robot.0 != 1 {
            return None;
        }
        seen += 1;
        if seen != 100 {
            return None;
        }
        pose.x += 0.001;
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        Some(encode(&pose, &mut buf).expect("encode").to_vec())
    });
    assert!(seen >= 100, "robot 1 has 100 poses on record");
}

/// Copies a recording, message by message; `change` may replace a postcard
/// message's bytes (it is given the schema name and the bytes).
fn rewrite(from: &Path, to: &Path, mut change: impl FnMut(&str, &[u8]) -> Option<Vec<u8>>) {
    let bytes = std::fs::read(from).expect("read recording");
    let out = std::fs::File::create(to).expect("create copy");
    let mut writer = mcap::WriteOptions::new().create(std::io::BufWriter::new(out)).expect("writer");
    for message in mcap::MessageStream::new(&bytes).expect("mcap") {
        let mut message = message.expect("message");
        let schema = message.channel.schema.as_ref().map(|s| s.name.clone()).unwrap_or_default();
        if message.channel.message_encoding == "postcard" {
            if let Some(data) = change(&schema, &message.data) {
                message.data = Cow::Owned(data);
            }
        }
        writer.write(&message).expect("write");
    }
    writer.finish().expect("finish");
}

#[test]
fn a_lockstep_launch_replays_to_the_same_decisions_and_a_moved_one_is_caught() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("launch.mcap");
    // The paper's 3-robot run: 2 stuck, 1 arrival.
    record_launch(&path, &[]);
    let out = replay(&path);
    assert_eq!(out.status.code(), Some(0), "{}\n{}", out.stdout, out.stderr);
    assert!(out.stdout.contains("MATCH:"), "{}", out.stdout);
    assert_eq!(out.stdout.matches("  same ").count(), 6, "3 deployments, 3 decisions:\n{}", out.stdout);

    let tampered = dir.path().join("tampered.mcap");
    let moved = tamper(&path, &tampered);
    let out = replay(&tampered);
    assert_eq!(out.status.code(), Some(1), "{}\n{}", out.stdout, out.stderr);
    assert!(out.stdout.contains("MISMATCH: 1 of 6"), "{}", out.stdout);
    let line = out.stdout.lines().find(|l| l.contains("MISMATCH  recorded")).expect("a mismatch line");
    assert!(line.contains(&format!("step {}", moved.step)), "{line}");

    // The core log is evidence only with the traffic it came from.
    let tampered = dir.path().join("tampered-pose.mcap");
    tamper_pose(&path, &tampered);
    let out = replay(&tampered);
    assert_eq!(out.status.code(), Some(1), "{}\n{}", out.stdout, out.stderr);
    assert!(out.stdout.contains("a pose that is not on the record: robot 1"), "{}", out.stdout);
}

#[test]
fn a_noisy_launch_with_a_time_limit_replays_too() {
    // Sensing noise and a budget the second robot runs out of: timeouts and
    // noisy turning go through the same replay.
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("noisy.mcap");
    record_launch(&path, &["--noise", "--seed", "7", "--time-limit", "60"]);
    let out = replay(&path);
    assert_eq!(out.status.code(), Some(0), "{}\n{}", out.stdout, out.stderr);
    assert!(out.stdout.contains("MATCH:"), "{}", out.stdout);
    assert!(out.stdout.contains(" timeout at "), "the budget runs out:\n{}", out.stdout);
}

#[test]
fn a_file_that_is_not_a_recording_is_an_error() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("junk.mcap");
    std::fs::write(&path, b"not an mcap file").expect("write");
    let out = replay(&path);
    assert_eq!(out.status.code(), Some(1), "{}", out.stderr);
    assert!(out.stderr.contains("junk.mcap is not an MCAP file"), "{}", out.stderr);
}

/// A copy of a recording compressed by the mcap crate's writer (as the
/// `mcap` CLI and the Python writer write by default).
fn compressed(from: &Path, to: &Path, compression: mcap::Compression) {
    let bytes = std::fs::read(from).expect("read recording");
    let out = std::fs::File::create(to).expect("create copy");
    let options = mcap::WriteOptions::new().compression(Some(compression));
    let mut writer = options.create(std::io::BufWriter::new(out)).expect("writer");
    for message in mcap::MessageStream::new(&bytes).expect("mcap") {
        writer.write(&message.expect("message")).expect("write");
    }
    writer.finish().expect("finish");
}

#[test]
fn zstd_and_lz4_copies_of_a_launch_replay_and_draw() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("launch.mcap");
    record_launch(&path, &[]);
    for (name, compression) in [("zstd", mcap::Compression::Zstd), ("lz4", mcap::Compression::Lz4)] {
        let packed = dir.path().join(format!("{name}.mcap"));
        compressed(&path, &packed, compression);
        let out = replay(&packed);
        assert_eq!(out.status.code(), Some(0), "{name}: {}\n{}", out.stdout, out.stderr);
        assert!(out.stdout.contains("MATCH:"), "{name}: {}", out.stdout);
        let drawn =
            Proc::orchestrator(&["draw", packed.to_str().expect("utf-8")]).wait(Duration::from_secs(60));
        assert_eq!(drawn.status.code(), Some(0), "{name}: {}", drawn.stderr);
        assert!(dir.path().join(format!("{name}.svg")).is_file(), "{name}");
    }
}

/// A copy of a recording in chunks of at most 64 KiB (many chunks).
fn small_chunks(from: &Path, to: &Path) {
    let bytes = std::fs::read(from).expect("read recording");
    let out = std::fs::File::create(to).expect("create copy");
    let options = mcap::WriteOptions::new().chunk_size(Some(64 * 1024));
    let mut writer = options.create(std::io::BufWriter::new(out)).expect("writer");
    for message in mcap::MessageStream::new(&bytes).expect("mcap") {
        writer.write(&message.expect("message")).expect("write");
    }
    writer.finish().expect("finish");
}

/// Flips a bit of the stored CRC of chunk `which` (by its index; `None`:
/// the last) of the finished recording at `path`; returns the chunk count.
fn damage_chunk(path: &Path, which: Option<usize>) -> usize {
    let mut bytes = std::fs::read(path).expect("read recording");
    let summary = mcap::Summary::read(&bytes).expect("summary").expect("a finished recording");
    let chunks = summary.chunk_indexes.len();
    let chunk = &summary.chunk_indexes[which.unwrap_or(chunks - 1)];
    // Opcode and length (9 bytes), the start and end times and the size (24): its CRC.
    bytes[chunk.chunk_start_offset as usize + 9 + 24] ^= 0x80;
    std::fs::write(path, &bytes).expect("write the damaged recording");
    chunks
}

/// Issue 49: `record recover` of a recording whose last chunk is damaged
/// writes a copy without it, and every reader of the copy says it is not
/// the whole run: `replay`'s MATCH is "of part of the run only" (it said a
/// plain MATCH, with one decision fewer), `replay` and `record export`
/// warn. A damaged first chunk, which holds the run metadata, is named as
/// such (it was "not a bycoms launch recording").
#[test]
fn a_recovered_copy_of_a_damaged_recording_says_it_is_part_of_the_run() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("launch.mcap");
    record_launch(&path, &[]);
    let chunked = dir.path().join("chunked.mcap");
    small_chunks(&path, &chunked);
    assert!(damage_chunk(&chunked, None) >= 3, "a recording of several chunks");
    let fixed = dir.path().join("fixed.mcap");
    let (c, f) = (chunked.to_str().expect("utf-8"), fixed.to_str().expect("utf-8"));
    let recovered = Proc::orchestrator(&["record", "recover", c, "--out", f]).wait(Duration::from_secs(60));
    assert_eq!(recovered.status.code(), Some(1), "damaged: {}", recovered.stderr);
    let out = replay(&fixed);
    assert_eq!(out.status.code(), Some(0), "{}\n{}", out.stdout, out.stderr);
    let verdict = out.stdout.lines().find(|l| l.starts_with("MATCH:")).expect("the verdict");
    assert!(
        verdict.contains("of part of the run only") && verdict.contains("left out as damaged: 1 chunk"),
        "{verdict}"
    );
    assert!(
        out.stderr.contains("not the whole run, a copy by `orchestrator record recover`"),
        "{}",
        out.stderr
    );
    let bag = dir.path().join("bag.mcap");
    let export = ["record", "export", "--ros2", f, "--out", bag.to_str().expect("utf-8")];
    let out = Proc::orchestrator(&export).wait(Duration::from_secs(60));
    assert_eq!(out.status.code(), Some(0), "{}", out.stderr);
    assert!(out.stderr.contains("not the whole run"), "{}", out.stderr);

    // The launch's own recording, its first chunk (the run metadata's) damaged.
    damage_chunk(&path, Some(0));
    let out =
        Proc::orchestrator(&["record", "recover", path.to_str().expect("utf-8"), "--out", f, "--force"])
            .wait(Duration::from_secs(60));
    assert_eq!(out.status.code(), Some(1), "{}", out.stderr);
    assert!(
        out.stderr.contains("the chunk holding the run metadata (bycoms/<swarm>/run) is damaged"),
        "{}",
        out.stderr
    );
    assert!(!out.stderr.contains("not a bycoms launch recording"), "{}", out.stderr);
}
