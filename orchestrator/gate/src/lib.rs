//! The deployment gate's judgement and the operator's placement at the
//! start: the plain rules by which a launch judges robots from their poses.
//!
//! Why a crate of its own: the launch core (`bycoms-launch-core`), the
//! study's pictures and replay (`bycoms-study`) and motion capture
//! (`bycoms-mocap`) all use these rules. Kept in the core's crate, they made
//! the study and motion capture depend on the core, so a one-line change in
//! the core rebuilt them and everything above them (issue 53: 25.9 s before
//! the core's crate, 31.3 s with it). Below all three, a change in the core
//! rebuilds only what uses the core. Like the core, it does no IO.

pub mod gate;
pub mod placement;
