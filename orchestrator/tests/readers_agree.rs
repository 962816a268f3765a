//! `draw`, `replay` and `record recover` read one recording alike: they share one streaming
//! reader (`record::Reader`) and one decoder (`record::decode`), so on a launch-like
//! recording, finished or cut anywhere, they find the same poses and gate events and stop at
//! the same record for the same reason.

use bycoms_launch::LaunchConfig;
use bycoms_orchestrator::replay::{read_recording, Entry};
use bycoms_protocol::msg::{GateEvent, GateKind, Pose, Tick, ToAgent};
use bycoms_protocol::{encode, RobotId, Swarm, MAX_MESSAGE_LEN};
use bycoms_record::schema::{self, Topics};
use bycoms_record::{recover, rewrite, Recorder};
use bycoms_sim::Vec2;
use bycoms_study::draw::run::read_run;

/// A recording shaped like a launch's: run metadata, commands, poses (and one that does not
/// decode), gate events, in several chunks. Returns its bytes and how many poses and gate
/// events it holds.
fn launch_like(dir: &std::path::Path) -> (Vec<u8>, usize, usize) {
    let path = dir.join("launch.mcap");
    let swarm = Swarm::new("t").expect("swarm");
    let mut recorder = Recorder::create(&path).expect("create");
    let run = serde_json::json!({
        "swarm": "t",
        "terrain": "hand-made",
        "terrain_text": "",
        "start": Vec2::new(0.0, 0.0),
        "goal": Vec2::new(5.0, 0.0),
        "config": LaunchConfig::default(),
    });
    recorder.record_json(&Topics::new("t").run(), schema::RUN, 0, &run).expect("run");
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    let (mut poses, mut gates) = (0, 0);
    for step in 1..=60u64 {
        for k in 1..=2u32 {
            let robot = RobotId(k);
            let tick = encode(&ToAgent::Tick(Tick { step }), &mut buf).expect("tick").to_vec();
            let topic = swarm.to_agent(robot);
            recorder.record_bytes(topic.name().as_str(), schema::TO_AGENT, step, step, &tick).expect("tick");
            let pose =
                Pose { robot, x: step as f64 * 0.1, y: f64::from(k), heading: 0.0, step, time_us: step };
            let bytes = encode(&pose, &mut buf).expect("pose").to_vec();
            let topic = swarm.pose(robot);
            recorder.record_bytes(topic.name().as_str(), schema::POSE, step, step, &bytes).expect("pose");
            poses += 1;
        }
        if step % 20 == 0 {
            let event = GateEvent { robot: RobotId(1), kind: GateKind::Deployed, x: 0.0, y: 1.0, step };
            let bytes = encode(&event, &mut buf).expect("gate").to_vec();
            recorder
                .record_bytes(swarm.gate().name().as_str(), schema::GATE, step, step, &bytes)
                .expect("gate");
            gates += 1;
            recorder.flush().expect("flush: a chunk");
        }
    }
    // Garbage on a pose topic is recorded as it came; nobody reads a pose from it.
    let topic = swarm.pose(RobotId(2));
    recorder.record_bytes(topic.name().as_str(), schema::POSE, 61, 61, &[0xff; 3]).expect("garbage");
    let summary = recorder.finish().expect("finish");
    assert!(summary.chunks >= 3, "{summary:?}");
    (std::fs::read(&path).expect("read"), poses, gates)
}

#[test]
fn draw_replay_and_recover_read_the_same_messages_of_a_file_cut_anywhere() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (bytes, poses, gates) = launch_like(dir.path());
    let (cut, fixed) = (dir.path().join("cut.mcap"), dir.path().join("fixed.mcap"));
    let on_bus = |recovered: &bycoms_record::Recovered| -> u64 {
        let on = |topic: &str| topic.ends_with("/pose") || topic.ends_with("/gate");
        recovered.counts.iter().filter(|(t, _)| on(t)).map(|(_, n)| n).sum()
    };
    let mut replayed_cuts = 0;
    for at in (mcap::MAGIC.len()..=bytes.len()).step_by(97).chain([bytes.len()]) {
        std::fs::write(&cut, &bytes[..at]).expect("write the cut file");
        let recovered = recover(&cut).expect("recover reads a cut file");
        let (drawn, rewritten) = match (read_run(&cut), rewrite(&cut, &fixed), read_recording(&cut)) {
            (Ok(drawn), Ok(rewritten), Ok(replayed)) => {
                replayed_cuts += 1;
                assert_eq!(replayed.stopped_by, recovered.stopped_by, "cut at {at}");
                let read =
                    replayed.entries.iter().filter(|e| matches!(e, Entry::Pose(_) | Entry::Gate(_))).count();
                assert_eq!(read as u64 + drawn.undecodable, on_bus(&recovered), "cut at {at}");
                assert!(drawn.meta.is_some(), "cut at {at}: replay found the run metadata, draw did too");
                (drawn, rewritten)
            }
            // Cut before the run metadata's chunk: not a launch recording to any of the three,
            // in the same words.
            (Err(drawn), Err(rewritten), Err(replayed)) => {
                for e in [drawn.to_string(), rewritten.to_string(), replayed.to_string()] {
                    assert!(e.contains("not a bycoms launch recording"), "cut at {at}: {e}");
                    assert_eq!(e, drawn.to_string(), "cut at {at}: one message");
                }
                assert!(!recovered.counts.keys().any(|t| t.ends_with("/run")), "cut at {at}");
                continue;
            }
            (drawn, rewritten, replayed) => {
                panic!("cut at {at}: the readers disagree: {drawn:?} | {rewritten:?} | {replayed:?}")
            }
        };
        assert_eq!(drawn.stopped_by, recovered.stopped_by, "cut at {at}");
        assert_eq!(rewritten, recovered, "cut at {at}");
        let bus = on_bus(&recovered);
        // The garbage pose (in the last chunk) is counted by recover and by draw as
        // undecodable; neither draw nor replay reads a pose from it.
        assert_eq!(drawn.undecodable, u64::from(bus == (poses + gates + 1) as u64), "cut at {at}");
        if recovered.is_complete() {
            assert_eq!(bus, (poses + gates + 1) as u64);
        }
    }
    assert!(replayed_cuts > 3, "most cuts hold the run: {replayed_cuts}");
}

/// A chunk whose CRC fails: `draw` and `replay` refuse the file naming it and the chunk's
/// byte; `record recover` copies the other chunks, says what it left out and exits 1.
#[test]
fn a_damaged_chunk_is_refused_by_draw_and_replay_and_left_out_by_record_recover() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (mut bytes, poses, gates) = launch_like(dir.path());
    let summary = mcap::Summary::read(&bytes).expect("summary").expect("finished");
    let chunk = summary.chunk_indexes[1].chunk_start_offset;
    bytes[chunk as usize + 9 + 24] ^= 0x01; // the chunk's stored CRC of its records
    let (path, fixed) = (dir.path().join("damaged.mcap"), dir.path().join("damaged.recovered.mcap"));
    std::fs::write(&path, &bytes).expect("write");
    let said = format!("damaged.mcap is damaged: the chunk at byte {chunk} is damaged: Chunk CRC failed");
    let drawn = read_run(&path).expect_err("draw refuses");
    assert!(drawn.to_string().contains(&said), "{drawn}");
    let replayed = read_recording(&path).expect_err("replay refuses");
    assert!(replayed.to_string().contains(&said), "{replayed}");

    let args = bycoms_orchestrator::commands::record::Args {
        command: bycoms_orchestrator::commands::record::RecordCommand::Recover(
            bycoms_orchestrator::commands::record::RecoverArgs {
                file: path.clone(),
                out: None,
                force: false,
            },
        ),
    };
    let code = bycoms_orchestrator::commands::record::run(args).expect("recover runs");
    assert_eq!(code, bycoms_runtime::exit::ERROR, "a chunk was left out");
    let copy = recover(&fixed).expect("the copy reads");
    assert!(copy.is_complete() && copy.damage.is_empty(), "the copy verifies: {copy:?}");
    let all = (poses + gates) as u64 + 1 + 1 + 120; // + garbage pose, run, ticks
    assert!(copy.messages > 0 && copy.messages < all, "{} of {all}", copy.messages);
    assert!(read_run(&fixed).is_ok(), "the copy draws");
}
