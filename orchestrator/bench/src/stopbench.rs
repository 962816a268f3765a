//! `orchestrator bench stop`: `orchestrator stop --now` → every robot told
//! `Stop`, timed from the asking side, over ipc and zenoh (issue 34).
//!
//! Why from outside: what a lab needs is the time from the command to the
//! robots, through the launch's control socket or queryable and its driver,
//! as `orchestrator stop` sees it. So each run starts a real-time
//! `orchestrator launch` as a child process (its own process group and
//! iceoryx2 isolation tag, as `bench crowd` does, whose cleanup it reuses)
//! on the all-stuck terrain (`crowd::ALL_STUCK`: every deployed robot
//! sticks and its agent stays alive), asks its `status` until every
//! robot's agent runs (bounded), then asks `Stop { now: true }` and times
//!
//! * until the launch's answer: the launch answers once every robot told
//!   `Stop` answered that it stopped (`StopDone`: a simulated agent stands
//!   still, a gateway sent its robot the link's stop frame), or the stop's
//!   wait (1 s) was over: command → every robot stopped;
//! * until the launch process has exited (agents wound down, summary written).
//!
//! The answer says how many robots were told and answered, and when the
//! last answer came in the launch's own time (`slowest`, without the
//! asking and answering around it).

use super::crowd::{end_leftovers, files_left, listing, Running, ALL_STUCK, SHARED_MEMORY};
use anyhow::{bail, Context, Result};
use bycoms_launch::config::Transport;
use bycoms_launch::control::{ask_socket, socket_path, Answer, Ask, Asker};
use bycoms_protocol::bus::ipc::root::ISOLATION_ENV;
use serde::Serialize;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// How long a question may wait for its answer.
const ASK_TIMEOUT: Duration = Duration::from_secs(3);

/// What `bench stop` is asked to do.
#[derive(Clone, Debug)]
pub struct Options {
    pub robots: u32,
    pub runs: u32,
    pub transport: Transport,
    /// `--agent-bin` for the launches.
    pub agent_bin: Option<PathBuf>,
    /// Real-time speed-up of the launches.
    pub speed: f64,
    /// Longest wait for every agent to run, then for the launch to exit.
    pub timeout: Duration,
}

/// One run's figures.
#[derive(Clone, Debug, Serialize)]
pub struct Sample {
    /// Robots whose agent ran when the stop was asked.
    pub running: usize,
    /// Robots the launch told `Stop`.
    pub told: usize,
    /// Robots that answered that they stopped.
    pub answered: usize,
    /// Ask → the launch's answer (every robot stopped), ms.
    pub answer_ms: f64,
    /// The stop taken in → the last robot's answer, in the launch, ms.
    pub slowest_ms: f64,
    /// Ask → the launch process exited, ms.
    pub exit_ms: f64,
}

/// Where the bench asks one launch.
enum Where {
    Socket(PathBuf),
    Zenoh(Asker, String),
}

impl Where {
    fn ask(&self, ask: &Ask) -> Result<Answer> {
        match self {
            Self::Socket(path) => ask_socket(path, ask, ASK_TIMEOUT),
            Self::Zenoh(asker, swarm) => {
                let reached = asker.ask(Some(swarm), ask)?;
                let r = reached.into_iter().next().context("the launch did not answer over zenoh")?;
                r.answer.map_err(|e| anyhow::anyhow!(e))
            }
        }
    }
}

/// Runs `opts.runs` launches, one stop each.
pub fn run(opts: &Options) -> Result<Vec<Sample>> {
    let dir =
        tempfile::Builder::new().prefix("bycoms-stopbench-").tempdir().context("temporary directory")?;
    let terrain = dir.path().join("all-stuck.txt");
    std::fs::write(&terrain, ALL_STUCK).context("cannot write the terrain")?;
    let exe = std::env::current_exe().context("cannot find this executable")?;
    let mut samples = Vec::new();
    for i in 0..opts.runs.max(1) {
        let tag = format!("stopbench-{}-{i}", std::process::id());
        let shm_before = listing(Path::new(SHARED_MEMORY));
        let result = one(opts, &exe, &terrain, dir.path(), &tag);
        end_leftovers(&tag);
        files_left(&tag, &shm_before);
        let sample = result.with_context(|| format!("run {i}"))?;
        tracing::info!(run = i, ?sample, "stop measured");
        samples.push(sample);
    }
    Ok(samples)
}

/// A free TCP port of this host for the launch's zenoh listener.
fn free_port() -> Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

/// One launch: started, awaited until every agent runs, stopped, timed.
fn one(opts: &Options, exe: &Path, terrain: &Path, dir: &Path, tag: &str) -> Result<Sample> {
    let out = dir.join(format!("{tag}.json"));
    let mut cmd = Command::new(exe);
    cmd.arg("launch")
        .arg("--terrain")
        .arg(terrain)
        .args(["--robots", &opts.robots.to_string(), "--clock", "realtime"])
        .args(["--speed", &opts.speed.to_string(), "--dwell", "2", "--stop-turn-rate", "0"])
        .args(["--time-limit", "1e7", "--json", "--swarm", tag])
        .args(["--transport", opts.transport.as_str()]);
    let port = free_port()?;
    if opts.transport == Transport::Zenoh {
        cmd.args(["--listen", &format!("tcp/127.0.0.1:{port}")]);
    }
    if let Some(bin) = &opts.agent_bin {
        cmd.arg("--agent-bin").arg(bin);
    }
    cmd.env(ISOLATION_ENV, tag)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).context("launch output file")?)
        .stderr(std::fs::File::create(dir.join(format!("{tag}.log"))).context("launch log file")?)
        .process_group(0);
    let mut child = Running(cmd.spawn().context("cannot start the launch")?);
    let place = match opts.transport {
        Transport::Zenoh => Where::Zenoh(asker_when_up(port, &mut child, opts.timeout)?, tag.to_owned()),
        _ => Where::Socket(socket_path(Some(tag), tag)),
    };
    let running = await_all_running(&place, &mut child, opts)?;
    let ask =
        Ask::Stop { now: true, who: format!("bench stop (pid {})", std::process::id()), why: "bench".into() };
    let t0 = Instant::now();
    let answer = place.ask(&ask)?;
    let answer_ms = t0.elapsed().as_secs_f64() * 1e3;
    let Answer::Stopping { now: true, told, answered, slowest_us, .. } = answer else {
        bail!("the launch answered {answer:?} to the stop");
    };
    let deadline = t0 + opts.timeout;
    let exit_ms = loop {
        if child.0.try_wait()?.is_some() {
            break t0.elapsed().as_secs_f64() * 1e3;
        }
        if Instant::now() > deadline {
            bail!("the launch did not exit within {:?} of the stop", opts.timeout);
        }
        std::thread::sleep(Duration::from_micros(500));
    };
    let slowest_ms = slowest_us.map_or(f64::NAN, |us| us as f64 / 1e3);
    Ok(Sample { running, told: told as usize, answered: answered as usize, answer_ms, slowest_ms, exit_ms })
}

/// A zenoh client of the launch at `port`, once the launch listens there.
fn asker_when_up(port: u16, child: &mut Running, timeout: Duration) -> Result<Asker> {
    let deadline = Instant::now() + timeout;
    let addr = std::net::SocketAddr::from(([127, 0, 0, 1], port));
    while std::net::TcpStream::connect_timeout(&addr, Duration::from_millis(200)).is_err() {
        if child.0.try_wait()?.is_some() || Instant::now() > deadline {
            bail!("the launch never listened on {addr}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Asker::open(Some(&format!("tcp/127.0.0.1:{port}")), None)
}

/// Asks the launch's status until every robot's agent runs; how many run.
fn await_all_running(place: &Where, child: &mut Running, opts: &Options) -> Result<usize> {
    let deadline = Instant::now() + opts.timeout;
    loop {
        if child.0.try_wait()?.is_some() {
            bail!("the launch ended before every agent ran (try a lower --speed)");
        }
        if Instant::now() > deadline {
            bail!("not every agent ran within {:?}", opts.timeout);
        }
        if let Ok(Answer::Status(s)) = place.ask(&Ask::Status) {
            let running = s.robots.iter().filter(|r| r.running).count();
            if running >= opts.robots as usize {
                return Ok(running);
            }
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// The figures of one transport's runs, in one line.
pub fn line(transport: Transport, robots: u32, samples: &[Sample]) -> String {
    let q = |f: fn(&Sample) -> f64, p: f64| {
        // A run without answers has no slowest answer (NaN): left out.
        let v: Vec<f64> = samples.iter().map(f).filter(|v| !v.is_nan()).collect();
        bycoms_runtime::stats::quantile(&v, p).unwrap_or(f64::NAN)
    };
    let all = samples.iter().filter(|s| s.told == robots as usize && s.answered == s.told).count();
    format!(
        "stop --now, {robots} robots over {}, {} runs: every robot stopped (answered) p50 {:.1} ms, \
         max {:.1} ms (in the launch p50 {:.1} ms); launch exited p50 {:.1} ms, max {:.1} ms; \
         every robot told and answered in {all} of {} runs",
        transport.as_str(),
        samples.len(),
        q(|s| s.answer_ms, 0.5),
        q(|s| s.answer_ms, 1.0),
        q(|s| s.slowest_ms, 0.5),
        q(|s| s.exit_ms, 0.5),
        q(|s| s.exit_ms, 1.0),
        samples.len()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_gives_p50_max_and_how_many_runs_had_every_robot_answer() {
        let s = |answer_ms, exit_ms, answered| Sample {
            running: 3,
            told: 3,
            answered,
            answer_ms,
            slowest_ms: answer_ms / 2.0,
            exit_ms,
        };
        let samples = [s(3.0, 30.0, 3), s(1.0, 10.0, 3), s(2.0, 20.0, 2)];
        assert_eq!(
            line(Transport::Ipc, 3, &samples),
            "stop --now, 3 robots over ipc, 3 runs: every robot stopped (answered) p50 2.0 ms, \
             max 3.0 ms (in the launch p50 1.0 ms); launch exited p50 20.0 ms, max 30.0 ms; \
             every robot told and answered in 2 of 3 runs"
        );
    }
}
