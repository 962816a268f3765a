//! Waiting for a child process with a bound, written once.
//!
//! Why: `std::process::Child` has no wait with a timeout, and every test
//! and bench that starts a process (a launch, a gateway, an SDK client)
//! must neither hang on one that never ends nor poll `try_wait` in a loop
//! with a sleep (a latency added to every wait, and a sleep in test code).
//! [`wait_or_kill`] blocks on the exit itself, on a scoped thread, and
//! wakes the moment the process ends or the bound passes; past the bound
//! it kills the process (or its group) and reaps it.

use nix::sys::signal::{kill, killpg, Signal};
use nix::unistd::Pid;
use std::io;
use std::process::{Child, ExitStatus};
use std::sync::mpsc;
use std::time::Duration;

/// What to kill once the bound has passed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kill {
    /// The child alone.
    Process,
    /// The child's process group (a child started as its group's leader,
    /// with what it started).
    Group,
}

/// How a waited-for child ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Waited {
    /// Its exit status.
    pub status: ExitStatus,
    /// Whether it ended within the bound (else it was killed).
    pub in_time: bool,
}

/// Waits for `child` to end, at most `timeout`; past it, SIGKILL to the
/// child or its group (`kill`), then the child is reaped. Either way the
/// child has ended when this returns.
pub fn wait_or_kill(child: &mut Child, timeout: Duration, what: Kill) -> io::Result<Waited> {
    let pid = Pid::from_raw(i32::try_from(child.id()).map_err(io::Error::other)?);
    std::thread::scope(|scope| {
        let (tx, rx) = mpsc::channel();
        scope.spawn(move || {
            let _ = tx.send(child.wait());
        });
        if let Ok(status) = rx.recv_timeout(timeout) {
            return Ok(Waited { status: status?, in_time: true });
        }
        // (The waiter has not reaped it: the pid is still the child's.)
        let _ = match what {
            Kill::Process => kill(pid, Signal::SIGKILL),
            Kill::Group => killpg(pid, Signal::SIGKILL),
        };
        let status = rx.recv().map_err(|_| io::Error::other("the waiter ended without a status"))??;
        Ok(Waited { status, in_time: false })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::process::Command;
    use std::time::Instant;

    #[test]
    fn a_child_that_ends_is_waited_for_and_one_that_does_not_is_killed() {
        let mut quick = Command::new("true").spawn().expect("spawn true");
        let waited = wait_or_kill(&mut quick, Duration::from_secs(30), Kill::Process).expect("wait");
        assert!(waited.in_time && waited.status.success(), "{waited:?}");
        let mut slow = Command::new("sleep").arg("30").spawn().expect("spawn sleep");
        let started = Instant::now();
        let waited = wait_or_kill(&mut slow, Duration::from_millis(100), Kill::Process).expect("wait");
        assert!(!waited.in_time && !waited.status.success(), "{waited:?}");
        assert!(started.elapsed() < Duration::from_secs(20), "killed at the bound, not after sleep's 30 s");
        assert!(slow.try_wait().expect("try_wait").is_some(), "reaped");
    }
}
