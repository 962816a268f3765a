//! The README's runnable commands, run: every command of every README code
//! block whose info string has the word `runnable` (```` ```sh runnable ````)
//! must exit 0.
//!
//! Why: the README is the first thing a newcomer runs, and a command that
//! no longer parses (a renamed flag, a moved file) goes unnoticed by every
//! other test. Blocks without the marker are shown, not run: they need what
//! a test cannot have (real robots, another host, a fixed port, your own
//! terrain file) or more time than CI has.
//!
//! How each block runs (documented in the README's Test section):
//! * in a fresh temporary directory holding a copy of `deploy/`, so the
//!   files the commands write land there and relative paths as written in
//!   the README (`deploy/lab/robots.toml`) resolve;
//! * with the workspace's debug binaries first on `PATH`
//!   ([`bycoms_tests::bin`]); `cargo run [--release] [-p P] --bin NAME --`
//!   and `target/{release,debug}/NAME` become `NAME` (no build here, and no
//!   other cargo command may be marked);
//! * each command through `bash -c` with `set -eo pipefail`, in its own
//!   process group, killed with that group after [`COMMAND_TIMEOUT`]; a
//!   command ending in `&` runs in the background until the block's other
//!   commands are done, then gets SIGINT (as `kill %1` or Ctrl-C would do)
//!   and must end within [`STOP_TIMEOUT`] with 0 or 130;
//! * under their own iceoryx2 isolation tag ([`Isolated`]: own root, own
//!   swarm names, its files and swarm locks removed at the end); every
//!   process carrying the tag in its environment must be gone within
//!   [`LEFTOVER_TIMEOUT`] of its block's end (leftovers are killed and fail
//!   the test).

use bycoms_protocol::bus::ipc::root::{Isolated, ISOLATION_ENV};
use bycoms_runtime::child::{wait_or_kill, Kill};
use nix::sys::signal::{killpg, Signal};
use nix::unistd::Pid;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// The word of a code block's info string that marks it runnable.
const MARKER: &str = "runnable";
/// The workspace binaries a README command may name.
const BINARIES: [&str; 4] = ["orchestrator", "sim-agent", "gateway", "natnet-serve"];
/// Longest one command may take.
const COMMAND_TIMEOUT: Duration = Duration::from_secs(60);
/// Longest a background command may take to end after SIGINT.
const STOP_TIMEOUT: Duration = Duration::from_secs(15);
/// Longest a process a block started may outlive the block.
const LEFTOVER_TIMEOUT: Duration = Duration::from_secs(10);

/// One command of a runnable block.
#[derive(Debug, Clone, PartialEq)]
struct Cmd {
    /// README.md's line number (1-based) where the command starts.
    line: usize,
    /// The command as written (continuations joined, comment removed).
    text: String,
    /// It ends with `&`: runs while the block's other commands run.
    background: bool,
}

/// A runnable code block: its opening line and its commands.
#[derive(Debug)]
struct Block {
    line: usize,
    commands: Vec<Cmd>,
}

/// `line` without a shell comment: from an unquoted `#` at the start or
/// after white space.
fn strip_comment(line: &str) -> &str {
    let (mut single, mut double, mut prev_space) = (false, false, true);
    for (i, c) in line.char_indices() {
        match c {
            '\'' if !double => single = !single,
            '"' if !single => double = !double,
            '#' if !single && !double && prev_space => return &line[..i],
            _ => {}
        }
        prev_space = c.is_whitespace();
    }
    line
}

/// The runnable blocks of a Markdown text: fences of three backticks whose
/// info string has the word [`MARKER`].
fn runnable_blocks(markdown: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    // The block being read: `Some(runnable)` inside a fence.
    let mut inside: Option<bool> = None;
    let mut pending: Option<(usize, String)> = None;
    for (i, line) in markdown.lines().enumerate() {
        let n = i + 1;
        if let Some(info) = line.trim_start().strip_prefix("```") {
            match inside {
                None => {
                    let runnable = info.split_whitespace().any(|w| w == MARKER);
                    if runnable {
                        blocks.push(Block { line: n, commands: Vec::new() });
                    }
                    inside = Some(runnable);
                }
                Some(_) => {
                    assert!(pending.is_none(), "README.md:{n}: a block ends inside a `\\` continuation");
                    inside = None;
                }
            }
            continue;
        }
        if inside != Some(true) {
            continue;
        }
        let (start, mut text) = pending.take().unwrap_or((n, String::new()));
        let code = strip_comment(line).trim_end();
        if let Some(cont) = code.strip_suffix('\\') {
            text.push_str(cont);
            text.push(' ');
            pending = Some((start, text));
            continue;
        }
        text.push_str(code);
        let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
        if text.is_empty() {
            continue;
        }
        let (text, background) = match text.strip_suffix('&') {
            Some(rest) if !rest.ends_with('&') => (rest.trim_end().to_string(), true),
            _ => (text, false),
        };
        blocks.last_mut().expect("inside a block").commands.push(Cmd { line: start, text, background });
    }
    assert!(inside.is_none(), "README.md: a code block is not closed");
    blocks
}

/// The command as run here: `cargo run … --bin NAME --` and
/// `target/{release,debug}/NAME` become `NAME`; any other cargo command is
/// refused (a runnable block builds nothing).
fn local(command: &str) -> Result<String, String> {
    let mut text = command.to_string();
    if let Some(rest) = text.strip_prefix("cargo run ") {
        let (flags, args) = rest.split_once(" -- ").map_or((rest, ""), |(f, a)| (f, a));
        let mut words = flags.split_whitespace();
        let mut name = None;
        while let Some(w) = words.next() {
            match w {
                "--release" => {}
                "-p" | "--package" => {
                    words.next();
                }
                "--bin" => name = words.next(),
                other => return Err(format!("`cargo run` with `{other}`: not runnable here")),
            }
        }
        let name = name.ok_or("`cargo run` without `--bin NAME`")?;
        text = format!("{name} {args}").trim_end().to_string();
    }
    let first = text.split_whitespace().next().unwrap_or("");
    if first == "cargo" {
        return Err("a runnable block runs no cargo command but `cargo run --bin NAME`".into());
    }
    for profile in ["target/release/", "target/debug/"] {
        text = text.replace(profile, "");
    }
    Ok(text)
}

/// Every process (but this one) whose environment has `ISOLATION_ENV=tag`.
fn processes_of(tag: &str) -> Vec<u32> {
    let needle = format!("{ISOLATION_ENV}={tag}");
    let me = std::process::id();
    let Ok(dir) = std::fs::read_dir("/proc") else { return Vec::new() };
    dir.flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
        .filter(|&pid| pid != me && !bycoms_tests::is_zombie(pid))
        .filter(|pid| {
            std::fs::read(format!("/proc/{pid}/environ"))
                .is_ok_and(|env| env.split(|&b| b == 0).any(|v| v == needle.as_bytes()))
        })
        .collect()
}

/// A started command: its process group is killed on drop.
struct Running {
    child: Child,
    cmd: Cmd,
    local: String,
    stderr: PathBuf,
    started: Instant,
}

impl Running {
    fn start(cmd: &Cmd, local: String, dir: &Path, path: &str, tag: &str, n: usize) -> Running {
        let stdout = dir.join(format!(".out-{n}"));
        let stderr = dir.join(format!(".err-{n}"));
        let file = |p: &Path| std::fs::File::create(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        // `bash` stays the parent: a background command gets SIGINT with its
        // whole group, and bash ends with what it ran.
        let script = format!("set -eo pipefail; {local}");
        let child = Command::new("bash")
            .arg("-c")
            .arg(script)
            .current_dir(dir)
            .env("PATH", path)
            .env(ISOLATION_ENV, tag)
            .env_remove("BYCOMS_SIM_AGENT")
            .env_remove("BYCOMS_LOG_FORMAT")
            .stdin(Stdio::null())
            .stdout(file(&stdout))
            .stderr(file(&stderr))
            .process_group(0)
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start bash: {e}"));
        Running { child, cmd: cmd.clone(), local, stderr, started: Instant::now() }
    }

    fn group(&self) -> Pid {
        Pid::from_raw(self.child.id() as i32)
    }

    /// Waits up to `timeout` for the command to end; kills its group after.
    fn wait(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let waited = wait_or_kill(&mut self.child, timeout, Kill::Group).expect("wait");
        waited.in_time.then_some(waited.status)
    }

    /// What went wrong, for a failure message.
    fn failure(&self, what: &str) -> String {
        let err = std::fs::read_to_string(&self.stderr).unwrap_or_default();
        let lines: Vec<&str> = err.lines().collect();
        let tail = lines[lines.len().saturating_sub(30)..].join("\n");
        format!(
            "README.md:{} `{}` (run as `{}`) {what}; stderr:\n{tail}",
            self.cmd.line, self.cmd.text, self.local
        )
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if self.child.try_wait().ok().flatten().is_none() {
            let _ = killpg(self.group(), Signal::SIGKILL);
            let _ = self.child.wait();
        }
    }
}

/// A status for the log: `exit status: 0`, or `killed` after a timeout.
fn shown(status: Option<ExitStatus>) -> String {
    status.map_or_else(|| "killed".to_string(), |s| s.to_string())
}

/// Copies directory `from` to `to`, recursively.
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("create dir");
    for entry in std::fs::read_dir(from).expect("read dir").flatten() {
        let target = to.join(entry.file_name());
        if entry.path().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).expect("copy file");
        }
    }
}

/// Runs one block in a fresh directory; returns its failures.
fn run_block(block: &Block, root: &Path, bin_dir: &Path, tag: &str) -> Vec<String> {
    let dir = tempfile::tempdir().expect("temp dir");
    copy_dir(&root.join("deploy"), &dir.path().join("deploy"));
    let path = format!("{}:{}", bin_dir.display(), std::env::var("PATH").unwrap_or_default());
    let mut failures = Vec::new();
    let mut background = Vec::new();
    for (n, cmd) in block.commands.iter().enumerate() {
        let local = match local(&cmd.text) {
            Ok(l) => l,
            Err(e) => {
                failures.push(format!("README.md:{} `{}`: {e}", cmd.line, cmd.text));
                continue;
            }
        };
        let mut running = Running::start(cmd, local, dir.path(), &path, tag, n);
        if cmd.background {
            background.push(running);
            continue;
        }
        let status = running.wait(COMMAND_TIMEOUT);
        eprintln!(
            "README.md:{} `{}`: {} in {:.1?}",
            cmd.line,
            cmd.text,
            shown(status),
            running.started.elapsed()
        );
        match status {
            None => failures.push(running.failure(&format!("did not end within {COMMAND_TIMEOUT:?}"))),
            Some(s) if !s.success() => failures.push(running.failure(&format!("exited with {s}"))),
            Some(_) => {}
        }
    }
    for mut running in background {
        let ended_early = running.child.try_wait().expect("try_wait");
        if ended_early.is_none() {
            let _ = killpg(running.group(), Signal::SIGINT);
        }
        let status = ended_early.or_else(|| running.wait(STOP_TIMEOUT));
        eprintln!(
            "README.md:{} `{} &`: {} in {:.1?}",
            running.cmd.line,
            running.cmd.text,
            shown(status),
            running.started.elapsed()
        );
        match (ended_early, status) {
            (_, None) => {
                failures.push(running.failure(&format!("did not end within {STOP_TIMEOUT:?} of SIGINT")));
            }
            (Some(s), _) if !s.success() => failures.push(running.failure(&format!("ended early with {s}"))),
            (None, Some(s)) if !(s.success() || s.code() == Some(130)) => {
                failures.push(running.failure(&format!("ended on SIGINT with {s} (not 0 or 130)")));
            }
            _ => {}
        }
    }
    let left = bycoms_tests::wait_for(LEFTOVER_TIMEOUT, || {
        let left = processes_of(tag);
        left.is_empty().then_some(())
    });
    if left.is_none() {
        let pids = processes_of(tag);
        for &pid in &pids {
            bycoms_tests::signal(pid, Signal::SIGKILL);
        }
        failures.push(format!(
            "README.md:{}: processes left {LEFTOVER_TIMEOUT:?} after the block ended (killed): {pids:?}",
            block.line
        ));
    }
    failures
}

/// Removes the swarm lock files of isolation tag `tag` on drop: a launch
/// removes its own when it ends, not one killed after a timeout.
struct LockFiles<'a>(&'a str);

impl Drop for LockFiles<'_> {
    fn drop(&mut self) {
        use bycoms_launch::swarm_lock::{lock_dir, lock_name};
        let prefix = lock_name(Some(self.0), "");
        let prefix = prefix.trim_end_matches(".lock");
        let Ok(dir) = std::fs::read_dir(lock_dir()) else { return };
        for entry in dir.flatten() {
            if entry.file_name().to_string_lossy().starts_with(prefix) {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the repository").to_path_buf()
}

#[test]
fn every_runnable_command_of_the_readme_succeeds() {
    let root = root();
    let readme = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    let blocks = runnable_blocks(&readme);
    let bins = tempfile::tempdir().expect("temp dir");
    for name in BINARIES {
        std::os::unix::fs::symlink(bycoms_tests::bin(name), bins.path().join(name)).expect("symlink");
    }
    let isolated = Isolated::new("readme");
    let _locks = LockFiles(isolated.tag());
    let started = Instant::now();
    let mut failures = Vec::new();
    for block in &blocks {
        failures.extend(run_block(block, &root, bins.path(), isolated.tag()));
    }
    eprintln!("{} runnable blocks of README.md in {:.1?}", blocks.len(), started.elapsed());
    assert!(failures.is_empty(), "README commands failed:\n\n{}", failures.join("\n\n"));
}

/// The commands the README must keep runnable (issue 15): its main job,
/// `launch`, `simulate`, a sweep, a launch over zenoh and the emulated lab.
#[test]
fn the_readme_marks_its_main_commands_runnable() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README.md");
    let first_fence = readme.lines().find(|l| l.starts_with("```")).expect("a code block");
    assert!(
        first_fence.split_whitespace().any(|w| w == MARKER),
        "the README's first code block (its main job) is not marked runnable: {first_fence}"
    );
    let commands: Vec<String> = runnable_blocks(&readme)
        .into_iter()
        .flat_map(|b| b.commands)
        .map(|c| local(&c.text).unwrap_or_else(|e| panic!("README.md:{}: {e}", c.line)))
        .collect();
    for wanted in [
        "orchestrator simulate",
        "orchestrator launch",
        "orchestrator sweep",
        "orchestrator launch --transport zenoh",
        "sim-agent lab",
    ] {
        assert!(
            commands.iter().any(|c| c.starts_with(wanted)),
            "no runnable README command starts with `{wanted}`: {commands:#?}"
        );
    }
}

/// How many lines a newcomer sees first (issue 31: the README's first
/// screen holds what it is, the main job and the test command).
const FIRST_SCREEN: usize = 40;

/// The README's first screen holds the command of its main job (its first
/// runnable command: the product card's `launch`, one process per robot),
/// `simulate` beside it, and the test command, and `.ci/run` runs exactly
/// that test command: a newcomer never has to dig for any of them.
#[test]
fn the_readmes_first_screen_holds_the_main_job_and_the_test_command() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README.md");
    let screen: String = readme.lines().take(FIRST_SCREEN).collect::<Vec<_>>().join("\n");
    let first: Vec<String> = runnable_blocks(&screen)
        .into_iter()
        .flat_map(|b| b.commands)
        .map(|c| local(&c.text).expect("a command that runs here"))
        .collect();
    assert!(
        first.first().is_some_and(|c| c.starts_with("orchestrator launch")),
        "the README's first runnable command is not `launch` (the main job): {first:?}"
    );
    assert!(
        first.iter().any(|c| c.starts_with("orchestrator simulate")),
        "no runnable `simulate` command within the README's first {FIRST_SCREEN} lines: {first:?}"
    );
    let test_command =
        screen.lines().map(str::trim).find(|l| l.starts_with("cargo test")).unwrap_or_else(|| {
            panic!("no `cargo test` command within the README's first {FIRST_SCREEN} lines")
        });
    let ci = std::fs::read_to_string(root().join(".ci/run")).expect(".ci/run");
    let ci_tests: Vec<&str> = ci.lines().map(str::trim).filter(|l| l.starts_with("cargo test")).collect();
    assert_eq!(ci_tests, [test_command], ".ci/run must run exactly the README's test command");
}

#[test]
fn runnable_blocks_are_parsed_as_the_readme_says() {
    let text = "```sh\nnot run\n```\n\n```sh runnable\n\
                a --x 1   # a comment\n\
                \n\
                # only a comment\n\
                b --y \\\n    --z '#not a comment' &\n\
                c && d\n\
                ```\n";
    let blocks = runnable_blocks(text);
    assert_eq!(blocks.len(), 1);
    assert_eq!(blocks[0].line, 5);
    let cmd = |line, text: &str, background| Cmd { line, text: text.to_string(), background };
    assert_eq!(
        blocks[0].commands,
        [cmd(6, "a --x 1", false), cmd(9, "b --y --z '#not a comment'", true), cmd(11, "c && d", false)]
    );
    assert_eq!(
        local("cargo run --release --bin orchestrator -- simulate").as_deref(),
        Ok("orchestrator simulate")
    );
    assert_eq!(
        local("cargo run -p bycoms-natnet-server --bin natnet-serve -- --x 1").as_deref(),
        Ok("natnet-serve --x 1")
    );
    assert_eq!(
        local("/usr/bin/time -v target/release/orchestrator sweep").as_deref(),
        Ok("/usr/bin/time -v orchestrator sweep")
    );
    assert!(local("cargo build --bins").is_err());
    assert!(local("cargo test -p x").is_err());
}
