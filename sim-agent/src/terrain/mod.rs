//! The simulated world of the paper (§IV-A/B): a grid of
//! unit cells, traversable or impassable, with a start and a goal.
//!
//! Robots are points that get stuck where they enter an impassable cell; the
//! paper's experiments draw such worlds from Perlin noise and study success
//! against the minimum path width. This module holds the grid ([`grid`]),
//! the plain-text file format every tool reads and writes ([`mod@format`],
//! read with a size limit by [`mod@read`]), the
//! Perlin generator with its feasibility check ([`mod@generate`]) and the
//! minimum-path-width measure ([`width`]).

pub mod format;
pub mod generate;
pub mod grid;
pub mod read;
pub mod width;

#[cfg(test)]
mod tests;

pub use format::{parse, to_text, ParseError, ParseErrorKind, MAX_SIDE};
pub use generate::{generate, generate_feasible, is_connected, GenParams, Generated};
pub use grid::Terrain;
pub use read::{read_terrain, read_terrain_file, read_text, read_text_file, ReadError, MAX_FILE_BYTES};
pub use width::{min_path_width, min_path_width_of, WidthModel};
