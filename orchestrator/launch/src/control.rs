//! A running launch answers questions and takes a stop from outside:
//! `orchestrator status` and `orchestrator stop` (issue 34), the ROS 2 stop
//! service (issue 32) feeding the same stop, and `orchestrator revoke`
//! (and `certs --revoke`) taking a robot's voice away.
//!
//! Why not a bus message: a bus message holds at most 64 bytes, and a
//! status (every robot's pose) or a stop with who and why does not fit;
//! an answer goes to one asker, not to the swarm's watchers. So:
//!
//! * on this host, a Unix socket beside the swarm's lock file
//!   (`/dev/shm/bycoms-swarm.[<tag>.]<swarm>.sock`, keyed like the lock
//!   and the bus, `swarm_lock`): one JSON line asked, one JSON line
//!   answered. `orchestrator status` finds every launch of this host (and
//!   isolation tag) by its lock files; a lock file no process holds, or a
//!   socket that refuses, is a launch that died;
//! * over zenoh (`--transport zenoh`), a queryable on
//!   `bycoms/<swarm>/control`: the query's payload is the same JSON, the
//!   reply's payload the same answer (PROTOCOL.md, "Control").
//!
//! Both servers only carry requests to the driver ([`Control::take`]),
//! which answers from its own thread between two steps of the core: the
//! core stays the one owner of the launch's state, and what `status`
//! shows is a projection of it (`orchestrator/launch/src/status.rs`).

use super::status::LaunchStatus;
use super::swarm_lock::{lock_dir, lock_name};
use anyhow::{Context, Result};
use bycoms_protocol::bus::zenoh::ZenohBus;
use serde::{Deserialize, Serialize};
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::Arc;
use std::time::Duration;
use zenoh::Wait as _;

/// The longest a question or an answer may be on the socket (a status of
/// a thousand robots fits).
const MAX_LINE: u64 = 1 << 20;

/// How long a server waits for an asker's question.
const ASK_TIMEOUT: Duration = Duration::from_secs(2);

/// The longest `--why` (the core's rule, [`crate::core::MAX_WHY_CHARS`]).
pub use crate::core::{shown, MAX_WHY_CHARS};

/// `--why` within [`MAX_WHY_CHARS`], or the usage error's words naming the
/// flag and the length given.
pub fn check_why(why: &str) -> Result<(), String> {
    let chars = why.chars().count();
    if chars > MAX_WHY_CHARS {
        return Err(format!("--why takes at most {MAX_WHY_CHARS} characters, got {chars}"));
    }
    Ok(())
}

/// What an asker asks a launch.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ask {
    /// End the launch: gracefully (as Ctrl-C), or `now` (every robot told
    /// `Stop` at once first).
    Stop {
        /// Every robot told `Stop` at once.
        now: bool,
        /// Who asks (the stop command says its user, host and pid).
        who: String,
        /// Why (may be empty).
        why: String,
    },
    /// Where the launch stands.
    Status,
    /// Take robot `robot`'s voice away (`orchestrator revoke`, `certs
    /// --revoke`): told `Stop`, its agent refused and its reports dropped
    /// from then on (`orchestrator/launch-core/src/revoke.rs`).
    Revoke {
        /// The robot.
        robot: u32,
        /// Who asks.
        who: String,
        /// Why (may be empty).
        why: String,
        /// Only a launch whose zenoh config is this file (a lab's
        /// `orchestrator.json5`, as `certs --revoke` asks) takes it; any
        /// other refuses.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        lab: Option<PathBuf>,
    },
}

/// What a launch answers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Answer {
    /// The launch stops; its summary follows where the launch writes it.
    /// Given once the launch has ended: with `now`, after every robot told
    /// `Stop` answered it or the stop's wait was over.
    Stopping {
        /// The swarm.
        swarm: String,
        /// Whether every robot was told `Stop` at once.
        now: bool,
        /// Robots told `Stop` (`now`).
        #[serde(default)]
        told: u32,
        /// Robots that answered that they stopped.
        #[serde(default)]
        answered: u32,
        /// The last answer, µs after the stop was taken in.
        #[serde(default)]
        slowest_us: Option<u64>,
        /// Where the launch's recording will be, if it records.
        recording: Option<String>,
        /// The launch's pid, whose end the asker may await.
        pid: u32,
    },
    /// Where the launch stands.
    Status(Box<LaunchStatus>),
    /// The robot's voice is taken away (its reports dropped from now on).
    Revoked {
        /// The swarm.
        swarm: String,
        /// The robot.
        robot: u32,
        /// Its agent ran and was told `Stop` now.
        told: bool,
        /// It had been revoked before (this ask changed nothing).
        already: bool,
        /// The launch's pid.
        pid: u32,
    },
    /// The launch does not run with the lab's zenoh config a revocation
    /// named: not that lab's launch (nothing changed).
    OtherLab,
    /// The question could not be understood, and why.
    Refused(String),
}

/// How a request is answered (by the server it came through).
pub type Reply = Box<dyn FnOnce(&Answer) + Send>;

/// A question that came in, and how to answer it.
pub struct Request {
    /// The question.
    pub ask: Ask,
    /// Its answer goes here.
    pub reply: Reply,
}

/// The socket of `swarm`'s launch on this host (isolation tag `tag`).
pub fn socket_path(tag: Option<&str>, swarm: &str) -> PathBuf {
    let lock = lock_name(tag, swarm);
    lock_dir().join(format!("{}.sock", lock.trim_end_matches(".lock")))
}

/// Whether a launch whose zenoh config is `config` is the lab `lab`
/// names (the same file once links and relative parts are resolved; its
/// inode changes when `certs --revoke` rewrites it).
pub fn same_lab(lab: &Path, config: Option<&Path>) -> bool {
    let resolved = |p: &Path| std::fs::canonicalize(p).ok();
    config.is_some_and(|c| resolved(c).is_some_and(|c| Some(c) == resolved(lab)))
}

/// `bycoms/<swarm>/control`, the launch's queryable over zenoh.
pub fn control_key(swarm: &str) -> String {
    format!("bycoms/{swarm}/control")
}

/// A launch's control servers; dropping it closes them.
pub struct Control {
    requests: Receiver<Request>,
    /// For other ways in (the ROS 2 stop service, `ros2_stop.rs`).
    sender: Sender<Request>,
    socket: Option<SocketServer>,
    _queryable: Option<zenoh::query::Queryable<()>>,
}

impl Control {
    /// Serves `swarm`'s control on this host's socket and, over zenoh, as
    /// a queryable.
    pub fn serve(swarm: &str, zenoh: Option<&ZenohBus>) -> Result<Self> {
        let (tx, requests) = channel();
        let tag = bycoms_protocol::bus::ipc::root::tag_from_env();
        // Without its socket (a path past the OS's 108 bytes, a read-only
        // directory) the launch still runs: it says so, and only this
        // host's `status` and `stop` cannot reach it.
        let socket = match SocketServer::open(&socket_path(tag.as_deref(), swarm), tx.clone()) {
            Ok(socket) => Some(socket),
            Err(e) => {
                tracing::warn!(
                    "orchestrator status and stop cannot reach this launch: {}",
                    bycoms_runtime::exit::message(&e)
                );
                None
            }
        };
        let queryable = zenoh.map(|z| serve_zenoh(z, swarm, tx.clone())).transpose()?;
        Ok(Self { requests, sender: tx, socket, _queryable: queryable })
    }

    /// Where another server hands its requests in.
    pub fn sender(&self) -> Sender<Request> {
        self.sender.clone()
    }

    /// The requests that came in since the last call.
    pub fn take(&self) -> Vec<Request> {
        self.requests.try_iter().collect()
    }
}

impl Drop for Control {
    fn drop(&mut self) {
        drop(self.socket.take());
    }
}

/// The socket's accepting thread; dropping it ends the thread and removes
/// the socket.
struct SocketServer {
    path: PathBuf,
    done: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl SocketServer {
    fn open(path: &Path, tx: Sender<Request>) -> Result<Self> {
        // The swarm's lock is held: a socket there is a dead launch's.
        let _ = std::fs::remove_file(path);
        let listener = UnixListener::bind(path)
            .with_context(|| format!("cannot serve control on {}", path.display()))?;
        let done = Arc::new(AtomicBool::new(false));
        let stop = done.clone();
        let thread = std::thread::Builder::new()
            .name("bycoms-control".into())
            .spawn(move || {
                let reading = Arc::new(AtomicUsize::new(0));
                for stream in listener.incoming() {
                    if stop.load(Ordering::SeqCst) {
                        return;
                    }
                    if let Ok(stream) = stream {
                        read_aside(stream, &tx, &reading);
                    }
                }
            })
            .context("cannot start the control thread")?;
        Ok(Self { path: path.to_path_buf(), done, thread: Some(thread) })
    }
}

impl Drop for SocketServer {
    fn drop(&mut self) {
        self.done.store(true, Ordering::SeqCst);
        // Wakes the accepting thread, which sees `done`.
        let _ = UnixStream::connect(&self.path);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Questions read at once at most, each on a thread of its own: an asker
/// that connects and says nothing (for up to [`ASK_TIMEOUT`]) must not
/// hold up a `stop` behind it. Past this many, a question is read on the
/// accepting thread.
const READING_AT_ONCE: usize = 16;

/// Reads the question of `stream` on a thread of its own (see
/// [`READING_AT_ONCE`]).
fn read_aside(stream: UnixStream, tx: &Sender<Request>, reading: &Arc<AtomicUsize>) {
    if reading.fetch_add(1, Ordering::SeqCst) >= READING_AT_ONCE {
        reading.fetch_sub(1, Ordering::SeqCst);
        return take_question(stream, tx);
    }
    let (tx, count) = (tx.clone(), reading.clone());
    let spawned = std::thread::Builder::new().name("bycoms-control-ask".into()).spawn(move || {
        take_question(stream, &tx);
        count.fetch_sub(1, Ordering::SeqCst);
    });
    if let Err(e) = spawned {
        reading.fetch_sub(1, Ordering::SeqCst);
        tracing::warn!(error = %e, "a control question was not read: no thread for it");
    }
}

/// Reads one question from `stream` and hands it on with its reply.
fn take_question(stream: UnixStream, tx: &Sender<Request>) {
    let _ = stream.set_read_timeout(Some(ASK_TIMEOUT));
    let mut line = String::new();
    let Ok(read) = stream.try_clone() else { return };
    if BufReader::new(read.take(MAX_LINE)).read_line(&mut line).is_err() {
        return;
    }
    let mut out = stream;
    let reply: Reply = Box::new(move |answer: &Answer| {
        if let Ok(mut text) = serde_json::to_string(answer) {
            text.push('\n');
            let _ = out.write_all(text.as_bytes());
        }
    });
    match serde_json::from_str::<Ask>(line.trim()) {
        Ok(ask) => {
            let _ = tx.send(Request { ask, reply });
        }
        Err(e) => reply(&Answer::Refused(format!("not a question this launch understands: {e}"))),
    }
}

use std::io::Read as _;

/// The zenoh queryable on [`control_key`].
fn serve_zenoh(z: &ZenohBus, swarm: &str, tx: Sender<Request>) -> Result<zenoh::query::Queryable<()>> {
    let key = control_key(swarm);
    let queryable = z
        .session()
        .declare_queryable(key.clone())
        .callback(move |query: zenoh::query::Query| {
            let asked = query.payload().map(|p| p.to_bytes().to_vec()).unwrap_or_default();
            let ask = serde_json::from_slice::<Ask>(&asked);
            let reply: Reply = Box::new(move |answer: &Answer| {
                let text = serde_json::to_vec(answer).unwrap_or_default();
                if let Err(e) = query.reply(query.key_expr().clone(), text).wait() {
                    tracing::debug!(error = %e, "a control reply was not sent");
                }
            });
            match ask {
                Ok(ask) => {
                    let _ = tx.send(Request { ask, reply });
                }
                Err(e) => reply(&Answer::Refused(format!("not a question this launch understands: {e}"))),
            }
        })
        .wait()
        .map_err(|e| anyhow::anyhow!("cannot declare the control queryable {key}: {e}"))?;
    tracing::debug!(key, "zenoh: the launch takes status and stop questions");
    Ok(queryable)
}

// ---- the asking side ---------------------------------------------------

/// A launch of this host, as its lock file shows it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Local {
    /// The swarm.
    pub swarm: String,
    /// Its launch runs (its lock is held).
    pub running: bool,
    /// Its control socket.
    pub socket: PathBuf,
}

/// Every launch this host's lock files show, for this isolation tag, in
/// swarm order.
pub fn local_launches() -> Vec<Local> {
    let tag = bycoms_protocol::bus::ipc::root::tag_from_env();
    let dir = lock_dir();
    let prefix = match &tag {
        Some(t) => format!("bycoms-swarm.{t}."),
        None => "bycoms-swarm.".into(),
    };
    let Ok(entries) = std::fs::read_dir(&dir) else { return Vec::new() };
    let mut found: Vec<Local> = entries
        .flatten()
        .filter_map(|e| e.file_name().to_str().map(str::to_owned))
        .filter_map(|name| {
            let swarm = name.strip_prefix(&prefix)?.strip_suffix(".lock")?;
            // Without a tag, names with one (`tag.swarm`) are another bus's.
            if swarm.contains('.') {
                return None;
            }
            let running = super::swarm_lock::is_held(&dir.join(&name));
            Some(Local { swarm: swarm.into(), running, socket: socket_path(tag.as_deref(), swarm) })
        })
        .collect();
    found.sort_by(|a, b| a.swarm.cmp(&b.swarm));
    found
}

/// Asks the launch behind `socket` and waits up to `timeout` for its answer.
pub fn ask_socket(socket: &Path, ask: &Ask, timeout: Duration) -> Result<Answer> {
    let mut stream = UnixStream::connect(socket)
        .with_context(|| format!("no launch answers on {} (it has ended)", socket.display()))?;
    stream.set_read_timeout(Some(timeout))?;
    let mut text = serde_json::to_string(ask)?;
    text.push('\n');
    stream.write_all(text.as_bytes())?;
    let mut line = String::new();
    BufReader::new(stream.take(MAX_LINE))
        .read_line(&mut line)
        .with_context(|| format!("the launch behind {} did not answer in time", socket.display()))?;
    if line.trim().is_empty() {
        anyhow::bail!("the launch behind {} closed without an answer (it is ending)", socket.display());
    }
    Ok(serde_json::from_str(line.trim())?)
}

/// Asks every launch reachable over `zenoh` (of `swarm`, or all), waiting
/// up to `timeout`: each answer with the key it came from.
pub fn ask_zenoh(
    zenoh: &ZenohBus,
    swarm: Option<&str>,
    ask: &Ask,
    timeout: Duration,
) -> Result<Vec<(String, Answer)>> {
    let key = control_key(swarm.unwrap_or("*"));
    let replies = zenoh
        .session()
        .get(key.clone())
        .payload(serde_json::to_vec(ask)?)
        .timeout(timeout)
        .wait()
        .map_err(|e| anyhow::anyhow!("cannot ask {key}: {e}"))?;
    let mut answers = Vec::new();
    while let Ok(reply) = replies.recv() {
        match reply.into_result() {
            Ok(sample) => {
                let from = sample.key_expr().as_str().to_owned();
                let answer = serde_json::from_slice(&sample.payload().to_bytes())
                    .with_context(|| format!("a reply from {from} that is no answer"))?;
                answers.push((from, answer));
            }
            Err(e) => {
                let words = String::from_utf8_lossy(&e.payload().to_bytes()).into_owned();
                answers.push((key.clone(), Answer::Refused(words)));
            }
        }
    }
    Ok(answers)
}

/// What one launch said, or why it said nothing.
#[derive(Debug)]
pub struct Reached {
    /// The swarm.
    pub swarm: String,
    /// Its answer, or why there is none (its launch is gone).
    pub answer: std::result::Result<Answer, String>,
}

/// Where the asker looks for launches.
pub enum Asker {
    /// This host's launches (their sockets).
    Local,
    /// Launches reachable over this zenoh session.
    Zenoh(ZenohBus),
}

/// How long an asker waits for answers.
pub const ANSWER_TIMEOUT: Duration = Duration::from_secs(3);

impl Asker {
    /// Opens a zenoh client session to `endpoint` (with the zenoh config
    /// `config`, for certificates), or looks on this host without one.
    pub fn open(connect: Option<&str>, config: Option<PathBuf>) -> Result<Self> {
        let Some(endpoint) = connect else { return Ok(Self::Local) };
        if config.is_none() && bycoms_protocol::bus::zenoh::is_secured(endpoint) {
            return Err(bycoms_runtime::exit::usage(format!(
                "--connect {endpoint}: a secured endpoint needs the lab's certificates: give \
                 --zenoh-config the lab's orchestrator.json5 (in the directory `orchestrator certs` wrote)"
            )));
        }
        let cfg = bycoms_runtime::zenoh_config(
            bycoms_protocol::bus::zenoh::Mode::Client,
            Vec::new(),
            vec![endpoint.to_owned()],
            config,
        );
        let bus = ZenohBus::open(cfg).with_context(|| format!("cannot reach {endpoint} over zenoh"))?;
        Ok(Self::Zenoh(bus))
    }

    /// Asks every launch it can see (of `swarm`, or all): their answers,
    /// and the launches that are gone, in swarm order.
    pub fn ask(&self, swarm: Option<&str>, ask: &Ask) -> Result<Vec<Reached>> {
        let mut reached = match self {
            Self::Local => local_launches()
                .into_iter()
                .filter(|l| swarm.is_none_or(|s| s == l.swarm))
                .map(|l| {
                    let answer = if l.running {
                        ask_socket(&l.socket, ask, ANSWER_TIMEOUT)
                            .map_err(|e| bycoms_runtime::exit::message(&e))
                    } else {
                        Err("gone: its launch ended without removing its lock (killed)".into())
                    };
                    Reached { swarm: l.swarm, answer }
                })
                .collect(),
            Self::Zenoh(z) => ask_zenoh(z, swarm, ask, ANSWER_TIMEOUT)?
                .into_iter()
                .map(|(key, answer)| {
                    let swarm = key.trim_start_matches("bycoms/").trim_end_matches("/control").to_owned();
                    Reached { swarm, answer: Ok(answer) }
                })
                .collect::<Vec<_>>(),
        };
        reached.sort_by(|a, b| a.swarm.cmp(&b.swarm));
        Ok(reached)
    }

    /// Why nothing may have answered although launches run, when it can
    /// tell: over zenoh with a config whose own certificate is not the
    /// orchestrator's (a robot's), the lab's ACL lets it ask no launch.
    pub fn silenced(&self) -> Option<String> {
        use bycoms_protocol::bus::zenoh::certs;
        let Self::Zenoh(z) = self else { return None };
        let file = z.config().base_config.as_ref()?;
        let zenoh = z.config().to_zenoh().ok()?;
        let own = certs::named(&zenoh).into_iter().next()?;
        let der = certs::read_der(&own).ok()?;
        let name = certs::name_of(&certs::parse(&der, &own).ok()?);
        (name != certs::common_name(bycoms_protocol::naming::Member::Orchestrator)).then(|| {
            format!(
                "nothing answered: {} (--zenoh-config) holds {name:?}'s certificate, and the lab's ACL lets \
                 only the orchestrator's ask a launch: give --zenoh-config the lab's orchestrator.json5",
                file.display()
            )
        })
    }

    /// Where it looks, in words (for "no launch runs …").
    pub fn place(&self) -> String {
        match self {
            Self::Local => match bycoms_protocol::bus::ipc::root::tag_from_env() {
                Some(tag) => format!("on this host (isolation tag {tag})"),
                None => "on this host".into(),
            },
            Self::Zenoh(z) => format!("over zenoh at {}", z.config().connect.join(", ")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An asker that connects and says nothing does not hold up the next
    /// one: its question is answered while the first still waits.
    #[test]
    fn a_silent_asker_does_not_hold_up_the_next() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let path = dir.path().join("control.sock");
        let (tx, requests) = channel();
        let _server = SocketServer::open(&path, tx).expect("serve");
        let _silent = UnixStream::connect(&path).expect("a silent asker connects");
        let asking = {
            let path = path.clone();
            std::thread::spawn(move || ask_socket(&path, &Ask::Status, Duration::from_secs(5)))
        };
        // The question arrives while the silent asker still holds its
        // connection (its read waits up to 2 s).
        let Request { ask, reply } = requests
            .recv_timeout(Duration::from_millis(1500))
            .expect("the second question came before the first asker's read timed out");
        assert_eq!(ask, Ask::Status);
        reply(&Answer::Refused("a test".into()));
        let answer = asking.join().expect("asker thread").expect("answered");
        assert_eq!(answer, Answer::Refused("a test".into()));
    }
}
