//! End-to-end tests live in `tests/tests/`; this library holds their shared
//! helpers.
//!
//! Why helpers for processes: every end-to-end test starts real processes
//! (the `orchestrator` and its `sim-agent`s). Each must be bounded in time,
//! must not collide with a test running in parallel, and must leave nothing
//! behind even when it fails. So: [`swarm_name`] makes unique topic
//! namespaces, [`Proc`] kills and reaps its process on drop, every wait has
//! a deadline, and [`agents_of`] finds a swarm's agent processes in `/proc`
//! (by their `--swarm` flag) so a test can kill one or prove none is left.

pub mod netns;

use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::bus::BusExt;
use bycoms_protocol::msg::Pose;
use bycoms_protocol::{RobotId, Swarm};
use bycoms_runtime::child::{wait_or_kill, Kill};
use bycoms_runtime::ipc_config;
use serde_json::Value;
use std::io::Read;
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// The lines `child` prints on its (piped) stdout, on a channel fed by a
/// thread that ends at its EOF: a test waits for a line with
/// `recv_timeout`, never without a deadline.
pub fn stdout_lines(child: &mut Child) -> std::sync::mpsc::Receiver<String> {
    use std::io::BufRead;
    let stdout = child.stdout.take().expect("piped stdout");
    let (tx, lines) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    lines
}

/// The iceoryx2 configuration the launched processes use: their own root
/// when `$BYCOMS_IPC_ISOLATION` is set (CI sets it for the whole run).
pub fn iox_config() -> bycoms_protocol::bus::ipc::root::Config {
    use bycoms_protocol::bus::ipc::root;
    root::config(root::tag_from_env().as_deref()).expect("valid $BYCOMS_IPC_ISOLATION")
}

/// A swarm name no other test (or test process) uses: `t<pid>-<n>-<tag>`.
pub fn swarm_name(tag: &str) -> String {
    static NEXT: AtomicU32 = AtomicU32::new(0);
    format!("t{}-{}-{tag}", std::process::id(), NEXT.fetch_add(1, Ordering::SeqCst))
}

/// A workspace binary (`orchestrator`, `sim-agent`) of the profile the tests
/// were built with. `cargo test --workspace` builds them; running this
/// crate's tests alone needs `cargo build --bins` first.
pub fn bin(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/<test> → target/<profile>/<name>
    let dir = exe.parent().and_then(|deps| deps.parent()).expect("target/<profile> directory");
    let path = dir.join(name);
    assert!(path.is_file(), "{} is missing: run `cargo build --workspace --bins` first", path.display());
    path
}

/// A child process that is killed and reaped when dropped.
pub struct Proc {
    child: Option<Child>,
    stdout: Option<std::thread::JoinHandle<String>>,
    stderr: Option<std::thread::JoinHandle<String>>,
    /// Each stderr line as it comes (the whole text is also kept).
    stderr_lines: std::sync::mpsc::Receiver<String>,
}

/// What a finished process left.
#[derive(Debug)]
pub struct Finished {
    pub status: ExitStatus,
    pub stdout: String,
    pub stderr: String,
}

impl Finished {
    /// The stdout as JSON (the `--json` summary).
    pub fn json(&self) -> Value {
        serde_json::from_str(&self.stdout)
            .unwrap_or_else(|e| panic!("stdout is not JSON ({e}): {}\nstderr: {}", self.stdout, self.stderr))
    }
}

/// Collects `r` whole and sends each line on `lines` as it comes.
fn collect_lines(
    r: impl Read + Send + 'static,
    lines: std::sync::mpsc::Sender<String>,
) -> std::thread::JoinHandle<String> {
    std::thread::spawn(move || {
        use std::io::BufRead;
        let mut s = String::new();
        for line in std::io::BufReader::new(r).lines() {
            let Ok(line) = line else { break };
            s.push_str(&line);
            s.push('\n');
            // The receiver may be gone; the text is still collected.
            let _ = lines.send(line);
        }
        s
    })
}

fn collect(mut r: impl Read + Send + 'static) -> std::thread::JoinHandle<String> {
    std::thread::spawn(move || {
        let mut s = String::new();
        let _ = r.read_to_string(&mut s);
        s
    })
}

impl Proc {
    /// Starts `program` with `args`, capturing stdout and stderr.
    pub fn start(program: &PathBuf, args: &[String]) -> Proc {
        Self::start_with_env(program, args, &[])
    }

    /// [`Proc::start`] with `env` added to the environment.
    pub fn start_with_env(program: &PathBuf, args: &[String], env: &[(&str, &str)]) -> Proc {
        let mut child = Command::new(program)
            .args(args)
            .envs(env.iter().copied())
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {}: {e}", program.display()));
        let stdout = child.stdout.take().map(collect);
        let (tx, stderr_lines) = std::sync::mpsc::channel();
        let stderr = child.stderr.take().map(|e| collect_lines(e, tx));
        Proc { child: Some(child), stdout, stderr, stderr_lines }
    }

    /// Waits up to `timeout` for a stderr line that `accept` maps to a
    /// value (lines before it are skipped, and stay in the final text).
    pub fn stderr_line<T>(&self, timeout: Duration, mut accept: impl FnMut(&str) -> Option<T>) -> Option<T> {
        let deadline = Instant::now() + timeout;
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            match self.stderr_lines.recv_timeout(left) {
                Ok(line) => {
                    if let Some(v) = accept(&line) {
                        return Some(v);
                    }
                }
                Err(_) => return None,
            }
        }
        None
    }

    /// The zenoh endpoint an orchestrator logged as where it listens, the
    /// first that starts with `prefix` (e.g. `tcp/10.231.0.1:`), with its
    /// port (the kernel's, for a `:0` listen); panics after `timeout`.
    pub fn logged_endpoint(&self, prefix: &str, timeout: Duration) -> String {
        self.stderr_line(timeout, |line| {
            let at = line.find(prefix)?;
            let port: String = line[at + prefix.len()..].chars().take_while(char::is_ascii_digit).collect();
            (!port.is_empty()).then(|| format!("{prefix}{port}"))
        })
        .unwrap_or_else(|| panic!("no {prefix}PORT endpoint logged within {timeout:?}"))
    }

    /// Starts the orchestrator with `args`.
    pub fn orchestrator(args: &[&str]) -> Proc {
        let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        Proc::start(&bin("orchestrator"), &args)
    }

    /// The process id.
    pub fn pid(&self) -> u32 {
        self.child.as_ref().map(Child::id).unwrap_or(0)
    }

    /// Sends SIGKILL.
    pub fn kill(&mut self) {
        if let Some(c) = self.child.as_mut() {
            let _ = c.kill();
        }
    }

    /// Waits up to `timeout` for the process to end; panics (after killing
    /// it) if it does not.
    pub fn wait(mut self, timeout: Duration) -> Finished {
        let mut child = self.child.take().expect("process not yet waited for");
        let waited = wait_or_kill(&mut child, timeout, Kill::Process).expect("wait for the process");
        if !waited.in_time {
            let err = self.stderr.take().map(|h| h.join().unwrap_or_default()).unwrap_or_default();
            panic!("process did not end within {timeout:?}; stderr:\n{err}");
        }
        let status = waited.status;
        let stdout = self.stdout.take().map(|h| h.join().unwrap_or_default()).unwrap_or_default();
        let stderr = self.stderr.take().map(|h| h.join().unwrap_or_default()).unwrap_or_default();
        Finished { status, stdout, stderr }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Live processes (not zombies) whose command line has `--swarm <swarm>`
/// and `--robot <id>`: the swarm's agents, with their robot ids.
pub fn agents_of(swarm: &str) -> Vec<(u32, u32)> {
    let mut found = Vec::new();
    let Ok(dir) = std::fs::read_dir("/proc") else { return found };
    for entry in dir.flatten() {
        let Some(pid) = entry.file_name().to_str().and_then(|s| s.parse::<u32>().ok()) else { continue };
        let Ok(cmdline) = std::fs::read(entry.path().join("cmdline")) else { continue };
        let args: Vec<&[u8]> = cmdline.split(|&b| b == 0).collect();
        let flag = |name: &[u8]| args.windows(2).find(|w| w[0] == name).map(|w| w[1]);
        if flag(b"--swarm") != Some(swarm.as_bytes()) || is_zombie(pid) {
            continue;
        }
        if let Some(robot) = flag(b"--robot").and_then(|r| std::str::from_utf8(r).ok()?.parse().ok()) {
            found.push((pid, robot));
        }
    }
    found
}

/// Whether `pid` is a zombie (dead, waiting to be reaped) or gone.
pub fn is_zombie(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        // The state follows the command name in parentheses.
        Ok(stat) => stat.rsplit_once(')').is_none_or(|(_, rest)| rest.trim_start().starts_with(['Z', 'X'])),
        Err(_) => true,
    }
}

/// Polls `f` every 10 ms until it returns `Some`, for at most `timeout`.
pub fn wait_for<T>(timeout: Duration, f: impl FnMut() -> Option<T>) -> Option<T> {
    wait_for_every(Duration::from_millis(10), timeout, f)
}

/// Polls `f` every `period` until it returns `Some`, for at most
/// `timeout` (a longer period where each poll starts a program).
pub fn wait_for_every<T>(period: Duration, timeout: Duration, mut f: impl FnMut() -> Option<T>) -> Option<T> {
    let deadline = Instant::now() + timeout;
    loop {
        if let Some(v) = f() {
            return Some(v);
        }
        if Instant::now() >= deadline {
            return None;
        }
        // Polled: what the callers wait for (a process in /proc, a file's
        // rows, a job in Slurm's queue) has no event to block on.
        std::thread::sleep(period);
    }
}

/// Sends `sig` to `pid` (ignoring a process that is already gone).
pub fn signal(pid: u32, sig: nix::sys::signal::Signal) {
    let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid as i32), sig);
}

/// Watches robot `robot`'s pose topic in swarm `swarm` (of `robots`
/// robots) until a pose satisfies `accept`, for at most `timeout`.
pub fn wait_for_pose(
    swarm: &str,
    robots: u32,
    robot: u32,
    timeout: Duration,
    mut accept: impl FnMut(&Pose) -> bool,
) -> Option<Pose> {
    let swarm = Swarm::new(swarm).expect("swarm name");
    let bus = IpcBus::new(ipc_config(robots)).expect("bus");
    let poses = bus.typed_subscriber(&swarm.pose(RobotId(robot))).expect("pose subscriber");
    let deadline = Instant::now() + timeout;
    while Instant::now() < deadline {
        if let Ok(Some(p)) = poses.recv_timeout(Duration::from_millis(20)) {
            if accept(&p) {
                return Some(p);
            }
        }
    }
    None
}

/// Pre-shared link keys of robots 1, 2, 3 for the tests' robots files
/// (64 hex digits each; test keys only).
pub const TEST_KEYS: [&str; 3] = [
    "1111111111111111111111111111111111111111111111111111111111111111",
    "2222222222222222222222222222222222222222222222222222222222222222",
    "3333333333333333333333333333333333333333333333333333333333333333",
];

/// A free loopback UDP address: bound on port 0, then released (a robots
/// file names fixed addresses, so a bound socket cannot be handed over;
/// the small race is accepted).
pub fn free_udp_port() -> std::net::SocketAddr {
    std::net::UdpSocket::bind(("127.0.0.1", 0)).and_then(|s| s.local_addr()).expect("a free UDP port")
}

/// How a launch's `--json` summary `j` differs from `expected`, the
/// in-process run (`bycoms_sim::run`) of the same world and settings: the
/// launch's error if it has one, outcome, total steps, robots used, then
/// robot by robot (the summary lists the deployed first, in order) its
/// end, its final position bit for bit (`x_bits`/`y_bits` against
/// `f64::to_bits`) and its active steps; every robot listed after those
/// never deployed. Empty when the two are the same.
pub fn simulate_differences(expected: &bycoms_sim::RunResult, j: &Value) -> Vec<String> {
    let mut found = Vec::new();
    if let Some(error) = j["error"].as_str() {
        found.push(format!("the launch's error: {error}"));
    }
    let mut check = |what: String, got: &Value, want: Value| {
        if *got != want {
            found.push(format!("{what}: {got}, simulate {want}"));
        }
    };
    check("outcome".into(), &j["outcome"], serde_json::to_value(expected.outcome).expect("serialisable"));
    check("steps".into(), &j["steps"], expected.steps.into());
    check("robots used".into(), &j["robots_used"], expected.robots_used.into());
    let robots = j["robots"].as_array().map(Vec::as_slice).unwrap_or_default();
    for (r, got) in expected.robots.iter().zip(robots) {
        let id = r.id;
        check(format!("robot {id} end"), &got["end"], serde_json::to_value(r.end).expect("serialisable"));
        check(format!("robot {id} x"), &got["x_bits"], r.position.x.to_bits().into());
        check(format!("robot {id} y"), &got["y_bits"], r.position.y.to_bits().into());
        check(format!("robot {id} steps"), &got["steps"], r.steps.into());
    }
    for got in robots.iter().skip(expected.robots.len()) {
        check(format!("robot {} end", got["id"]), &got["end"], "not_deployed".into());
    }
    if robots.len() < expected.robots.len() {
        found.push(format!("{} robots listed, simulate deployed {}", robots.len(), expected.robots.len()));
    }
    found
}

/// A Python test client of `tests/python/` (a client that is not ours:
/// eclipse-zenoh, rosbags, xxhash), killed and reaped on drop. It prints
/// lines (`ready`, then a JSON report) and reads one line on its stdin
/// when the test is done.
pub struct PythonClient {
    child: Child,
    stdin: Option<std::process::ChildStdin>,
    lines: std::sync::mpsc::Receiver<String>,
}

impl PythonClient {
    /// Starts `tests/python/<script>` with `args`.
    pub fn start(script: &str, args: &[&str]) -> PythonClient {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("python").join(script);
        let mut child = Command::new("python3")
            .arg(&path)
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("python3 starts");
        let lines = stdout_lines(&mut child);
        let stdin = child.stdin.take();
        PythonClient { child, stdin, lines }
    }

    /// Its next line (at most 60 s away).
    pub fn line(&self, what: &str) -> String {
        self.lines
            .recv_timeout(Duration::from_secs(60))
            .unwrap_or_else(|_| panic!("the Python client printed no {what} within 60 s"))
    }

    /// Tells it the test is done; its JSON report.
    pub fn report(&mut self) -> Value {
        self.report_after("done")
    }

    /// Writes `line` on its stdin (its cue) and closes it; its JSON report.
    pub fn report_after(&mut self, line: &str) -> Value {
        use std::io::Write;
        let mut stdin = self.stdin.take().expect("stdin");
        writeln!(stdin, "{line}").expect("write to the Python client");
        drop(stdin);
        serde_json::from_str(&self.line("report")).expect("the report is JSON")
    }
}

impl Drop for PythonClient {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
