//! What every BYCOMS swarm process shares, in one place that is not the
//! simulator: the binaries (`orchestrator`, `sim-agent`, `natnet-serve`,
//! the `agent` gateway) live in different crates, and a real robot's
//! gateway must not depend on the simulated world to behave like the rest.
//!
//! * [`logging`] — one logging setup: `tracing` on stderr, `RUST_LOG`,
//!   `--log-format text|json`, status lines, the text of an error.

pub mod logging;
