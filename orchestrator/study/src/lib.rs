//! The paper's study and the pictures of runs and studies.
//!
//! * [`runs`] — a run's parameters checked, its verdict sentence, a
//!   terrain file's error, said alike by every command;
//! * [`gate`] — the deployment gate's judgement from poses alone (the
//!   launch core, the replay and the pictures judge alike);
//! * [`scenario`] — where a run's world comes from: a file, a seed of the
//!   study's candidate stream, a built-in terrain;
//! * [`sweep`] — the study (§V): ε × path width, resumable and shardable;
//! * [`draw`] — every picture: a run, its trace, the study's tables.
//!
//! Why one crate below the launch: the launch draws its `--svg` trace and
//! judges with the gate, and the study draws its tables; neither needs the
//! launch, which sits above (ARCHITECTURE.md, "Crates of the orchestrator").

pub mod draw;
/// The gate's judgement, in its own crate (`orchestrator/gate/src/gate.rs`).
pub use bycoms_gate::gate;
pub mod runs;
pub mod scenario;
pub mod sweep;
