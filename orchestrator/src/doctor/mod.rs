//! `orchestrator doctor`: what would stop a lab day, found before it starts.
//!
//! Why: a launch finds an expired certificate, a robot missing from the
//! ACL, a taken gateway port or a silent NatNet server only when it
//! starts (or worse, when robot 7 is deployed), with a room full of
//! people waiting. The doctor runs the same checks the launch would, on
//! this host and without starting anything, and says each finding as a
//! [`Finding`]: which check, how bad ([`Level`]), the cause and the fix.
//!
//! The checks read what the launch reads (the launch config, its robots
//! file, the certificates `orchestrator certs` wrote) and reuse the
//! launch's own arithmetic (`launch::limits`), so the doctor and the
//! launch cannot disagree about what is enough. With `--connect` it also
//! reaches the orchestrator's zenoh endpoint as a robot's host would,
//! looks for the orchestrator's liveliness and measures this host's clock
//! offset to the orchestrator's ([`zenoh`]). A robot's host without the
//! orchestrator binary runs the same check with `gateway doctor` or
//! `sim-agent doctor` (with its certificate, its gateway's port and its
//! open-files limit): the shared checks live once in
//! `bycoms_runtime::doctor`, this module keeps the orchestrator's own (the
//! certificate set against the ACL, memory, iceoryx2 leftovers, NatNet).
//! The other direction (the orchestrator reaching each host) is not
//! checked: each host's doctor checks its own way in.

pub mod certs;
pub mod host;
#[cfg(test)]
mod tests;

/// The findings, their report and the zenoh check are every host's
/// (`bycoms_runtime::doctor`, shared with `gateway doctor` and `sim-agent
/// doctor`).
pub use bycoms_runtime::doctor::{any_error, json, text, zenoh, Finding, Level};
