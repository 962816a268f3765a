//! The MCAP recorder: round trip through the mcap crate's readers, survival of `kill -9`,
//! and the Python `mcap` reader (1.6.0, as `.ci/run` installs it).
//!
//! The Python checks are `#[ignore = "needs python3 with mcap==1.6.0"]`: `cargo test` alone
//! runs without Python, and `.ci/run` runs them with `--include-ignored`, where a missing
//! python3 or package fails them, saying so (they never pass without having looked).

use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use bycoms_record::{read_counts, recover, schema, RecordError, Recorder};

const TOPICS: [&str; 3] = ["bycoms/s1/agent/0/to_agent", "bycoms/s1/agent/0/pose", "bycoms/s1/tick"];
const SCHEMAS: [&str; 3] = ["bycoms.ToAgent", "bycoms.Pose", "bycoms.Tick"];
const GATE: &str = "bycoms/s1/gate";
/// The run metadata's topic: a launch recording holds one (its content is not read here).
const RUN: &str = "bycoms/s1/run";

/// The payload of message `i`: varied lengths (including empty) and contents.
fn payload(i: u64) -> Vec<u8> {
    (0..(i % 97)).map(|k| (i.wrapping_mul(31).wrapping_add(k) % 251) as u8).collect()
}

#[derive(serde::Serialize, serde::Deserialize, Debug, PartialEq)]
struct GateEvent {
    robot: u32,
    state: String,
    t: f64,
}

/// Writes `n` messages round-robin on [`TOPICS`] and `events` gate events; returns the file.
fn write_sample(dir: &Path, n: u64, events: u32) -> PathBuf {
    write_sample_of(dir, n, events, false)
}

/// [`write_sample`] of a launch: the run metadata first ([`RUN`]), as `draw`, `replay` and
/// `record recover` require.
fn write_launch_sample(dir: &Path, n: u64, events: u32) -> PathBuf {
    write_sample_of(dir, n, events, true)
}

fn write_sample_of(dir: &Path, n: u64, events: u32, launch: bool) -> PathBuf {
    let path = dir.join("run.mcap");
    let mut recorder = Recorder::create(&path).expect("create recording");
    if launch {
        recorder.record_json(RUN, schema::RUN, 0, &serde_json::json!({})).expect("run");
    }
    for i in 0..n {
        let k = (i % 3) as usize;
        recorder.record_bytes(TOPICS[k], SCHEMAS[k], 1_000 + i * 10, 500 + i, &payload(i)).expect("record");
    }
    for robot in 0..events {
        let event = GateEvent { robot, state: "arrived".into(), t: f64::from(robot) * 0.5 };
        recorder.record_json(GATE, "bycoms.GateEvent", 2_000_000 + u64::from(robot), &event).expect("json");
    }
    let all = n + u64::from(events) + u64::from(launch);
    assert_eq!(recorder.counts().values().sum::<u64>(), all);
    let summary = recorder.finish().expect("finish");
    assert_eq!(summary.messages, all);
    // For looking at a sample with other tools (Foxglove, `mcap info`): BYCOMS_RECORD_KEEP=dir.
    if let Some(keep) = std::env::var_os("BYCOMS_RECORD_KEEP") {
        std::fs::copy(&path, Path::new(&keep).join(format!("sample-{n}.mcap"))).expect("keep a copy");
    }
    path
}

fn expected_counts(n: u64, events: u32) -> BTreeMap<String, u64> {
    let mut counts: BTreeMap<String, u64> = TOPICS.iter().map(|t| (t.to_string(), n / 3)).collect();
    for i in 0..n % 3 {
        *counts.entry(TOPICS[i as usize].to_string()).or_default() += 1;
    }
    counts.insert(GATE.to_string(), u64::from(events));
    counts
}

/// [`expected_counts`] of [`write_launch_sample`].
fn expected_launch_counts(n: u64, events: u32) -> BTreeMap<String, u64> {
    let mut counts = expected_counts(n, events);
    counts.insert(RUN.to_string(), 1);
    counts
}

#[test]
fn round_trip_through_the_mcap_readers() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (n, events) = (3_001, 7);
    let path = write_sample(dir.path(), n, events);
    let expected = expected_counts(n, events);

    assert_eq!(read_counts(&path).expect("read_counts"), expected);
    assert!(recover(&path).expect("recover").is_complete());

    let bytes = std::fs::read(&path).expect("read file");
    let summary = mcap::Summary::read(&bytes).expect("summary parses").expect("file has a summary");
    let stats = summary.stats.as_ref().expect("statistics");
    assert_eq!(stats.message_count, n + u64::from(events));
    assert_eq!(stats.channel_count, 4);
    assert_eq!(stats.schema_count, 4);
    assert!(!summary.chunk_indexes.is_empty(), "the finished file is indexed");

    let mut seen: BTreeMap<String, u64> = BTreeMap::new();
    let (mut i, mut robot) = (0u64, 0u32);
    for message in mcap::MessageStream::new(&bytes).expect("message stream") {
        let message = message.expect("message");
        let channel = &message.channel;
        let schema = channel.schema.as_ref().expect("every channel has a schema");
        *seen.entry(channel.topic.clone()).or_default() += 1;
        if channel.topic == GATE {
            assert_eq!((channel.message_encoding.as_str(), schema.encoding.as_str()), ("json", "jsonschema"));
            assert_eq!(schema.name, "bycoms.GateEvent");
            assert_eq!(message.log_time, 2_000_000 + u64::from(robot));
            let event: GateEvent = serde_json::from_slice(&message.data).expect("gate event is JSON");
            assert_eq!(event, GateEvent { robot, state: "arrived".into(), t: f64::from(robot) * 0.5 });
            robot += 1;
        } else {
            let k = (i % 3) as usize;
            assert_eq!(channel.topic, TOPICS[k], "messages come back in write order");
            assert_eq!((channel.message_encoding.as_str(), schema.name.as_str()), ("postcard", SCHEMAS[k]));
            assert_eq!((message.log_time, message.publish_time), (1_000 + i * 10, 500 + i));
            assert_eq!(message.data.as_ref(), payload(i).as_slice(), "payload of message {i}");
            i += 1;
        }
    }
    assert_eq!((i, robot), (n, events));
    assert_eq!(seen, expected);
}

#[test]
fn errors_name_the_file_and_the_topic() {
    let dir = tempfile::tempdir().expect("temp dir");
    let missing = dir.path().join("no/such/dir/run.mcap");
    let error = Recorder::create(&missing).err().expect("cannot create in a missing directory");
    assert!(error.to_string().contains("no/such/dir/run.mcap"), "{error}");

    let mut recorder = Recorder::create(&dir.path().join("run.mcap")).expect("create");
    recorder.record_bytes("t", "bycoms.A", 1, 1, b"x").expect("first use");
    let mismatch = recorder.record_json("t", "bycoms.A", 2, &1).expect_err("json on a postcard topic");
    assert!(matches!(mismatch, RecordError::TopicMismatch { .. }), "{mismatch}");
    recorder.finish().expect("finish");

    let junk = dir.path().join("junk.mcap");
    std::fs::write(&junk, b"definitely not an MCAP recording").expect("write junk");
    let error = read_counts(&junk).expect_err("not MCAP");
    assert!(
        matches!(error, RecordError::NotMcap { .. }) && error.to_string().contains("junk.mcap"),
        "{error}"
    );
}

/// The environment variable that turns [`crash_child`] into the recording child.
const CHILD_ENV: &str = "BYCOMS_RECORD_CHILD";

/// Child mode: records until killed (or 20 s), printing `flushed N` each time the recorder's
/// own 1 s auto-flush made N messages durable. Without [`CHILD_ENV`] it does nothing.
#[test]
fn crash_child() {
    let Some(path) = std::env::var_os(CHILD_ENV) else { return };
    let mut recorder = Recorder::create(Path::new(&path)).expect("child: create");
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "started").and_then(|()| stdout.flush()).expect("child: stdout");
    let (start, mut reported, mut i) = (Instant::now(), 0, 0u64);
    while start.elapsed() < Duration::from_secs(20) {
        let k = (i % 3) as usize;
        recorder.record_bytes(TOPICS[k], SCHEMAS[k], i, i, &payload(i)).expect("child: record");
        i += 1;
        if recorder.durable_messages() != reported {
            reported = recorder.durable_messages();
            writeln!(stdout, "flushed {reported}").and_then(|()| stdout.flush()).expect("child: stdout");
        }
        if i % 10 == 0 {
            // Wall time must pass: the recorder's auto-flush is once a
            // second of wall time; this pace keeps the file small meanwhile.
            std::thread::sleep(Duration::from_millis(1));
        }
    }
}

/// Kills and reaps the child on every way out of the test.
struct Reaper(Child);

impl Drop for Reaper {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn kill_9_loses_at_most_the_last_second() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("crash.mcap");
    let exe = std::env::current_exe().expect("test binary");
    let child = Command::new(exe)
        .args(["record::crash_child", "--exact", "--nocapture", "--test-threads=1"])
        .env(CHILD_ENV, &path)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn child");
    let mut child = Reaper(child);
    let stdout = child.0.stdout.take().expect("child stdout");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });

    // Wait for the child to start, then let it record ~1.5 s: one auto-flush at ~1 s, and half
    // a second of unflushed messages that the kill may take with it.
    let deadline = Instant::now() + Duration::from_secs(60);
    let wait_for = |want: &dyn Fn(&str) -> bool| loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match rx.recv_timeout(left) {
            Ok(line) if want(&line) => return line,
            Ok(_) => continue,
            Err(error) => panic!("child said nothing useful before the deadline: {error}"),
        }
    };
    // libtest prints "test crash_child ... " without a newline before the child's first line.
    wait_for(&|line| line.ends_with("started"));
    let started = Instant::now();
    let first = wait_for(&|line| line.starts_with("flushed "));
    // Wall time must pass (the recorder flushes on wall time): the kill is
    // to land half a second after the first auto-flush, not at an event.
    std::thread::sleep(Duration::from_millis(1_500).saturating_sub(started.elapsed()));
    child.0.kill().expect("kill -9 the child");
    let status = child.0.wait().expect("reap the child");
    assert!(!status.success(), "the child was killed, not finished: {status}");

    // Every line the child printed happened before the kill, so each count it reported is durable.
    let flushed = std::iter::once(first)
        .chain(rx.try_iter())
        .filter_map(|line| line.strip_prefix("flushed ")?.parse::<u64>().ok())
        .max()
        .expect("a flush count");
    let recovered = recover(&path).expect("the crashed recording reads");
    let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    eprintln!(
        "kill -9 after {:?}: {} messages flushed, {} recovered ({size} bytes), stopped by {:?}",
        started.elapsed(),
        flushed,
        recovered.messages,
        recovered.stopped_by
    );
    assert!(!recovered.is_complete(), "a killed recording has no footer");
    assert!(recovered.messages >= flushed, "recovered {} < flushed {flushed}", recovered.messages);
    assert_eq!(recovered.counts.values().sum::<u64>(), recovered.messages);
    // What the Python streaming reader makes of such a file:
    // `the_python_streaming_reader_recovers_every_cut_like_recover`.
}

/// The Python package the Python checks read with (`.ci/run` installs this version).
const PY_MCAP_VERSION: &str = "1.6.0";

/// Runs `timeout 60 python3 -c script args…` and returns its stdout; fails the test, saying
/// why, if python3 cannot run or lacks `mcap` [`PY_MCAP_VERSION`] (the callers are ignored
/// unless asked for, so asked for they must check, not pass silently).
fn python_mcap(script: &str, args: &[&Path]) -> String {
    let need = format!(
        "python3 with mcap=={PY_MCAP_VERSION} (pip install mcap=={PY_MCAP_VERSION}, as .ci/run does)"
    );
    let version = "import importlib.metadata as m, mcap.reader; print(m.version('mcap'))";
    let probe = Command::new("timeout").args(["60", "python3", "-c", version]).output().unwrap_or_else(|e| {
        panic!("this test needs {need}, but `timeout 60 python3` cannot be started: {e}")
    });
    let why = String::from_utf8_lossy(&probe.stderr);
    // The last line says it ("ModuleNotFoundError: No module named 'mcap'", "timeout: failed to
    // run command 'python3': No such file or directory").
    assert!(
        probe.status.success(),
        "this test needs {need}, but: {}",
        why.trim().lines().last().unwrap_or("")
    );
    let version = String::from_utf8_lossy(&probe.stdout).trim().to_owned();
    assert_eq!(version, PY_MCAP_VERSION, "this test needs {need}; python3 has mcap {version}");
    let output = Command::new("timeout")
        .args(["60", "python3", "-c", script])
        .args(args)
        .output()
        .expect("run python3");
    assert!(
        output.status.success(),
        "python failed ({}): {}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// For each file named on the command line, the messages the Python reader's streaming mode
/// yields before the file ends or breaks off (one count a line).
const PY_RECOVER: &str = r#"
import sys
from mcap.reader import NonSeekingReader
for path in sys.argv[1:]:
    count = 0
    try:
        with open(path, "rb") as f:
            for _ in NonSeekingReader(f).iter_messages(log_time_order=False):
                count += 1
    except Exception:
        pass
    print(count)
"#;

/// [`write_sample`]'s messages (no gate events), flushed every 50: a chunk each, as the
/// recorder's 1 s auto-flush cuts a launch's recording into chunks.
fn write_chunked_sample(dir: &Path, n: u64) -> PathBuf {
    let path = dir.join("chunked.mcap");
    let mut recorder = Recorder::create(&path).expect("create recording");
    for i in 0..n {
        let k = (i % 3) as usize;
        recorder.record_bytes(TOPICS[k], SCHEMAS[k], 1_000 + i * 10, 500 + i, &payload(i)).expect("record");
        if i % 50 == 49 {
            recorder.flush().expect("flush");
        }
    }
    let summary = recorder.finish().expect("finish");
    assert_eq!((summary.messages, u64::from(summary.chunks)), (n, n.div_ceil(50)), "one chunk per flush");
    path
}

/// What a crash leaves (a recording cut anywhere, as `kill -9` cuts it) is read by Python's
/// streaming reader exactly as far as by [`recover`]: a chunked recording cut at every 997th
/// length, as in `every_cut_of_a_recording_rewrites_into_a_complete_one_with_the_same_messages`.
#[test]
#[ignore = "needs python3 with mcap==1.6.0"]
fn the_python_streaming_reader_recovers_every_cut_like_recover() {
    let dir = tempfile::tempdir().expect("temp dir");
    let n = 500;
    let bytes = std::fs::read(write_chunked_sample(dir.path(), n)).expect("read");
    let lens: Vec<usize> = (8..bytes.len()).step_by(997).chain([bytes.len() - 1, bytes.len()]).collect();
    let cuts: Vec<PathBuf> = lens
        .iter()
        .map(|len| {
            let cut = dir.path().join(format!("cut-{len}.mcap"));
            std::fs::write(&cut, &bytes[..*len]).expect("write cut");
            cut
        })
        .collect();
    let out = python_mcap(PY_RECOVER, &cuts.iter().map(PathBuf::as_path).collect::<Vec<_>>());
    let python: Vec<u64> = out.lines().map(|l| l.trim().parse().expect("python printed a count")).collect();
    assert_eq!(python.len(), cuts.len(), "one count per cut: {out}");
    for ((len, cut), python) in lens.iter().zip(&cuts).zip(&python) {
        let recovered = recover(cut).expect("the cut streams");
        assert_eq!(*python, recovered.messages, "cut at {len} of {}: Python and recover()", bytes.len());
    }
    assert_eq!(python.last(), Some(&n), "the whole file: every message");
    let partial: BTreeSet<u64> = python.iter().copied().filter(|&c| c > 0 && c < n).collect();
    assert!(partial.len() > 1, "cuts fall between the first and the last chunk: {python:?}");
}

const PY_COUNT: &str = r#"
import json, sys
from mcap.reader import make_reader
counts = {}
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f)
    for schema, channel, message in reader.iter_messages():
        counts[channel.topic] = counts.get(channel.topic, 0) + 1
    stats = reader.get_summary().statistics
print(json.dumps({"counts": counts, "messages": stats.message_count}))
"#;

#[test]
#[ignore = "needs python3 with mcap==1.6.0"]
fn the_python_mcap_reader_agrees() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (n, events) = (1_000, 5);
    let path = write_sample(dir.path(), n, events);
    let out = python_mcap(PY_COUNT, &[&path]);
    let report: serde_json::Value = serde_json::from_str(out.trim()).expect("python printed JSON");
    let counts: BTreeMap<String, u64> =
        serde_json::from_value(report["counts"].clone()).expect("counts object");
    assert_eq!(counts, expected_counts(n, events));
    assert_eq!(report["messages"], n + u64::from(events));
}

#[test]
fn every_cut_of_a_recording_rewrites_into_a_complete_one_with_the_same_messages() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = write_launch_sample(dir.path(), 500, 3);
    let bytes = std::fs::read(&path).expect("read");
    let (cut, fixed) = (dir.path().join("cut.mcap"), dir.path().join("fixed.mcap"));
    for len in (8..bytes.len()).step_by(997).chain([bytes.len() - 1, bytes.len()]) {
        std::fs::write(&cut, &bytes[..len]).expect("write cut");
        let streamed = recover(&cut).expect("the cut streams");
        let _ = std::fs::remove_file(&fixed);
        if streamed.messages == 0 {
            // Cut before the run metadata: nothing to recover, and nothing is written.
            let refused = bycoms_record::rewrite(&cut, &fixed);
            assert!(matches!(refused, Err(RecordError::NotLaunch { .. })), "cut at {len}: {refused:?}");
            assert!(!fixed.exists(), "cut at {len}: a copy was written");
            continue;
        }
        let rewritten = bycoms_record::rewrite(&cut, &fixed).expect("rewrite");
        assert_eq!(
            (rewritten.messages, &rewritten.counts),
            (streamed.messages, &streamed.counts),
            "cut at {len}"
        );
        assert_eq!(rewritten.is_complete(), len == bytes.len(), "cut at {len}: {:?}", rewritten.stopped_by);
        let whole = recover(&fixed).expect("the copy reads");
        assert!(whole.is_complete(), "cut at {len}: {:?}", whole.stopped_by);
        assert_eq!(whole.counts, streamed.counts, "cut at {len}");
        let copy = std::fs::read(&fixed).expect("read copy");
        let summary = mcap::Summary::read(&copy).expect("summary").expect("the copy has a summary");
        assert_eq!(summary.stats.map(|s| s.message_count), Some(streamed.messages));
    }
    let junk = dir.path().join("junk");
    std::fs::write(&junk, b"not a recording at all").expect("junk");
    assert!(matches!(bycoms_record::rewrite(&junk, &fixed), Err(RecordError::NotMcap { .. })));
}

/// A copy of `from` written by the mcap crate's writer with `compression`
/// (what the `mcap` CLI and the Python writer produce by default).
fn compressed_copy(from: &Path, to: &Path, compression: mcap::Compression) {
    let bytes = std::fs::read(from).expect("read recording");
    let out = std::fs::File::create(to).expect("create copy");
    let options = mcap::WriteOptions::new().compression(Some(compression)).chunk_size(Some(4096));
    let mut writer = options.create(std::io::BufWriter::new(out)).expect("writer");
    for message in mcap::MessageStream::new(&bytes).expect("mcap") {
        writer.write(&message.expect("message")).expect("write");
    }
    writer.finish().expect("finish");
}

#[test]
fn zstd_and_lz4_recordings_read_like_uncompressed_ones() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (n, events) = (2_000, 5);
    let plain = write_launch_sample(dir.path(), n, events);
    let expected = expected_launch_counts(n, events);
    for (name, compression) in [("zstd", mcap::Compression::Zstd), ("lz4", mcap::Compression::Lz4)] {
        let packed = dir.path().join(format!("{name}.mcap"));
        compressed_copy(&plain, &packed, compression);
        let header =
            mcap::Summary::read(&std::fs::read(&packed).expect("read")).expect("summary").expect("summary");
        assert!(header.chunk_indexes.iter().all(|c| c.compression == name), "{name}: the copy is compressed");
        let read = recover(&packed).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(read.is_complete(), "{name}: {:?}", read.stopped_by);
        assert_eq!(read.counts, expected, "{name}");
        let run = bycoms_study::draw::run::read_run(&packed).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(run.stopped_by.is_none(), "{name}: {:?}", run.stopped_by);
        let fixed = dir.path().join(format!("{name}.recovered.mcap"));
        let copied = bycoms_record::rewrite(&packed, &fixed).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(copied.counts, expected, "{name}: record recover copies every message");
    }
}
