//! Agent processes started from a thread with a descriptor table of its
//! own, which holds only the standard streams.
//!
//! Why: the orchestrator holds about 17 iceoryx2 files for every robot of
//! its launch (services, data segments, port tags, event sockets), and
//! iceoryx2 opens them without close-on-exec, so an agent started from the
//! launch's thread inherited all of them and closed them first thing
//! (`bycoms_runtime::inherited`): about 2 500 files per agent of a
//! 300-robot launch, 9 000 of a 1000-robot one. Each close of a real file
//! goes through the kernel's flush of it, and `perf` of `launch --robots
//! 300` on `bench crowd`'s terrain put 15 % of all the launch's CPU (its
//! orchestrator and agents) in those closes.
//!
//! How: the spawner thread unshares its descriptor table
//! (`unshare(CLONE_FILES)`: it gets a copy, the rest of the process keeps
//! the original) and closes everything above standard error in its copy,
//! once. Files the launch opens later go to the original table only, so a
//! child started from this thread inherits its standard streams and the
//! pipes made for it, nothing else. The pipes live in this thread's table,
//! so the child's standard input is written and its standard error tapped
//! ([`StderrTap`], whose reader threads share this table) from here; the
//! [`Child`] handed back holds no descriptor, only the pid (waited for and
//! killed by pid, from any thread). The thread lives as long as its
//! [`Spawner`]: an agent's parent-death signal (`bycoms_runtime::lifeline`)
//! follows the thread that started it, and [`super::spawned::Spawned`]
//! ends its children before its spawner.
//!
//! If the table cannot be unshared, children are started from the thread
//! as they were from the launch's (they inherit its files and close them).

use super::stderr_tap::StderrTap;
use std::io::Write;
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::thread::JoinHandle;

/// One process to start.
pub struct Request {
    /// The executable.
    pub program: PathBuf,
    /// Its arguments.
    pub args: Vec<String>,
    /// Written to its standard input, which is then closed.
    pub stdin_text: String,
    /// The name of the thread that taps its standard error.
    pub tap_name: String,
}

/// A started process: the child (no descriptor of it kept), the tap on its
/// standard error, and how writing its standard input went.
pub struct Spawn {
    /// The process.
    pub child: Child,
    /// Its standard error, passed through.
    pub tap: StderrTap,
    /// Writing its standard input (a child that died at once broke the pipe).
    pub written: std::io::Result<()>,
}

type Reply = std::io::Result<Spawn>;

/// The thread that starts processes.
pub struct Spawner {
    requests: Option<mpsc::Sender<(Request, mpsc::Sender<Reply>)>>,
    thread: Option<JoinHandle<()>>,
    own_table: bool,
}

impl Spawner {
    /// Starts the thread and gives it its own descriptor table.
    pub fn start() -> std::io::Result<Self> {
        let (requests, inbox) = mpsc::channel::<(Request, mpsc::Sender<Reply>)>();
        let (ready, own) = mpsc::channel();
        let thread = std::thread::Builder::new().name("spawner".into()).spawn(move || {
            let _ = ready.send(own_table());
            for (request, reply) in inbox {
                let _ = reply.send(spawn(request));
            }
        })?;
        let own_table =
            own.recv().map_err(|_| std::io::Error::other("the spawner thread ended at its start"))?;
        Ok(Self { requests: Some(requests), thread: Some(thread), own_table })
    }

    /// Whether its children inherit only their standard streams.
    pub fn own_table(&self) -> bool {
        self.own_table
    }

    /// Starts `request`'s process, in its own process group.
    pub fn spawn(&self, request: Request) -> Reply {
        let (reply, answer) = mpsc::channel();
        let gone = || std::io::Error::other("the spawner thread ended");
        self.requests.as_ref().ok_or_else(gone)?.send((request, reply)).map_err(|_| gone())?;
        answer.recv().map_err(|_| gone())?
    }
}

impl Drop for Spawner {
    fn drop(&mut self) {
        // The inbox closes: the thread's loop ends.
        self.requests = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// This thread's own copy of the descriptor table, emptied but for the
/// standard streams; false (and nothing closed) if it cannot have one.
fn own_table() -> bool {
    match nix::sched::unshare(nix::sched::CloneFlags::CLONE_FILES) {
        Ok(()) => {
            // Only this thread's copy: the launch's files stay open.
            let closed = bycoms_runtime::inherited::close_inherited_files();
            tracing::debug!(closed, "the spawner's descriptor table holds the standard streams only");
            true
        }
        Err(e) => {
            tracing::debug!("agents inherit the launch's files: cannot unshare the descriptor table: {e}");
            false
        }
    }
}

fn spawn(request: Request) -> Reply {
    let mut child = Command::new(&request.program)
        .args(&request.args)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .process_group(0)
        .spawn()?;
    // Taken here: their descriptors are in this thread's table.
    let stdin = child.stdin.take();
    let stderr = child.stderr.take().ok_or_else(|| std::io::Error::other("no stderr pipe"))?;
    let tap = StderrTap::start(stderr, request.tap_name)?;
    let written = match stdin {
        Some(mut stdin) => stdin.write_all(request.stdin_text.as_bytes()),
        None => Ok(()),
    };
    Ok(Spawn { child, tap, written })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::fd::AsRawFd;
    use std::time::Duration;

    /// What the descriptors of a shell started by `start` lead to, as it
    /// says them on its standard error (as an error line, which the tap
    /// keeps).
    fn files_of(start: impl FnOnce(Request) -> (Child, StderrTap)) -> Vec<String> {
        let list = r#"echo "ERROR $(for f in /proc/$$/fd/*; do readlink "$f"; done | tr '\n' '|')" >&2"#;
        let request = Request {
            program: "sh".into(),
            args: vec!["-c".into(), list.into()],
            stdin_text: String::new(),
            tap_name: "test-tap".into(),
        };
        let (mut child, tap) = start(request);
        assert!(child.wait().expect("wait").success());
        let said = tap.last_error(Duration::from_secs(10)).expect("the shell listed its descriptors");
        said.split('|').filter(|s| !s.is_empty()).map(str::to_owned).collect()
    }

    /// What this process's descriptor of `f` leads to.
    fn file_of(f: &std::fs::File) -> String {
        let link = std::fs::read_link(format!("/proc/self/fd/{}", f.as_raw_fd())).expect("readlink");
        link.to_string_lossy().into_owned()
    }

    /// Files the launch holds without close-on-exec (as iceoryx2 leaves
    /// them) reach a child started from the launch's thread, and not one
    /// started by the spawner, even files opened after the spawner started.
    #[test]
    fn a_child_of_the_spawner_inherits_only_its_standard_streams() {
        let inheritable = || {
            let f = tempfile::tempfile().expect("temp file");
            nix::fcntl::fcntl(&f, nix::fcntl::FcntlArg::F_SETFD(nix::fcntl::FdFlag::empty()))
                .expect("inheritable");
            f
        };
        let before = inheritable();
        let spawner = Spawner::start().expect("spawner");
        assert!(spawner.own_table(), "this machine can unshare a thread's descriptor table");
        let after = inheritable();
        let held = [file_of(&before), file_of(&after)];
        let direct = files_of(|r| {
            let mut child =
                Command::new(&r.program).args(&r.args).stderr(Stdio::piped()).spawn().expect("sh");
            let tap = StderrTap::start(child.stderr.take().expect("stderr"), r.tap_name).expect("tap");
            (child, tap)
        });
        assert!(held.iter().all(|f| direct.contains(f)), "the control inherits {held:?}: {direct:?}");
        let spawned = files_of(|r| {
            let s = spawner.spawn(r).expect("spawned");
            s.written.expect("stdin written");
            (s.child, s.tap)
        });
        assert!(held.iter().all(|f| !spawned.contains(f)), "{held:?} not inherited: {spawned:?}");
        // The launch's own files are still open.
        nix::fcntl::fcntl(&before, nix::fcntl::FcntlArg::F_GETFD).expect("still open");
    }
}
