//! The orchestrator's integration tests but the launch simulation, as one
//! test binary.
//!
//! Why one binary: each file here used to be its own test target, and each
//! compiled and linked its own copy of the orchestrator and everything it
//! uses; as modules of one binary they build and link once. Run one file's
//! tests with `cargo test -p bycoms-orchestrator --test integration cli::`.
//! `launch_sim` stays its own target (its seeds are replayed by name). A new
//! file here is added as a module below (`autotests = false`); `layers.rs`
//! is its own target too (it reads the sources and runs no orchestrator code).

mod agent_source_suite;
mod cli;
mod completions;
mod error_texts;
mod inputs;
mod logging;
mod memory_launch;
mod open_files;
mod outputs;
mod pictures;
mod pose_source_suite;
mod readers_agree;
mod record;
mod suites;
mod transport_suite;
mod zenoh_security;
