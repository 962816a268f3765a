//! The one Ctrl-C (and SIGTERM / SIGHUP) handler of a process.
//!
//! Why one: a process can install a signal handler only once (`ctrlc`
//! refuses a second), yet the orchestrator's `launch`, `sweep`, `bridge` and
//! `bench`, and every agent's lifeline, each want to know about Ctrl-C.
//! Each used to install its own, and whichever came second silently got
//! nothing. Here the handler is installed on first use and every caller
//! shares its flag; callers that start a new piece of work reset it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

/// Why the handler could not be installed (the process keeps the default
/// effect of Ctrl-C: it ends at once).
#[derive(Clone, Debug, thiserror::Error)]
#[error("cannot install the termination handler: {0}")]
pub struct HandlerError(String);

/// The process-wide flag set by Ctrl-C, SIGTERM and SIGHUP; the handler is
/// installed on the first call, and its failure is reported to every caller.
pub fn flag() -> Result<Arc<AtomicBool>, HandlerError> {
    static FLAG: OnceLock<Result<Arc<AtomicBool>, HandlerError>> = OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let handler_flag = Arc::clone(&flag);
        ctrlc::set_handler(move || handler_flag.store(true, Ordering::SeqCst))
            .map_err(|e| HandlerError(e.to_string()))?;
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
}
