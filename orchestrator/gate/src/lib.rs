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
//!
//! `view` is the run as every view shows it ([`view::RunView`], issue 53):
//! the one fold of the core's outputs that the scene, the trace, ROS 2, the
//! live view and the summary read, below every crate that renders it.

pub mod gate;
pub mod placement;
pub mod view;
