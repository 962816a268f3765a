//! The `orchestrator` binary's library: its command line (one file per
//! subcommand) and what runs only around a launch (the live view, the
//! replay, the doctor, the lab's certificates).
//!
//! Kept as a library so the end-to-end tests can call the same code the
//! binary runs. The launch, the recording, the study, motion capture and the
//! benchmarks are crates of their own below this one (ARCHITECTURE.md,
//! "Crates of the orchestrator").

pub mod certs;
pub mod commands;
pub mod doctor;
pub mod live;
pub mod replay;
