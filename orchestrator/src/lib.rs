//! The orchestrator's library: subcommands, sweeps, pictures.
//!
//! Kept as a library so the end-to-end tests can call the same code the
//! binary runs.

pub mod commands;
pub mod draw;
pub mod launch;
pub mod record;
pub mod scenario;
pub mod sweep;

/// Exit codes of every subcommand.
pub mod exit {
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
