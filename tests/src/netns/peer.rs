//! The test's side of a `netns-peer` process: start it inside a host's
//! namespace and read what it saw, line by line, while it runs.
//!
//! Why streaming (not the output at exit): the partition tests act on what
//! the peers report *now* (routes up, loss seen) and time it against their
//! own actions on the shared monotonic clock ([`mono_ns`]).

use super::Host;
use serde_json::Value;
use std::io::BufRead as _;
use std::path::Path;
use std::process::{Child, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// `CLOCK_MONOTONIC` now, in ns: the clock `netns-peer` stamps events with.
pub fn mono_ns() -> u128 {
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC)
        .map(|t| Duration::from(t).as_nanos())
        .unwrap_or(0)
}

/// One line printed by `netns-peer`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PeerEvent {
    /// Session open, token declared, watch running.
    Ready { mono_ns: u128 },
    /// A member's token appeared.
    Alive { member: String, mono_ns: u128 },
    /// A member's token disappeared.
    Lost { member: String, mono_ns: u128 },
    /// A counter arrived.
    Msg { seq: u64, mono_ns: u128 },
}

impl PeerEvent {
    fn parse(line: &str) -> Option<Self> {
        let v: Value = serde_json::from_str(line).ok()?;
        let mono_ns = v.get("mono_ns")?.as_u64()? as u128;
        let member = || v.get("member").and_then(Value::as_str).map(str::to_owned);
        Some(match v.get("event")?.as_str()? {
            "ready" => Self::Ready { mono_ns },
            "alive" => Self::Alive { member: member()?, mono_ns },
            "lost" => Self::Lost { member: member()?, mono_ns },
            "msg" => Self::Msg { seq: v.get("seq")?.as_u64()?, mono_ns },
            _ => return None,
        })
    }
}

/// A running `netns-peer`; killed and reaped on drop.
pub struct PeerProc {
    child: Child,
    events: mpsc::Receiver<PeerEvent>,
    /// Every event taken so far, in order (for failure messages).
    pub seen: Vec<PeerEvent>,
}

impl PeerProc {
    /// Starts `program` (the `netns-peer` binary) with `args` inside `host`.
    pub fn start(host: &Host, program: &Path, args: &[String]) -> Self {
        let mut child = host
            .command(program)
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {} in {}: {e}", program.display(), host.netns));
        let stdout = child.stdout.take().expect("piped stdout");
        let (tx, events) = mpsc::channel();
        std::thread::spawn(move || {
            for line in std::io::BufReader::new(stdout).lines().map_while(Result::ok) {
                match PeerEvent::parse(&line) {
                    Some(e) => {
                        if tx.send(e).is_err() {
                            break;
                        }
                    }
                    None => tracing::warn!("netns-peer printed an unknown line: {line}"),
                }
            }
        });
        Self { child, events, seen: Vec::new() }
    }

    /// The process id (that of the peer itself: `ip netns exec` execs it).
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Sends SIGKILL now.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
    }

    /// The first event (after those already taken) that `accept` returns
    /// `Some` for, waiting at most `timeout`.
    pub fn until<T>(
        &mut self,
        timeout: Duration,
        mut accept: impl FnMut(&PeerEvent) -> Option<T>,
    ) -> Option<T> {
        let deadline = Instant::now() + timeout;
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            let Ok(e) = self.events.recv_timeout(left) else { return None };
            self.seen.push(e.clone());
            if let Some(found) = accept(&e) {
                return Some(found);
            }
        }
        None
    }

    /// Every event that arrives within `window`.
    pub fn drain_for(&mut self, window: Duration) -> Vec<PeerEvent> {
        let mut got = Vec::new();
        self.until(window, |e| {
            got.push(e.clone());
            None::<()>
        });
        got
    }
}

impl Drop for PeerProc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
