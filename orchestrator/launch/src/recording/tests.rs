//! The recording's side of a launch: one scene for file and observers, the writer thread's order, errors and flushes.

use super::*;
use bycoms_protocol::msg::{GateEvent, GateKind, Pose};
use bycoms_protocol::{encode, RobotId, MAX_MESSAGE_LEN};

fn world() -> World {
    World::tiny()
}

fn feed(rec: &mut Recording) {
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    let pose = Pose { robot: RobotId(1), x: 0.5, y: 0.5, heading: 0.0, step: 0, time_us: 0 };
    rec.bytes("bycoms/t/robot/1/pose", schema::POSE, encode(&pose, &mut buf).unwrap());
    rec.seen(Seen::Pose(pose));
    let moved = Pose { x: 1.5, step: 1, time_us: 100_000, ..pose };
    rec.bytes("bycoms/t/robot/1/pose", schema::POSE, encode(&moved, &mut buf).unwrap());
    rec.seen(Seen::Pose(moved));
    let event = GateEvent { robot: RobotId(1), kind: GateKind::Deployed, x: 0.5, y: 0.5, step: 0 };
    rec.bytes("bycoms/t/gate", schema::GATE, encode(&event, &mut buf).unwrap());
    rec.seen(Seen::Gate(event));
}

/// Recorded bytes feed no scene, even those that would decode: the scene
/// is folded from the core's inputs and outputs ([`Recording::seen`]),
/// nothing is decoded twice.
#[test]
fn bytes_feed_no_scene_the_cores_inputs_and_outputs_do() {
    let cfg = LaunchConfig { serve: Some("127.0.0.1:0".into()), ..Default::default() };
    let scene = Recording::scene_for("t", &world(), &cfg);
    let mut rec = Recording::start("t", &world(), &cfg, scene).expect("starts");
    rec.sync();
    let _world = rec.take_scene();
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    let pose = Pose { robot: RobotId(1), x: 0.5, y: 0.5, heading: 0.0, step: 0, time_us: 0 };
    rec.bytes("bycoms/t/robot/1/pose", schema::POSE, encode(&pose, &mut buf).unwrap());
    rec.sync();
    assert_eq!(rec.take_scene(), Vec::new());
    rec.seen(Seen::Pose(pose));
    rec.sync();
    assert!(!rec.take_scene().is_empty(), "the pose handed to the core shows robot 1");
    rec.finish().expect("finishes");
}

/// Pose messages written to the file are numbered on their topic, in file
/// order: the number the core's log names a recorded pose by.
#[test]
fn pose_messages_in_a_file_are_numbered_on_their_topic() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cfg = LaunchConfig { record: Some(dir.path().join("r.mcap")), ..Default::default() };
    let mut rec = Recording::start("t", &world(), &cfg, None).expect("starts");
    let sent = [("1", schema::POSE), ("2", schema::POSE), ("1", schema::POSE), ("3", schema::GATE)];
    let numbers: Vec<_> = sent
        .iter()
        .map(|(robot, schema)| rec.message(&format!("bycoms/t/robot/{robot}/x"), schema, b"x"))
        .collect();
    assert_eq!(numbers, [Some(0), Some(0), Some(1), None]);
    rec.finish().expect("finishes");
    let shown = LaunchConfig { serve: Some("127.0.0.1:0".into()), ..Default::default() };
    let mut unfiled = Recording::start("t", &world(), &shown, None).expect("starts");
    assert_eq!(unfiled.message("bycoms/t/robot/1/x", schema::POSE, b"x"), None, "no file, no number");
    unfiled.finish().expect("finishes");
}

/// The scene's output as (topic, bytes), for comparing.
fn encoded(outs: &[Out]) -> Vec<(String, Vec<u8>)> {
    outs.iter().map(|o| (o.topic.clone(), o.message.encode().expect("encodes"))).collect()
}

#[test]
fn one_scene_feeds_the_file_and_the_observers_with_the_same_messages() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("r.mcap");
    let cfg =
        LaunchConfig { record: Some(path.clone()), serve: Some("127.0.0.1:0".into()), ..Default::default() };
    let scene = Recording::scene_for("t", &world(), &cfg).expect("recorded and served: a scene");
    let mut rec = Recording::start("t", &world(), &cfg, Some(scene.clone())).expect("starts");
    feed(&mut rec);
    rec.sync();
    let shown = encoded(&rec.take_scene());
    assert!(rec.take_scene().is_empty(), "handed out once");
    assert!(shown.iter().any(|(t, _)| t == "bycoms/t/scene"), "the world and the robot: {shown:?}");
    assert!(shown.iter().any(|(t, _)| t == "bycoms/t/gate/json"));
    rec.finish().expect("finishes");
    // The file's decoded channels hold exactly what the observers got.
    let bytes = std::fs::read(&path).expect("read");
    let decoded = ["/scene", "/tf", "/log", "/gate/json", "/pose/json", "/mode", "/telemetry"];
    let in_file: Vec<(String, Vec<u8>)> = mcap::MessageStream::new(&bytes)
        .expect("mcap")
        .map(|m| m.expect("message"))
        .filter(|m| decoded.iter().any(|d| m.channel.topic.ends_with(d)))
        .map(|m| (m.channel.topic.clone(), m.data.into_owned()))
        .collect();
    assert_eq!(in_file, shown);
    // The scene the live view snapshots is the same one: it knows robot 1.
    let snapshot = scene.lock().snapshot(0);
    assert!(encoded(&snapshot).iter().any(|(t, _)| t == "bycoms/t/scene"));
}

#[test]
fn a_served_run_without_a_file_still_feeds_its_scene_and_an_unshown_run_has_none() {
    let cfg = LaunchConfig { serve: Some("127.0.0.1:0".into()), ..Default::default() };
    let scene = Recording::scene_for("t", &world(), &cfg);
    let mut rec = Recording::start("t", &world(), &cfg, scene).expect("starts");
    feed(&mut rec);
    rec.sync();
    assert!(encoded(&rec.take_scene()).iter().any(|(t, _)| t == "bycoms/t/robot/1/pose/json"));
    assert!(Recording::scene_for("t", &world(), &LaunchConfig::default()).is_none());
}

/// Every raw message on `topic` in the file at `path`, with its log time.
fn raw_of(path: &std::path::Path, topic: &str) -> Vec<(u64, Vec<u8>)> {
    let bytes = std::fs::read(path).expect("read");
    mcap::MessageStream::new(&bytes)
        .expect("mcap")
        .map(|m| m.expect("message"))
        .filter(|m| m.channel.topic == topic)
        .map(|m| (m.log_time, m.data.into_owned()))
        .collect()
}

/// Many batches (more messages than one batch holds, a hand-over on every
/// "pass"), each message at the simulated time stamped when it was
/// recorded: the file holds them all, in order, at those times.
#[test]
fn the_writer_keeps_the_loops_order_and_times_across_batches() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("r.mcap");
    let cfg = LaunchConfig { record: Some(path.clone()), ..Default::default() };
    let mut rec = Recording::start("t", &world(), &cfg, None).expect("starts");
    let n = 3 * BATCH_ITEMS as u64 + 17;
    for i in 0..n {
        rec.set_simulated_time(i * 1000);
        rec.bytes("bycoms/t/robot/1/to_agent", schema::TO_AGENT, &i.to_le_bytes());
        if i % 100 == 0 {
            rec.tick();
        }
    }
    let summary = rec.finish().expect("finishes").expect("a file");
    assert_eq!(summary.counts.get("bycoms/t/robot/1/to_agent"), Some(&n));
    let got = raw_of(&path, "bycoms/t/robot/1/to_agent");
    let want: Vec<(u64, Vec<u8>)> = (0..n).map(|i| (i * 1000, i.to_le_bytes().to_vec())).collect();
    assert!(
        got == want,
        "{} messages, first difference at {:?}",
        got.len(),
        got.iter().zip(&want).position(|(a, b)| a != b)
    );
}

/// A write error (here: one topic used with two schemas) stops the
/// recording, and the launch hears of it when it finishes the file.
#[test]
fn a_write_error_stops_the_recording_and_is_reported_at_the_end() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("r.mcap");
    let mut rec = Recording::create(&path).expect("creates");
    rec.bytes("bycoms/t/x", schema::POSE, b"a");
    rec.bytes("bycoms/t/x", schema::GATE, b"b");
    rec.sync();
    rec.bytes("bycoms/t/y", schema::POSE, b"c");
    let error = rec.finish().expect_err("the mismatch is reported");
    assert!(error.contains("bycoms/t/x"), "{error}");
    let counts = bycoms_record::read_counts(&path).expect("what was written reads back");
    assert_eq!(counts.get("bycoms/t/x"), Some(&1), "{counts:?}");
    assert_eq!(counts.get("bycoms/t/y"), None, "nothing after the error: {counts:?}");
}

/// A message followed by silence reaches the file within about a second,
/// with no further call from the loop: the writer flushes on its own (the
/// crash guarantee). The wait is bounded; the file is read, not slept on.
#[test]
fn a_quiet_tail_reaches_the_file_on_its_own() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("r.mcap");
    let mut rec = Recording::create(&path).expect("creates");
    rec.bytes("bycoms/t/x", schema::POSE, b"a");
    let deadline = Instant::now() + Duration::from_secs(20);
    let on_disk = loop {
        // As the launch loop does on every pass (it hands over every 50 ms).
        rec.tick();
        let counts = bycoms_record::read_counts(&path).expect("a valid prefix at any time");
        if counts.get("bycoms/t/x") == Some(&1) || Instant::now() > deadline {
            break counts;
        }
        std::thread::yield_now();
    };
    assert_eq!(on_disk.get("bycoms/t/x"), Some(&1), "{on_disk:?}");
    drop(rec);
}

/// A recording dropped without `finish` (a launch that failed on the way)
/// is still a finished file with everything recorded.
#[test]
fn a_dropped_recording_is_a_finished_file() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("r.mcap");
    let mut rec = Recording::create(&path).expect("creates");
    for i in 0u32..10 {
        rec.bytes("bycoms/t/x", schema::POSE, &i.to_le_bytes());
    }
    drop(rec);
    let bytes = std::fs::read(&path).expect("read");
    let summary = mcap::Summary::read(&bytes).expect("reads").expect("a summary: the file was finished");
    assert_eq!(summary.stats.map(|s| s.message_count), Some(10));
}
