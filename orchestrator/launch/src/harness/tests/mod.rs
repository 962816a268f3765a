//! The launch core's rules in virtual time, played through the harness:
//! the core's tests that need the harness, the config or the setup, all
//! above the core's own crate (`bycoms-launch-core`, which cannot depend on
//! them), so they live here, one file per rule file of the core
//! (`orchestrator/launch-core/src/clocks.rs` → `clocks.rs`, …).

mod clocks;
mod log;
mod moved;
mod revoke;
mod stop;
mod timers;
