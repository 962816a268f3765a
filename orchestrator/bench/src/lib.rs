//! The benchmarks that run whole launches, measured from outside.
//!
//! * [`scale`] — the most real-time agents at once (`orchestrator bench
//!   scale`): missed periods and memory;
//! * [`crowd`] — a whole lockstep launch as the swarm grows (`orchestrator
//!   bench crowd`);
//! * [`stopbench`] — every robot stopped after a `stop --now`
//!   (`orchestrator bench stop`);
//! * [`procfs`] — the benches' one reader of `/proc` (memory, open files, a
//!   process tree).
//!
//! Why a crate of its own above the launch: the benches start launches and
//! agents like a user would, and the launch must not carry them.

pub mod crowd;
pub mod procfs;
pub mod scale;
pub mod stopbench;
