//! What a recording costs: the MCAP recorder alone, and whole launches with
//! and without `--record`.
//!
//! * **Recorder**: write throughput and file size per message for payloads
//!   of 16, 64 and 256 bytes (one million messages each, round robin on
//!   three topics, as a launch records them).
//! * **Launches** (in one process: the in-memory bus, agents as threads, so
//!   no process start or shared memory blurs the figure): the same lockstep
//!   launch run alternately without and with a recording, `ROUNDS` times
//!   each; the median wall times give the slowdown (and the median CPU
//!   times, less at the mercy of a busy machine, the work it added), the file its bytes per
//!   robot-second (a robot-second is one live robot for one simulated
//!   second: every live robot publishes one pose per 0.1 s period, moving or
//!   not, so robot-seconds = recorded poses × 0.1 s) and the messages
//!   written per wall second. Two launches: the default 3-robot scenario,
//!   and a crowd — a terrain whose goal is walled in, so no robot arrives
//!   and every robot deployed stays live as a beacon to the end (`ROBOTS`
//!   robots, noise on so that they stop in different places).
//!
//! * **Codecs**: the crowd's recording re-written with each compression MCAP
//!   allows (none, lz4, zstd; chunks of `CHUNK_SIZE`, compression on the
//!   writing thread as the recorder does): file size and write time.
//!
//! A measurement, not a check, so a bench and not a test. Run:
//! `cargo bench -p bycoms-orchestrator --bench record_throughput`
//! (`BYCOMS_BENCH_ROBOTS=N` sets the crowd's robots, default 20; `--quick`
//! skips the recorder part).

use bycoms_launch::config::Transport;
use bycoms_launch::{self as launch, Clock, LaunchConfig};
use bycoms_orchestrator::commands::launch::world;
use bycoms_record::{read_counts, Recorder, CHUNK_SIZE};
use bycoms_runtime::stats::median;
use std::path::Path;
use std::time::Instant;

const TOPICS: [&str; 3] = ["bycoms/s1/agent/0/to_agent", "bycoms/s1/agent/0/pose", "bycoms/s1/tick"];
const SCHEMAS: [&str; 3] = ["bycoms.ToAgent", "bycoms.Pose", "bycoms.Tick"];

/// Launches timed per setting (the median is reported).
const ROUNDS: usize = 5;

/// A 40 × 40 arena whose goal sits in a closed box: no robot ever arrives.
fn walled_in_goal() -> String {
    let (w, h) = (40usize, 40usize);
    let mut grid = vec![vec!['.'; w]; h];
    for (y, row) in grid.iter_mut().enumerate() {
        for (x, cell) in row.iter_mut().enumerate() {
            let on_box = (26..=34).contains(&x) && (26..=34).contains(&y);
            if on_box && (x == 26 || x == 34 || y == 26 || y == 34) {
                *cell = '#';
            }
        }
    }
    grid[30][30] = 'G';
    grid[10][10] = 'S';
    // The text format's first row is the highest y.
    grid.iter().rev().map(|row| row.iter().collect::<String>() + "\n").collect()
}

fn main() {
    let dir = tempfile::tempdir().expect("temp dir");
    if !std::env::args().any(|a| a == "--quick") {
        recorder(&dir.path().join("throughput.mcap"));
    }
    let robots: u32 = std::env::var("BYCOMS_BENCH_ROBOTS").ok().and_then(|s| s.parse().ok()).unwrap_or(20);
    let terrain = dir.path().join("walled-in.txt");
    std::fs::write(&terrain, walled_in_goal()).expect("terrain");
    let default = LaunchConfig::default();
    let crowd =
        LaunchConfig { robots, terrain: Some(terrain), eps: 1.0, noise: true, ..LaunchConfig::default() };
    for (name, cfg) in [
        ("default lockstep launch, 3 robots".to_string(), default),
        (format!("walled-in goal, {robots} robots"), crowd),
    ] {
        launches(&name, cfg, dir.path());
    }
    // The crowd's recording, the last one written.
    codecs(&dir.path().join("launch.mcap"), &dir.path().join("codec.mcap"));
}

/// The messages of `input` re-written to `output` with each compression.
fn codecs(input: &Path, output: &Path) {
    let bytes = std::fs::read(input).expect("the recording");
    let messages: Vec<mcap::Message> =
        mcap::MessageStream::new(&bytes).expect("mcap").map(|m| m.expect("message")).collect();
    for (name, compression) in
        [("none", None), ("lz4", Some(mcap::Compression::Lz4)), ("zstd", Some(mcap::Compression::Zstd))]
    {
        let start = Instant::now();
        let options = mcap::WriteOptions::new()
            .compression(compression)
            .chunk_size(Some(CHUNK_SIZE))
            .compression_threads(0);
        let file = std::io::BufWriter::new(std::fs::File::create(output).expect("create"));
        let mut writer = mcap::Writer::with_options(file, options).expect("writer");
        for m in &messages {
            writer.write(m).expect("write");
        }
        writer.finish().expect("finish");
        drop(writer);
        let secs = start.elapsed().as_secs_f64();
        let size = std::fs::metadata(output).expect("written").len();
        println!(
            "codec {name:>4}: {size} bytes, {:.2} M messages/s written ({} messages)",
            messages.len() as f64 / secs / 1e6,
            messages.len()
        );
    }
}

/// The recorder alone.
fn recorder(path: &Path) {
    for size in [16usize, 64, 256] {
        let n = 1_000_000u64;
        let body = vec![0xA5u8; size];
        let start = Instant::now();
        let mut recorder = Recorder::create(path).expect("create");
        for i in 0..n {
            let k = (i % 3) as usize;
            recorder.record_bytes(TOPICS[k], SCHEMAS[k], i, i, &body).expect("record");
        }
        let summary = recorder.finish().expect("finish");
        let secs = start.elapsed().as_secs_f64();
        println!(
            "recorder, {size:>4} B payload: {:.2} M messages/s, {:.1} bytes/message in the file ({} chunks)",
            n as f64 / secs / 1e6,
            summary.bytes as f64 / n as f64,
            summary.chunks
        );
        // A figure of a recording that does not read back would be no figure.
        assert_eq!(
            read_counts(path).expect("read back").values().sum::<u64>(),
            n,
            "every message reads back"
        );
    }
}

/// One launch of `cfg` over the in-memory bus; its wall time, and the
/// recording's summary when `record` is set.
fn launch_once(
    cfg: &LaunchConfig,
    record: Option<&Path>,
    round: usize,
) -> (f64, f64, Option<(u64, u64, u64)>) {
    let mut cfg = cfg.clone();
    cfg.clock = Clock::Lockstep;
    cfg.transport.kind = Transport::Memory;
    cfg.swarm = Some(format!("bench-{}-{round}-{}", std::process::id(), record.is_some()));
    cfg.record = record.map(Path::to_path_buf);
    let w = world(&cfg).expect("world");
    // Agents are threads: no executable is started.
    let agent = launch::agent_command(Some(Path::new("/nonexistent")), None).expect("command");
    let (start, cpu) = (Instant::now(), cpu_seconds());
    let summary = launch::run(cfg, w, agent).expect("the launch runs");
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds() - cpu;
    assert_eq!(summary.error, None, "the launch ran to its end");
    let recorded = summary.recording.as_ref().map(|r| {
        let poses: u64 = r.counts.iter().filter(|(t, _)| t.ends_with("/pose")).map(|(_, n)| n).sum();
        let bytes = std::fs::metadata(&r.path).expect("the recording").len();
        (bytes, r.messages, poses)
    });
    (wall, cpu, recorded)
}

/// CPU time of this process so far (user + system, every thread), seconds:
/// on a busy shared machine wall time depends on the neighbours, CPU time
/// much less.
fn cpu_seconds() -> f64 {
    // 100 ticks a second.
    bycoms_bench::procfs::cpu_ticks("self").map_or(f64::NAN, |t| t as f64 / 100.0)
}

fn launches(name: &str, cfg: LaunchConfig, dir: &Path) {
    let path = dir.join("launch.mcap");
    let (mut bare, mut recorded, mut file) = (Vec::new(), Vec::new(), None);
    // Alternated, so that a busy moment of the machine hits both alike.
    for round in 0..ROUNDS {
        let (wall, cpu, _) = launch_once(&cfg, None, round);
        bare.push((wall, cpu));
        let _ = std::fs::remove_file(&path);
        let (wall, cpu, f) = launch_once(&cfg, Some(&path), round);
        recorded.push((wall, cpu));
        file = f;
    }
    // The runtime's one median, of ROUNDS launches each.
    let of = |v: &[(f64, f64)], f: fn(&(f64, f64)) -> f64| {
        median(&v.iter().map(f).collect::<Vec<_>>()).expect("ROUNDS launches timed")
    };
    let wall = |v: &[(f64, f64)]| of(v, |x| x.0);
    let cpu = |v: &[(f64, f64)]| of(v, |x| x.1);
    let (bare_wall, rec_wall, bare_cpu, rec_cpu) = (wall(&bare), wall(&recorded), cpu(&bare), cpu(&recorded));
    let (bytes, messages, poses) = file.expect("a recording");
    let robot_seconds = poses as f64 * 0.1;
    println!(
        "{name}: {bytes} bytes, {messages} messages, {robot_seconds:.0} robot-s: {:.0} bytes/robot-s, \
         {:.0} messages/s written; wall {bare_wall:.2} s without recording, {rec_wall:.2} s with ({:+.1} %); \
         CPU {bare_cpu:.2} s without, {rec_cpu:.2} s with ({:+.1} %)",
        bytes as f64 / robot_seconds,
        messages as f64 / rec_wall,
        (rec_wall / bare_wall - 1.0) * 100.0,
        (rec_cpu / bare_cpu - 1.0) * 100.0
    );
}
