//! Why an agent never outlives its orchestrator.
//!
//! An orphaned robot process would keep publishing poses into the next
//! run's topics and hold shared memory; our rule is "no orphan
//! processes, ever". Three layers, each enough on its own:
//!
//! 1. `prctl(PR_SET_PDEATHSIG, SIGTERM)`: the kernel signals the agent the
//!    moment its parent dies, even by `kill -9`. (Linux ties this to the
//!    parent *thread*, so the orchestrator spawns agents from one spawner
//!    thread that lives until its agents have ended:
//!    `orchestrator/launch/src/agents/spawner.rs`.)
//! 2. SIGTERM, SIGINT and SIGHUP set a flag, in the signal handler itself
//!    (`crate::interrupt`), and cut the agent's wait on its commands short;
//!    its loop then finds the flag set and exits through its normal path,
//!    releasing its iceoryx2 node cleanly, within milliseconds even when
//!    it slept until its next heartbeat (a parked robot's agent: up to 1 s).
//!    Otherwise the loop checks the flag at least every 50 ms.
//! 3. The parent pid is compared with `getppid()` every 100 ms: if the
//!    parent died before step 1 took effect (a race at spawn) or the signal
//!    was lost, the agent notices it has been re-parented.

use nix::sys::signal::Signal;
use nix::unistd::{getppid, Pid};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The clap value parser of `--parent-pid` (every agent binary's): a pid
/// of 2 or more. No agent is the child of pid 0 (no process) or of init
/// (pid 1, what an orphan is re-parented to): either made the agent exit
/// at once, "parent gone".
pub fn parent_pid(text: &str) -> Result<i32, String> {
    match text.trim().parse::<i32>() {
        Ok(pid) if pid >= 2 => Ok(pid),
        _ => Err(format!(
            "must be the pid of the process the agent stays the child of (2 or more), got {text:?}"
        )),
    }
}

/// How often the parent pid is compared.
const PARENT_CHECK: Duration = Duration::from_millis(100);

/// Why the agent must exit now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExitCause {
    /// The orchestrator sent `Shutdown`.
    Shutdown,
    /// The parent process is gone.
    ParentGone,
    /// SIGTERM, SIGINT, SIGHUP or SIGQUIT.
    Signal,
    /// The orchestrator refused this agent: another agent already holds
    /// its robot (`ToAgent::Refused`).
    Refused,
    /// The orchestrator's liveliness token was gone for longer than the
    /// failsafe's grace period (zenoh); the robot was stopped first.
    OrchestratorLost,
}

impl ExitCause {
    /// The exit code of an agent process (`sim-agent`, `sim-agent lab`, the
    /// `gateway`) that ended for this cause: 0 for an orderly end
    /// (`Shutdown`, the parent gone), 130 for a signal (as the orchestrator
    /// and every shell say an interrupted program ended), 3 when refused,
    /// 4 when the failsafe stopped the robot. One mapping, so the agents
    /// never disagree about what an end means.
    pub fn exit_code(self) -> i32 {
        match self {
            Self::Shutdown | Self::ParentGone => 0,
            Self::Signal => 130,
            Self::Refused => 3,
            Self::OrchestratorLost => 4,
        }
    }
}

/// Why the lifeline could not be installed.
#[derive(Debug, thiserror::Error)]
pub enum LifelineError {
    /// `prctl(PR_SET_PDEATHSIG)` failed.
    #[error("cannot ask to be signalled when the parent dies: {0}")]
    Pdeathsig(nix::Error),
    /// The signal handler could not be installed.
    #[error(transparent)]
    Handler(#[from] crate::interrupt::HandlerError),
}

/// The agent's link to its parent; see the module docs.
pub struct Lifeline {
    parent: Pid,
    signalled: Arc<AtomicBool>,
    last_check: Instant,
    parent_gone: bool,
}

impl Lifeline {
    /// Installs the parent-death signal and the termination handler. Call
    /// once per process, first thing in `main`. `parent` is the pid the
    /// agent must stay the child of (default: its parent now).
    pub fn install(parent: Option<i32>) -> Result<Self, LifelineError> {
        nix::sys::prctl::set_pdeathsig(Signal::SIGTERM).map_err(LifelineError::Pdeathsig)?;
        let signalled = crate::interrupt::flag()?;
        let parent = parent.map(Pid::from_raw).unwrap_or_else(getppid);
        let parent_gone = getppid() != parent;
        Ok(Self { parent, signalled, last_check: Instant::now(), parent_gone })
    }

    /// A lifeline that never fires (for in-process tests of the loop).
    pub fn detached() -> Self {
        Self {
            parent: getppid(),
            signalled: Arc::new(AtomicBool::new(false)),
            last_check: Instant::now(),
            parent_gone: false,
        }
    }

    /// A lifeline of an agent that runs as a thread of another process:
    /// it fires (as a signal) when `flag` is set, and never for the
    /// process's parent.
    pub fn with_flag(flag: Arc<AtomicBool>) -> Self {
        Self { parent: getppid(), signalled: flag, last_check: Instant::now(), parent_gone: false }
    }

    /// Whether the agent must exit now; cheap enough to call every loop.
    pub fn check(&mut self) -> Option<ExitCause> {
        let now = Instant::now();
        if now.duration_since(self.last_check) >= PARENT_CHECK {
            self.last_check = now;
            self.parent_gone |= getppid() != self.parent;
        }
        if self.parent_gone {
            return Some(ExitCause::ParentGone);
        }
        if self.signalled.load(Ordering::SeqCst) {
            // PDEATHSIG arrives as SIGTERM: say which it was.
            return Some(if getppid() != self.parent { ExitCause::ParentGone } else { ExitCause::Signal });
        }
        None
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn no_agent_is_the_child_of_pid_0_or_1() {
        assert_eq!(super::parent_pid("4242"), Ok(4242));
        for bad in ["0", "1", "-5", "x", ""] {
            let e = super::parent_pid(bad).unwrap_err();
            assert!(e.contains("(2 or more)") && e.contains(&format!("{bad:?}")), "{e}");
        }
    }
}
