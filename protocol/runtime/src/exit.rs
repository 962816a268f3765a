//! Exit codes of every subcommand of the orchestrator, and the usage error
//! that ends one with [`USAGE`].
//!
//! Why in the process runtime: the launch, the study, the recording tools
//! and the CLI all end commands with these codes, and they live in
//! separate crates below the CLI.

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
/// its chain with every cause said once ([`crate::logging::error_text`]).
pub fn message(err: &anyhow::Error) -> String {
    crate::logging::error_text(err.as_ref())
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
