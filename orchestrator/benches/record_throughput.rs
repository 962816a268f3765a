//! The MCAP recorder's write throughput and file size per message, for
//! payloads of 16, 64 and 256 bytes (one million messages each, round robin
//! on three topics, as a launch records them).
//!
//! A measurement, not a check, so a bench and not a test. Run:
//! `cargo bench -p bycoms-orchestrator --bench record_throughput`.

use bycoms_orchestrator::record::{read_counts, Recorder};
use std::time::Instant;

const TOPICS: [&str; 3] = ["bycoms/s1/agent/0/to_agent", "bycoms/s1/agent/0/pose", "bycoms/s1/tick"];
const SCHEMAS: [&str; 3] = ["bycoms.ToAgent", "bycoms.Pose", "bycoms.Tick"];

fn main() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("throughput.mcap");
    for size in [16usize, 64, 256] {
        let n = 1_000_000u64;
        let body = vec![0xA5u8; size];
        let start = Instant::now();
        let mut recorder = Recorder::create(&path).expect("create");
        for i in 0..n {
            let k = (i % 3) as usize;
            recorder.record_bytes(TOPICS[k], SCHEMAS[k], i, i, &body).expect("record");
        }
        let summary = recorder.finish().expect("finish");
        let secs = start.elapsed().as_secs_f64();
        println!(
            "{size:>4} B payload: {:.2} M messages/s, {:.1} bytes/message in the file ({} chunks)",
            n as f64 / secs / 1e6,
            summary.bytes as f64 / n as f64,
            summary.chunks
        );
        // A figure of a recording that does not read back would be no figure.
        assert_eq!(
            read_counts(&path).expect("read back").values().sum::<u64>(),
            n,
            "every message reads back"
        );
    }
}
