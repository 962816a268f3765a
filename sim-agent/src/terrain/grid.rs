//! The grid itself: which unit cells a robot may enter.
//!
//! The paper's world is a 60 × 60 grid of unit cells, each either traversable
//! or impassable, with a start and a goal point (§IV-A). Robots are points;
//! the simulator asks, every control period, whether the robot's position lies
//! in an impassable cell or outside the arena — [`Terrain::is_blocked_at`] is
//! therefore the hot path and is kept to a floor, a bounds check and one load.
//!
//! Cell `(ix, iy)` covers `[ix, ix + 1) × [iy, iy + 1)`; `iy = 0` is the bottom
//! row (y up, as in the world frame of [`Vec2`]).

use crate::geom::Vec2;

/// A grid of unit cells with a start and a goal point.
///
/// Equality compares the grid and the exact bits of the start and goal
/// coordinates, which makes it a lawful [`Eq`].
#[derive(Clone, Debug)]
pub struct Terrain {
    width: usize,
    height: usize,
    /// Row-major impassable flags, index `iy * width + ix`.
    blocked: Vec<bool>,
    start: Vec2,
    goal: Vec2,
}

impl PartialEq for Terrain {
    fn eq(&self, other: &Self) -> bool {
        let bits = |p: Vec2| (p.x.to_bits(), p.y.to_bits());
        self.width == other.width
            && self.height == other.height
            && self.blocked == other.blocked
            && bits(self.start) == bits(other.start)
            && bits(self.goal) == bits(other.goal)
    }
}

impl Eq for Terrain {}

/// The centre of cell `(ix, iy)`.
pub fn cell_centre(ix: usize, iy: usize) -> Vec2 {
    Vec2::new(ix as f64 + 0.5, iy as f64 + 0.5)
}

/// Default start cell of a `width × height` grid: `(w/4, h/4)`.
pub fn default_start_cell(width: usize, height: usize) -> (usize, usize) {
    (width / 4, height / 4)
}

/// Default goal cell of a `width × height` grid: `(w−1−w/4, h−1−h/4)`.
pub fn default_goal_cell(width: usize, height: usize) -> (usize, usize) {
    (width - 1 - width / 4, height - 1 - height / 4)
}

impl Terrain {
    /// An all-free `width × height` grid with the default start and goal
    /// (for 60 × 60: (15.5, 15.5) and (44.5, 44.5), as in the paper).
    ///
    /// # Panics
    /// If `width` or `height` is zero.
    pub fn new(width: usize, height: usize) -> Terrain {
        assert!(width > 0 && height > 0, "a terrain needs at least one cell, got {width} × {height}");
        let (sx, sy) = default_start_cell(width, height);
        let (gx, gy) = default_goal_cell(width, height);
        Terrain {
            width,
            height,
            blocked: vec![false; width * height],
            start: cell_centre(sx, sy),
            goal: cell_centre(gx, gy),
        }
    }

    /// The paper's empty 60 × 60 arena.
    pub fn paper() -> Terrain {
        Terrain::new(60, 60)
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn height(&self) -> usize {
        self.height
    }

    pub fn start(&self) -> Vec2 {
        self.start
    }

    pub fn goal(&self) -> Vec2 {
        self.goal
    }

    pub fn set_start(&mut self, p: Vec2) {
        self.start = p;
    }

    pub fn set_goal(&mut self, p: Vec2) {
        self.goal = p;
    }

    /// Whether cell `(ix, iy)` is impassable; cells outside the grid are.
    #[inline]
    pub fn cell_blocked(&self, ix: usize, iy: usize) -> bool {
        ix >= self.width || iy >= self.height || self.blocked[iy * self.width + ix]
    }

    /// Marks cell `(ix, iy)` impassable (`true`) or free (`false`).
    ///
    /// # Panics
    /// If the cell is outside the grid.
    pub fn set_blocked(&mut self, ix: usize, iy: usize, blocked: bool) {
        assert!(
            ix < self.width && iy < self.height,
            "cell ({ix}, {iy}) is outside the {} × {} grid",
            self.width,
            self.height
        );
        self.blocked[iy * self.width + ix] = blocked;
    }

    /// True if `p` is outside the arena `[0, w) × [0, h)` or inside an
    /// impassable cell. NaN coordinates count as outside.
    #[inline]
    pub fn is_blocked_at(&self, p: Vec2) -> bool {
        // `!(a >= 0)` also catches NaN; for non-negative values the saturating
        // cast truncates, i.e. floors, and huge values saturate to usize::MAX.
        if !(p.x >= 0.0 && p.y >= 0.0) {
            return true;
        }
        let (ix, iy) = (p.x as usize, p.y as usize);
        if ix >= self.width || iy >= self.height {
            return true;
        }
        match self.blocked.get(iy * self.width + ix) {
            Some(&b) => b,
            None => true,
        }
    }

    /// The cell containing `p`, if `p` is inside the arena.
    pub fn cell_of(&self, p: Vec2) -> Option<(usize, usize)> {
        if !(p.x >= 0.0 && p.y >= 0.0) {
            return None;
        }
        let (ix, iy) = (p.x as usize, p.y as usize);
        (ix < self.width && iy < self.height).then_some((ix, iy))
    }

    /// Number of impassable cells.
    pub fn blocked_count(&self) -> usize {
        self.blocked.iter().filter(|&&b| b).count()
    }

    /// Row-major impassable flags, index `iy * width + ix`.
    pub fn blocked_cells(&self) -> &[bool] {
        &self.blocked
    }
}
