//! A lab's arena as a terrain for simulated robots: the room of a scenario
//! in cells of a few centimetres, each cell blocked where a robot's body
//! would touch a frame or a wall.
//!
//! Why: in a mixed swarm (simulated robots beside real ones, one field) the
//! simulated members run the paper's simulation, where a robot is a point
//! that is stuck once it enters a blocked cell; the real ones are bodies
//! that stick when their footprint touches a frame. Blocking every cell
//! whose centre lies within the body's radius of a frame or of the walls
//! (the frames grown by the footprint, as a planner's configuration space
//! does) makes a simulated robot stick where a real one of that footprint
//! would, to within half a cell. The terrain is built from the scenario, the
//! lab's one description, so it cannot disagree with the room the real
//! robots drive in: its origin is the arena's corner (0, 0) and it covers
//! the arena's width and height.

use super::body::arena_walls;
use super::body::Obstacle;
use super::scenario::Scenario;
use bycoms_sim::terrain::{Terrain, MAX_SIDE};
use bycoms_sim::Vec2;

/// The default cell of a lab's arena, m: a fifth of a frame's 4 cm
/// thickness would be finer than motion capture needs; 2 cm keeps
/// exp-long's 3.5 m × 2.5 m arena at 175 × 125 cells and a 0.22 m/s
/// robot within about one cell a control period.
pub const DEFAULT_CELL: f64 = 0.02;

/// Why an arena cannot be a terrain.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ArenaError {
    /// The cell is not a positive number of metres.
    #[error("the arena's cell must be a positive number of metres, got {0}")]
    Cell(f64),
    /// Too many cells across.
    #[error(
        "scenario {name}: {width} m × {height} m in cells of {cell} m is more than {MAX_SIDE} cells across; \
         take a larger cell"
    )]
    TooLarge {
        /// The scenario.
        name: String,
        /// Its width, m.
        width: f64,
        /// Its height, m.
        height: f64,
        /// The cell asked for, m.
        cell: f64,
    },
    /// The start or the goal is blocked: no simulated robot could leave or reach it.
    #[error("scenario {name}: its {what} lies within a body's radius ({radius} m) of a frame or a wall")]
    Blocked {
        /// The scenario.
        name: String,
        /// `start` or `goal`.
        what: &'static str,
        /// The footprint radius, m.
        radius: f64,
    },
}

/// Scenario `s`'s arena in cells of `cell` metres: a cell is blocked when
/// its centre lies within the scenario's body radius of a frame or of the
/// arena's walls; the start and the goal are the scenario's (in cells).
/// Positions in metres are a terrain's cells × `cell`.
pub fn terrain(s: &Scenario, cell: f64) -> Result<Terrain, ArenaError> {
    if !(cell.is_finite() && cell > 0.0) {
        return Err(ArenaError::Cell(cell));
    }
    let cells = |m: f64| (m / cell).ceil();
    let (w, h) = (cells(s.width), cells(s.height));
    if w > MAX_SIDE as f64 || h > MAX_SIDE as f64 {
        let (name, width, height) = (s.name.clone(), s.width, s.height);
        return Err(ArenaError::TooLarge { name, width, height, cell });
    }
    let radius = s.body.radius;
    let mut frames: Vec<Obstacle> = s.obstacles.clone();
    frames.extend(arena_walls(s.width, s.height));
    let touches = |x: f64, y: f64| frames.iter().any(|o| o.distance(x, y) < radius);
    let mut terrain = Terrain::new(w as usize, h as usize);
    for iy in 0..h as usize {
        for ix in 0..w as usize {
            let (x, y) = ((ix as f64 + 0.5) * cell, (iy as f64 + 0.5) * cell);
            terrain.set_blocked(ix, iy, touches(x, y));
        }
    }
    for (what, p) in [("start", Vec2::new(s.start.x, s.start.y)), ("goal", Vec2::new(s.goal.x, s.goal.y))] {
        let at = Vec2::new(p.x / cell, p.y / cell);
        if terrain.is_blocked_at(at) {
            return Err(ArenaError::Blocked { name: s.name.clone(), what, radius });
        }
    }
    terrain.set_start(Vec2::new(s.start.x / cell, s.start.y / cell));
    terrain.set_goal(Vec2::new(s.goal.x / cell, s.goal.y / cell));
    Ok(terrain)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_long_is_blocked_where_a_body_would_touch_the_frame_or_a_wall() {
        let s = Scenario::builtin("exp-long").expect("built in");
        let t = terrain(&s, DEFAULT_CELL).expect("a terrain");
        assert_eq!((t.width(), t.height()), (175, 125));
        let blocked = |x: f64, y: f64| t.is_blocked_at(Vec2::new(x / DEFAULT_CELL, y / DEFAULT_CELL));
        let r = s.body.radius;
        // The frame (1.6..1.64 × 0.5..2.5) grown by the footprint.
        assert!(blocked(1.6 - r + 0.02, 1.0) && blocked(1.64 + r - 0.02, 1.0));
        assert!(!blocked(1.6 - r - 0.02, 1.0) && !blocked(1.64 + r + 0.02, 1.0));
        assert!(blocked(1.62, 0.5 - r + 0.02) && !blocked(1.62, 0.5 - r - 0.02), "the gap below stays open");
        // The walls, grown inwards.
        assert!(blocked(0.05, 1.0) && blocked(3.45, 1.0) && blocked(1.0, 0.05) && blocked(1.0, 2.45));
        assert!(!blocked(0.4, 1.0) && !blocked(3.0, 1.0), "start and goal free");
        assert_eq!((t.start(), t.goal()), (Vec2::new(20.0, 50.0), Vec2::new(150.0, 50.0)));
    }

    #[test]
    fn a_cell_that_is_no_size_or_too_small_for_the_room_is_refused() {
        let s = Scenario::builtin("exp-short").expect("built in");
        assert_eq!(terrain(&s, 0.0).unwrap_err(), ArenaError::Cell(0.0));
        assert!(matches!(terrain(&s, f64::NAN), Err(ArenaError::Cell(_))));
        let err = terrain(&s, 0.001).unwrap_err().to_string();
        assert!(err.contains("more than 1000 cells across"), "{err}");
        let mut tight = s.clone();
        tight.start.x = 0.05;
        let err = terrain(&tight, DEFAULT_CELL).unwrap_err().to_string();
        assert!(err.contains("its start lies within"), "{err}");
    }
}
