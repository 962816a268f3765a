//! The simulated BYCOMS world (paper §IV–V).
//!
//! Everything the paper's Python simulation did, as a library: the terrain
//! grid and its text format, Perlin-noise generation, the minimum path width,
//! the field physics, sensing noise, point kinematics and the sequential
//! runner that deploys robots one at a time. The controller itself is not
//! here: it is `bycoms_agent::point`, the same code every other shell runs.
#![forbid(unsafe_code)]

pub mod body;
pub mod bypass;
pub mod field;
pub mod geom;
pub mod robot;
pub mod runner;
pub mod seed;
pub mod sensing;
pub mod terrain;

pub use geom::Vec2;
pub use runner::{run, RunConfig, RunOutcome, RunResult};
