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
//! no summary. `ctrlc` knows only SIGINT, SIGTERM and SIGHUP; SIGQUIT goes
//! through `signal-hook`'s flag, set from the signal handler itself.

use std::sync::atomic::{AtomicBool, Ordering};
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
        let flag = Arc::new(AtomicBool::new(false));
        let handler_flag = Arc::clone(&flag);
        ctrlc::set_handler(move || handler_flag.store(true, Ordering::SeqCst))
            .map_err(|e| HandlerError(e.to_string()))?;
        signal_hook::flag::register(signal_hook::consts::SIGQUIT, Arc::clone(&flag))
            .map_err(|e| HandlerError(format!("SIGQUIT: {e}")))?;
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
    #[test]
    fn every_caller_shares_one_flag() {
        let a = super::flag().expect("handler installs in a test process");
        let b = super::flag().expect("second call reuses it");
        assert!(std::sync::Arc::ptr_eq(&a, &b));
    }

    #[test]
    fn sigquit_sets_the_flag_as_ctrl_c_does() {
        // Without a handler SIGQUIT ends this test process at once (core
        // dumped): the launch ended with no cleanup and no summary.
        let flag = super::flag().expect("handler installs in a test process");
        nix::sys::signal::raise(nix::sys::signal::Signal::SIGQUIT).expect("raise SIGQUIT");
        // The handler runs before `raise` returns (a signal to oneself is
        // delivered at once to the raising thread unless blocked).
        assert!(flag.load(std::sync::atomic::Ordering::SeqCst), "SIGQUIT set the interrupt flag");
        flag.store(false, std::sync::atomic::Ordering::SeqCst);
    }
}
