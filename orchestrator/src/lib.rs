//! The orchestrator's library: subcommands, sweeps, pictures.
//!
//! Kept as a library so the end-to-end tests can call the same code the
//! binary runs.

pub mod certs;
pub mod commands;
pub mod doctor;
pub mod draw;
pub mod gate;
pub mod launch;
pub mod live;
pub mod mocap;
pub mod out;
pub mod record;
pub mod replay;
pub mod runs;
pub mod scenario;
pub mod scene;
pub mod sweep;

/// Exit codes of every subcommand.
pub mod exit {
    /// A bad value given by the user (a flag or a config key): the command
    /// did nothing and exits with [`USAGE`], like clap's own usage errors.
    #[derive(Debug, thiserror::Error)]
    #[error("{0}")]
    pub struct UsageError(pub String);

    /// Wraps any message as a [`UsageError`].
    pub fn usage(message: impl std::fmt::Display) -> anyhow::Error {
        UsageError(message.to_string()).into()
    }

    /// The text of an error that ends a command (or is shown as a cause):
    /// its chain with every cause said once ([`bycoms_runtime::logging::error_text`]).
    pub fn message(err: &anyhow::Error) -> String {
        bycoms_runtime::logging::error_text(err.as_ref())
    }

    /// The exit code of an error that ended a command: [`USAGE`] if a
    /// [`UsageError`] is anywhere in its chain, else [`ERROR`].
    pub fn code_of(err: &anyhow::Error) -> i32 {
        if err.chain().any(|e| e.is::<UsageError>()) {
            USAGE
        } else {
            ERROR
        }
    }

    /// The run (or command) succeeded; for `simulate`, a robot arrived.
    pub const SUCCESS: i32 = 0;
    /// Bad input or a failure: the message says which.
    pub const ERROR: i32 = 1;
    /// Command-line usage error (clap's own code).
    pub const USAGE: i32 = 2;
    /// The run finished but no robot reached the goal.
    pub const NOT_ARRIVED: i32 = 3;
    /// Interrupted (Ctrl-C); what was done is kept.
    pub const INTERRUPTED: i32 = 130;
}
