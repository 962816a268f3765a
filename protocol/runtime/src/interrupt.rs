//! The one Ctrl-C (and SIGTERM / SIGHUP / SIGQUIT) handler of a process.
//!
//! Why one: a process can install a signal handler only once (`ctrlc`
//! refuses a second), yet the orchestrator's `launch`, `sweep`, `bridge` and
//! `bench`, and every agent's lifeline, each want to know about Ctrl-C.
//! Each used to install its own, and whichever came second silently got
//! nothing. Here the handler is installed on first use and every caller
//! shares its flag; callers that start a new piece of work reset it.
//!
//! SIGQUIT (Ctrl-\) sets the same flag: by default it ends a process at
//! once (and dumps its core), so a launch left its agents to their
//! lifelines, its recording unfinished, its swarm's lock file behind and
//! no summary.
//!
//! Why the flag is set in the signal handler itself (`signal-hook`'s flag),
//! not by a thread the handler wakes (as `ctrlc` does): an agent sleeps on
//! its commands for up to its parked heartbeat (1 s), and the signal cuts
//! that sleep short (`EINTR`) so the agent looks at this flag at once. With
//! `ctrlc` the flag was set later, by its own thread, and on two busy cores
//! the agent often looked before it was set and slept again: agents of a
//! `kill -9`ed orchestrator (their parent-death signal is SIGTERM,
//! `lifeline`) took up to 1.95 s to exit instead of milliseconds.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, OnceLock};

/// Why the handler could not be installed (the process keeps the default
/// effect of Ctrl-C: it ends at once).
#[derive(Clone, Debug, thiserror::Error)]
#[error("cannot install the termination handler: {0}")]
pub struct HandlerError(String);

/// The process-wide flag set by Ctrl-C, SIGTERM, SIGHUP and SIGQUIT; the
/// handlers are installed on the first call, and their failure is reported
/// to every caller.
pub fn flag() -> Result<Arc<AtomicBool>, HandlerError> {
    static FLAG: OnceLock<Result<Arc<AtomicBool>, HandlerError>> = OnceLock::new();
    FLAG.get_or_init(|| {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGQUIT, SIGTERM};
        let flag = Arc::new(AtomicBool::new(false));
        for (signal, name) in
            [(SIGINT, "SIGINT"), (SIGTERM, "SIGTERM"), (SIGHUP, "SIGHUP"), (SIGQUIT, "SIGQUIT")]
        {
            signal_hook::flag::register(signal, Arc::clone(&flag))
                .map_err(|e| HandlerError(format!("{name}: {e}")))?;
        }
        Ok(flag)
    })
    .clone()
}

/// [`flag`], or — when no handler could be installed — a flag nothing sets
/// (logged once per caller): for commands that work without one.
pub fn flag_or_default() -> Arc<AtomicBool> {
    flag().unwrap_or_else(|e| {
        tracing::warn!("{e}; Ctrl-C will end the process at once");
        Arc::new(AtomicBool::new(false))
    })
}

#[cfg(test)]
mod tests {
    /// The tests that raise a signal set and clear the one flag: one at a time.
    static RAISING: std::sync::Mutex<()> = std::sync::Mutex::new(());

    #[test]
    fn every_caller_shares_one_flag() {
        let a = super::flag().expect("handler installs in a test process");
        let b = super::flag().expect("second call reuses it");
        assert!(std::sync::Arc::ptr_eq(&a, &b));
    }

    /// SIGTERM (an agent's parent-death signal) sets the flag before
    /// `raise` returns, as a signal that cuts a sleep short does before the
    /// sleep returns: the sleeper finds it set. (With `ctrlc` a thread of
    /// its own set it later, and an agent went back to sleep.)
    #[test]
    fn sigterm_sets_the_flag_in_the_handler_itself() {
        let _one = RAISING.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let flag = super::flag().expect("handler installs in a test process");
        nix::sys::signal::raise(nix::sys::signal::Signal::SIGTERM).expect("raise SIGTERM");
        assert!(flag.load(std::sync::atomic::Ordering::SeqCst), "SIGTERM set the flag before raise returned");
        flag.store(false, std::sync::atomic::Ordering::SeqCst);
    }

    #[test]
    fn sigquit_sets_the_flag_as_ctrl_c_does() {
        // Without a handler SIGQUIT ends this test process at once (core
        // dumped): the launch ended with no cleanup and no summary.
        let _one = RAISING.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let flag = super::flag().expect("handler installs in a test process");
        nix::sys::signal::raise(nix::sys::signal::Signal::SIGQUIT).expect("raise SIGQUIT");
        // The handler runs before `raise` returns (a signal to oneself is
        // delivered at once to the raising thread unless blocked).
        assert!(flag.load(std::sync::atomic::Ordering::SeqCst), "SIGQUIT set the interrupt flag");
        flag.store(false, std::sync::atomic::Ordering::SeqCst);
    }
}
