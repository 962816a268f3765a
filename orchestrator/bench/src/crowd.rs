//! `orchestrator bench crowd`: what a whole lockstep launch uses as the
//! swarm grows — memory of all its processes, open files, wall time per tick.
//!
//! Why a real launch: `bench scale` measures agents with no gate, no
//! beacons and no orchestrator ports, and did not show what made large
//! launches fail (memory that grew with the swarm and the run's length, an
//! orchestrator out of open files). So this bench runs `orchestrator
//! launch` itself, unchanged, on the all-stuck terrain ([`ALL_STUCK`]: the
//! start is walled in, so every robot sticks at once and every agent stays
//! alive to the end — the most processes, ports and beacons a launch of n
//! robots can have) and measures it from outside, as `top` would:
//!
//! * the launch is a child process (of the current executable), in its own
//!   process group: its memory, files and exit are its own, and one that is
//!   refused, fails or hangs does not take the bench with it;
//! * every [`SAMPLE_EVERY`] the launch's process tree is read from `/proc`
//!   ([`super::procfs`], the reader `bench scale` uses): PSS summed over
//!   the orchestrator and every agent (PSS divides shared pages among the
//!   processes sharing them, so the sum is what they use together), open
//!   files of the orchestrator and of the busiest agent, agents alive; the
//!   peaks are kept. Reading `smaps_rollup` of hundreds of processes takes
//!   CPU from the launch, so the time a sample took is reported too, and
//!   samples are spaced so that they take at most a fifth of the time;
//! * ticks and wall time come from the launch's own `--json` summary;
//! * each launch runs under its own iceoryx2 isolation tag
//!   (`BYCOMS_IPC_ISOLATION`, inherited by its agents): every file it makes
//!   in `/dev/shm` carries the tag and its iceoryx2 root is its own, so the
//!   files it leaves behind are counted exactly even while other runs use
//!   the machine's bus, and the processes left of it (whose parent ended,
//!   so no longer in its tree) are found by the tag in their environment.
//!   Both are reported, then removed (killed). The root's `global_mgmt`
//!   segment, which a fresh root gets and the machine's root has once for
//!   all launches, is reported apart.

use super::procfs;
use anyhow::{Context, Result};
use bycoms_protocol::bus::ipc::root::{root_dir, ISOLATION_ENV};
use nix::sys::signal::{kill, killpg, Signal};
use nix::unistd::Pid;
use serde::Serialize;
use std::collections::BTreeSet;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The terrain where every robot gets stuck at once: the start walled in.
pub const ALL_STUCK: &str = ".....\n..G..\n.###.\n.#S#.\n.###.\n";

/// How often the launch's processes are read.
pub const SAMPLE_EVERY: Duration = Duration::from_millis(250);

/// How long a launch sent SIGINT (timeout, Ctrl-C) may take to wind down
/// before its process group and what is left of it are killed.
const STOP_GRACE: Duration = Duration::from_secs(30);

/// Where the machine's shared memory is (iceoryx2's segments, swarm locks).
pub(super) const SHARED_MEMORY: &str = "/dev/shm";

/// What `bench crowd` is asked to do.
#[derive(Clone, Debug)]
pub struct Options {
    /// The swarm sizes, one launch each, in order.
    pub robots: Vec<u32>,
    /// `--agent-bin` for the launches.
    pub agent_bin: Option<PathBuf>,
    /// Longest one launch may take.
    pub timeout: Duration,
    /// Run each swarm size a second time, recorded (`--record`).
    pub record: bool,
    /// Launches per swarm size (at least 1), each size's in turn.
    pub repeat: u32,
}

/// How one launch ended, as the bench saw it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Ended {
    /// It ran to its end and printed a summary (its outcome is in the row).
    Ran,
    /// It refused to start (a usage error, exit 2: the open-files check).
    Refused,
    /// It failed without a summary.
    Failed,
    /// It ran past `--timeout` and was stopped.
    TimedOut,
    /// Ctrl-C: it was stopped, and no further launch runs.
    Interrupted,
}

/// One launch's figures.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub robots: u32,
    /// Bytes of the launch's recording, when it was recorded.
    pub recording_bytes: Option<u64>,
    pub ended: Ended,
    /// The summary's outcome (`robots_exhausted` expected).
    pub outcome: Option<String>,
    /// The launch's exit code (none when killed by a signal).
    pub exit_code: Option<i32>,
    /// Why it refused or failed: its last error line, or the summary's error.
    pub message: Option<String>,
    /// Peak PSS of the orchestrator and all its agents together, MB.
    pub peak_pss_mb: f64,
    /// `peak_pss_mb / robots`.
    pub pss_mb_per_robot: f64,
    /// Peak PSS of the orchestrator alone, MB.
    pub peak_orchestrator_pss_mb: f64,
    /// Lockstep ticks run (the summary's `ticks`).
    pub ticks: Option<u64>,
    /// Wall time of the launch (the summary's `wall_s`).
    pub wall_s: Option<f64>,
    /// `wall_s / ticks`, ms (the agents' start and wind-down included).
    pub ms_per_tick: Option<f64>,
    /// A tick's own wall time (the summary's `tick_us`: its `Tick`s to its
    /// last answer, ticks without a re-send), ms.
    pub clock_ms_per_tick: Option<f64>,
    /// Agents stepping per tick (the summary's `ticked_agents / ticks`:
    /// ticked, or covered by a run of ticks): what a tick costs over this
    /// is what one stepping agent costs.
    pub agents_per_tick: Option<f64>,
    /// What one stepping agent adds to a tick, µs: a tick's own time per
    /// agent stepping in it, over the ticks while no agent was starting (the
    /// summary's `quiet_us_per_agent`).
    pub us_per_agent: Option<f64>,
    /// Peak open files of the orchestrator.
    pub peak_files_orchestrator: usize,
    /// Peak open files of the busiest agent.
    pub peak_files_agent: usize,
    /// Most agents alive at one sample.
    pub peak_agents: usize,
    /// Agents killed because they did not exit after `Shutdown` (the
    /// summary's `shutdown_killed`).
    pub killed_at_shutdown: Option<usize>,
    /// Files the launch left in `/dev/shm` and its iceoryx2 root (removed
    /// after counting).
    pub files_left: Vec<String>,
    /// iceoryx2's root segments the launch's fresh root made (not counted in
    /// `files_left`; a launch on the machine's root shares the existing one).
    pub root_segments: Vec<String>,
    /// Processes of the launch still running after it ended (killed).
    pub processes_left: usize,
    /// Samples taken.
    pub samples: u32,
    /// Mean time one sample took, ms.
    pub sample_ms: f64,
}

/// Runs one launch per swarm size of `opts`, in order; stops early on Ctrl-C
/// (the last row says `interrupted`).
pub fn run(opts: &Options) -> Result<Vec<Row>> {
    let stop = bycoms_launch::interrupt_flag();
    let dir = tempfile::Builder::new().prefix("bycoms-crowd-").tempdir().context("temporary directory")?;
    let terrain = dir.path().join("all-stuck.txt");
    std::fs::write(&terrain, ALL_STUCK).context("cannot write the terrain")?;
    let exe = std::env::current_exe().context("cannot find this executable")?;
    let mut rows = Vec::new();
    for &robots in &opts.robots {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        let times = (0..opts.repeat.max(1)).flat_map(|_| [false, true]);
        for record in times.filter(|r| !r || opts.record) {
            if stop.load(Ordering::SeqCst) {
                break;
            }
            let launch = Launch { exe: &exe, terrain: &terrain, dir: dir.path(), robots, record, opts };
            let row = launch.run(&stop)?;
            tracing::info!(robots, record, ended = ?row.ended, wall_s = ?row.wall_s, peak_pss_mb = row.peak_pss_mb, "launch measured");
            let interrupted = row.ended == Ended::Interrupted;
            rows.push(row);
            if interrupted {
                return Ok(rows);
            }
        }
    }
    Ok(rows)
}

/// One launch to run and measure.
struct Launch<'a> {
    exe: &'a Path,
    /// Whether it records (to a file in `dir`, removed with it).
    record: bool,
    terrain: &'a Path,
    dir: &'a Path,
    robots: u32,
    opts: &'a Options,
}

/// The peaks of the samples so far.
#[derive(Default)]
struct Peaks {
    pss_kb: u64,
    orchestrator_pss_kb: u64,
    files_orchestrator: usize,
    files_agent: usize,
    agents: usize,
    samples: u32,
    sampling: Duration,
}

impl Peaks {
    /// Reads the process tree under `root` once.
    fn sample(&mut self, root: u32) {
        let t0 = Instant::now();
        let tree = procfs::tree(root);
        let agents = &tree[1..];
        let orchestrator = procfs::pss_kb(root);
        let pss = orchestrator + agents.iter().map(|&p| procfs::pss_kb(p)).sum::<u64>();
        self.pss_kb = self.pss_kb.max(pss);
        self.orchestrator_pss_kb = self.orchestrator_pss_kb.max(orchestrator);
        self.files_orchestrator = self.files_orchestrator.max(procfs::open_files(root).unwrap_or(0));
        let busiest = agents.iter().filter_map(|&p| procfs::open_files(p)).max().unwrap_or(0);
        self.files_agent = self.files_agent.max(busiest);
        self.agents = self.agents.max(agents.len());
        self.samples += 1;
        self.sampling += t0.elapsed();
    }
}

/// When to sample next after a sample due at `due` took `took`: every
/// [`SAMPLE_EVERY`], or less often when a sample takes longer than a fifth
/// of that, so the bench takes at most a fifth of the machine from the
/// launch it measures (reading 1000 processes' `smaps_rollup` took up to
/// 360 ms, which every 250 ms had halved the launch's speed).
fn next_sample_after(due: Instant, took: Duration) -> Instant {
    due + SAMPLE_EVERY.max(took * 5)
}

/// The child launch, its process group killed if it is dropped running.
pub(super) struct Running(pub(super) Child);

impl Drop for Running {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            let _ = killpg(Pid::from_raw(self.0.id() as i32), Signal::SIGKILL);
            let _ = self.0.wait();
        }
    }
}

impl Launch<'_> {
    fn run(&self, stop: &AtomicBool) -> Result<Row> {
        let n = self.robots;
        let tag = format!("crowd-{}-{n}", std::process::id());
        let shm_before = listing(Path::new(SHARED_MEMORY));
        let (out_path, err_path) =
            (self.dir.join(format!("launch-{n}.json")), self.dir.join(format!("launch-{n}.log")));
        let recording = self.record.then(|| self.dir.join(format!("launch-{n}.mcap")));
        let mut cmd = self.command(&tag, &out_path, &err_path, recording.as_deref())?;
        let mut child = Running(cmd.spawn().context("cannot start the launch")?);
        let (status, peaks, mut ended) = self.watch(&mut child, stop)?;
        let processes_left = end_leftovers(&tag);
        let (files_left, root_segments) = files_left(&tag, &shm_before);
        let stdout = std::fs::read_to_string(&out_path).unwrap_or_default();
        let stderr = std::fs::read_to_string(&err_path).unwrap_or_default();
        let summary: Option<serde_json::Value> = serde_json::from_str(&stdout).ok();
        let exit_code = status.code();
        if ended == Ended::Ran && summary.is_none() {
            ended =
                if exit_code == Some(bycoms_runtime::exit::USAGE) { Ended::Refused } else { Ended::Failed };
        }
        let get = |key: &str| summary.as_ref().and_then(|s| s.get(key));
        let ticks = get("ticks").and_then(serde_json::Value::as_u64);
        let wall_s = get("wall_s").and_then(serde_json::Value::as_f64);
        let per_tick = |key: &str, scale: f64| match (get(key).and_then(serde_json::Value::as_f64), ticks) {
            (Some(v), Some(t)) if t > 0 => Some(scale * v / t as f64),
            _ => None,
        };
        let message = get("error")
            .and_then(|e| e.as_str())
            .map(str::to_owned)
            .or_else(|| (summary.is_none()).then(|| last_words(&stderr)).flatten());
        let mb = |kb: u64| kb as f64 / 1024.0;
        let recording_bytes = recording.as_ref().and_then(|f| std::fs::metadata(f).ok()).map(|m| m.len());
        if let Some(file) = &recording {
            let _ = std::fs::remove_file(file);
        }
        Ok(Row {
            robots: n,
            recording_bytes,
            ended,
            outcome: get("outcome").and_then(|o| o.as_str()).map(str::to_owned),
            exit_code,
            message,
            peak_pss_mb: mb(peaks.pss_kb),
            pss_mb_per_robot: mb(peaks.pss_kb) / f64::from(n.max(1)),
            peak_orchestrator_pss_mb: mb(peaks.orchestrator_pss_kb),
            ticks,
            wall_s,
            ms_per_tick: per_tick("wall_s", 1e3),
            clock_ms_per_tick: get("tick_us").and_then(serde_json::Value::as_f64).map(|us| us / 1e3),
            agents_per_tick: per_tick("ticked_agents", 1.0),
            us_per_agent: get("quiet_us_per_agent")
                .and_then(serde_json::Value::as_f64)
                .filter(|&us| us > 0.0),
            peak_files_orchestrator: peaks.files_orchestrator,
            peak_files_agent: peaks.files_agent,
            peak_agents: peaks.agents,
            killed_at_shutdown: get("shutdown_killed").and_then(|k| k.as_array()).map(Vec::len),
            files_left,
            root_segments,
            processes_left,
            samples: peaks.samples,
            sample_ms: if peaks.samples == 0 {
                0.0
            } else {
                peaks.sampling.as_secs_f64() * 1e3 / f64::from(peaks.samples)
            },
        })
    }

    /// The launch's command line: the crowd's terrain, every robot sticking
    /// at once, its summary and log to files, its own process group.
    fn command(
        &self,
        tag: &str,
        out_path: &Path,
        err_path: &Path,
        recording: Option<&Path>,
    ) -> Result<Command> {
        let mut cmd = Command::new(self.exe);
        cmd.arg("launch")
            .arg("--terrain")
            .arg(self.terrain)
            .args(["--robots", &self.robots.to_string(), "--dwell", "1", "--stop-turn-rate", "0"])
            .args(["--time-limit", "1e7", "--json", "--swarm", tag]);
        if let Some(bin) = &self.opts.agent_bin {
            cmd.arg("--agent-bin").arg(bin);
        }
        if let Some(file) = recording {
            cmd.arg("--record").arg(file);
        }
        cmd.env(ISOLATION_ENV, tag)
            .stdin(Stdio::null())
            .stdout(std::fs::File::create(out_path).context("launch output file")?)
            .stderr(std::fs::File::create(err_path).context("launch log file")?)
            // Its own group: a timeout kills the launch, not the bench.
            .process_group(0);
        Ok(cmd)
    }

    /// Samples the running launch's memory and files until it ends, the
    /// bench is interrupted or the timeout passes: how it ended.
    fn watch(&self, child: &mut Running, stop: &AtomicBool) -> Result<(ExitStatus, Peaks, Ended)> {
        let pid = child.0.id();
        let started = Instant::now();
        let mut peaks = Peaks::default();
        let mut next_sample = started;
        let mut ended = Ended::Ran;
        let status = loop {
            if let Some(status) = child.0.try_wait()? {
                break status;
            }
            let interrupted = stop.load(Ordering::SeqCst);
            if interrupted || started.elapsed() > self.opts.timeout {
                ended = if interrupted { Ended::Interrupted } else { Ended::TimedOut };
                tracing::warn!(robots = self.robots, "stopping the launch ({ended:?})");
                break stop_launch(&mut child.0)?;
            }
            if Instant::now() >= next_sample {
                let t0 = Instant::now();
                peaks.sample(pid);
                next_sample = next_sample_after(next_sample, t0.elapsed());
            }
            // Short naps: the launch's end is noticed within 20 ms.
            std::thread::sleep(
                next_sample.saturating_duration_since(Instant::now()).min(Duration::from_millis(20)),
            );
        };
        Ok((status, peaks, ended))
    }
}

/// Stops a running launch as Ctrl-C would (SIGINT to its group: it winds
/// its agents down in order), then kills the group after [`STOP_GRACE`].
fn stop_launch(child: &mut Child) -> Result<ExitStatus> {
    let group = Pid::from_raw(child.id() as i32);
    let _ = killpg(group, Signal::SIGINT);
    let deadline = Instant::now() + STOP_GRACE;
    while Instant::now() < deadline {
        if let Some(status) = child.try_wait()? {
            return Ok(status);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = killpg(group, Signal::SIGKILL);
    Ok(child.wait()?)
}

/// Kills the processes still carrying the launch's tag (its agents run in
/// process groups of their own and outlive a killed orchestrator until
/// their lifeline notices); returns how many there were.
pub(super) fn end_leftovers(tag: &str) -> usize {
    let left = procfs::with_env(ISOLATION_ENV, tag);
    for &pid in &left {
        let _ = kill(Pid::from_raw(pid as i32), Signal::SIGKILL);
    }
    if !left.is_empty() {
        tracing::warn!(count = left.len(), "processes of the launch outlived it: killed");
        // Not our children (reparented): wait until the kernel has ended them.
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline && !procfs::with_env(ISOLATION_ENV, tag).is_empty() {
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    left.len()
}

/// The files of tag `tag` that are left: new entries of `/dev/shm` naming
/// it, every file under its iceoryx2 root; and apart, the root's own
/// segments ([`is_root_segment`]). All removed once listed.
pub(super) fn files_left(tag: &str, shm_before: &BTreeSet<PathBuf>) -> (Vec<String>, Vec<String>) {
    let shm: Vec<PathBuf> = listing(Path::new(SHARED_MEMORY))
        .into_iter()
        .filter(|p| !shm_before.contains(p))
        .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().contains(tag)))
        .collect();
    let root = root_dir(tag);
    let mut all: Vec<String> = shm.iter().map(|p| p.display().to_string()).collect();
    all.extend(listing(&root).iter().map(|p| p.display().to_string()));
    for p in &shm {
        let _ = std::fs::remove_file(p);
    }
    let _ = std::fs::remove_dir_all(&root);
    all.into_iter().partition(|f| !is_root_segment(f))
}

/// Whether `file` is iceoryx2's `global_mgmt` segment of a root (the
/// counter its nodes draw their ids from): made by the first process of a
/// root and kept for every later one. A launch on the machine's own root
/// finds it there; under the bench's fresh tag each launch makes one. So
/// it is not counted as left by the launch (reported apart).
fn is_root_segment(file: &str) -> bool {
    file.ends_with(".global_mgmt")
}

/// Every file (not directory) under `dir`, recursively; empty when `dir` is
/// missing.
pub(super) fn listing(dir: &Path) -> BTreeSet<PathBuf> {
    let mut out = BTreeSet::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else { continue };
        for e in entries.flatten() {
            match e.file_type() {
                Ok(t) if t.is_dir() => todo.push(e.path()),
                Ok(_) => {
                    out.insert(e.path());
                }
                Err(_) => {}
            }
        }
    }
    out
}

/// The last line of a launch's log that says something (its error),
/// without the log level in front.
fn last_words(log: &str) -> Option<String> {
    let line = log.lines().rev().map(str::trim).find(|l| !l.is_empty())?;
    let text = ["ERROR ", "WARN "].iter().find_map(|level| line.strip_prefix(level)).unwrap_or(line);
    Some(text.trim_start().to_owned())
}

/// Files left named per row in the table.
const FILES_NAMED: usize = 5;

/// The rows as a table, with the files left named under it.
pub fn table(rows: &[Row]) -> String {
    let mut out = format!(
        "launch --terrain ALL_STUCK --robots N --dwell 1 --stop-turn-rate 0 --time-limit 1e7 (lockstep), \
         sampled every {} ms (less often when a sample takes over a fifth of that)\n",
        SAMPLE_EVERY.as_millis()
    );
    out.push_str(&format!(
        "{:>6} {:>8} {:>9} {:>8} {:>8} {:>8} {:>8} {:>9} {:>9} {:>8} {:>8} {:>10} {:>11} {:>7} {:>6} {:>6}\n",
        "robots",
        "rec MB",
        "PSS MB",
        "MB/robot",
        "orch MB",
        "ticks",
        "wall s",
        "ms/tick",
        "clock ms",
        "agents",
        "µs/agent",
        "files orch",
        "files agent",
        "agents",
        "killed",
        "left"
    ));
    let opt = |v: Option<f64>, prec: usize| v.map_or("–".to_owned(), |v| format!("{v:.prec$}"));
    for r in rows {
        if matches!(r.ended, Ended::Refused | Ended::Failed) {
            let what = if r.ended == Ended::Refused { "refused" } else { "failed" };
            out.push_str(&format!(
                "{:>6} {what}: {}\n",
                r.robots,
                r.message.as_deref().unwrap_or("no message")
            ));
            continue;
        }
        out.push_str(&format!(
            "{:>6} {:>8} {:>9.1} {:>8.2} {:>8.1} {:>8} {:>8} {:>9} {:>9} {:>8} {:>8} {:>10} {:>11} {:>7} {:>6} {:>6}",
            r.robots,
            r.recording_bytes.map_or("–".to_owned(), |b| format!("{:.1}", b as f64 / 1e6)),
            r.peak_pss_mb,
            r.pss_mb_per_robot,
            r.peak_orchestrator_pss_mb,
            r.ticks.map_or("–".to_owned(), |t| t.to_string()),
            opt(r.wall_s, 2),
            opt(r.ms_per_tick, 2),
            opt(r.clock_ms_per_tick, 3),
            opt(r.agents_per_tick, 2),
            opt(r.us_per_agent, 1),
            r.peak_files_orchestrator,
            r.peak_files_agent,
            r.peak_agents,
            r.killed_at_shutdown.map_or("–".to_owned(), |k| k.to_string()),
            r.files_left.len()
        ));
        match (r.ended, &r.outcome) {
            (Ended::Ran, Some(o)) if o == "robots_exhausted" => {}
            (Ended::Ran, o) => out.push_str(&format!("  (outcome {})", o.as_deref().unwrap_or("unknown"))),
            (e, _) => out.push_str(&format!("  ({e:?})")),
        }
        out.push('\n');
    }
    out.push_str(&row_notes(rows));
    out.push_str(&recording_costs(rows));
    for m in medians(rows) {
        out.push_str(&m.line());
    }
    let sample_ms = rows.iter().map(|r| r.sample_ms).fold(0.0, f64::max);
    out.push_str(&format!(
        "PSS: orchestrator and all agents together, peak of the samples; a sample took up to {sample_ms:.1} ms\n\
         ms/tick: wall time over ticks; clock ms: a tick's own time (its Ticks to its last answer, ticks without \
         a re-send); agents: agents stepping per tick (ticked, or covered by a run of ticks sent before: a creeping \
         robot judged stuck); µs/agent: a tick's own time per stepping agent, over the \
         ticks while no agent was starting (what each stepping agent adds)"
    ));
    out
}

/// Under the table: each run's error, the files and processes it left.
fn row_notes(rows: &[Row]) -> String {
    let mut out = String::new();
    for r in rows {
        if let Some(m) = r.message.as_ref().filter(|_| r.ended == Ended::Ran) {
            out.push_str(&format!("{} robots: error: {m}\n", r.robots));
        }
        if !r.files_left.is_empty() {
            // A launch that was stopped leaves thousands: name a few (the
            // JSON has them all).
            let named = r.files_left.iter().take(FILES_NAMED).map(String::as_str).collect::<Vec<_>>();
            let more = r.files_left.len().saturating_sub(FILES_NAMED);
            let more = if more > 0 { format!(" and {more} more") } else { String::new() };
            out.push_str(&format!(
                "{} robots: {} files left (removed): {}{more}\n",
                r.robots,
                r.files_left.len(),
                named.join(", ")
            ));
        }
        if r.processes_left > 0 {
            out.push_str(&format!(
                "{} robots: {} processes outlived the launch (killed)\n",
                r.robots, r.processes_left
            ));
        }
    }
    out
}

/// The medians of one swarm size's unrecorded launches that ran, when it
/// ran more than once (`--repeat`).
///
/// Why: a small crowd's `µs/agent` is taken over few ticks (about a hundred
/// at 10 robots, those away from agent starts), and one launch's figure
/// swings by a third from the next one's; the median of several is the
/// figure to quote.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Medians {
    pub robots: u32,
    /// Launches counted.
    pub launches: usize,
    /// Median, least and greatest `us_per_agent`.
    pub us_per_agent: Option<Spread>,
    /// Median, least and greatest `ms_per_tick`.
    pub ms_per_tick: Option<Spread>,
}

/// A figure's median and range over launches.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Spread {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

impl Spread {
    fn of(values: &[f64]) -> Option<Self> {
        use bycoms_runtime::stats::{median, quantile};
        Some(Self { median: median(values)?, min: quantile(values, 0.0)?, max: quantile(values, 1.0)? })
    }
}

impl Medians {
    /// One line under the table.
    fn line(&self) -> String {
        let spread = |s: Option<Spread>, prec: usize| {
            s.map_or("–".to_owned(), |s| format!("{:.prec$} ({:.prec$}–{:.prec$})", s.median, s.min, s.max))
        };
        format!(
            "{} robots, median of {} launches (least–greatest): µs/agent {}, ms/tick {}\n",
            self.robots,
            self.launches,
            spread(self.us_per_agent, 1),
            spread(self.ms_per_tick, 3)
        )
    }
}

/// [`Medians`] of each swarm size run more than once, in the order of the
/// sizes' first launches.
pub fn medians(rows: &[Row]) -> Vec<Medians> {
    let mut sizes: Vec<u32> = Vec::new();
    for r in rows {
        if !sizes.contains(&r.robots) {
            sizes.push(r.robots);
        }
    }
    let counted = |robots: u32| {
        rows.iter()
            .filter(move |r| r.robots == robots && r.ended == Ended::Ran && r.recording_bytes.is_none())
    };
    sizes
        .into_iter()
        .filter(|&n| counted(n).count() > 1)
        .map(|n| {
            let us: Vec<f64> = counted(n).filter_map(|r| r.us_per_agent).collect();
            let ms: Vec<f64> = counted(n).filter_map(|r| r.ms_per_tick).collect();
            Medians {
                robots: n,
                launches: counted(n).count(),
                us_per_agent: Spread::of(&us),
                ms_per_tick: Spread::of(&ms),
            }
        })
        .collect()
}

/// Under the table: what recording cost, for each size run both without
/// and with `--record` (in that order).
fn recording_costs(rows: &[Row]) -> String {
    let mut out = String::new();
    for pair in rows.windows(2) {
        let (plain, recorded) = (&pair[0], &pair[1]);
        if plain.robots != recorded.robots || plain.recording_bytes.is_some() {
            continue;
        }
        let (Some(bytes), Some(slow), Some(fast)) =
            (recorded.recording_bytes, recorded.ms_per_tick, plain.ms_per_tick)
        else {
            continue;
        };
        out.push_str(&format!(
            "{} robots recorded: {:.1} MB, {slow:.2} ms/tick against {fast:.2} unrecorded ({:+.1} %)\n",
            plain.robots,
            bytes as f64 / 1e6,
            100.0 * (slow / fast - 1.0)
        ));
    }
    out
}

#[cfg(test)]
mod tests;
