//! Perlin terrain generation (paper §IV-B).
//!
//! The paper draws its worlds from 2-D Perlin noise f: one threshold
//! a ~ U(−1, 1) per terrain, f > a → impassable, a 10 × 10 square around start
//! and goal always free, and only terrains where start and goal are joined by
//! a 4-connected path of free cells are kept (the paper checked with A*).
//!
//! Details fixed here:
//! * f is plain single-octave `noise::Perlin` evaluated at cell centres,
//!   `f(ox + (ix + 0.5)/scale, oy + (iy + 0.5)/scale)`: `scale` is the feature
//!   size in cells. The offset (ox, oy) ∈ [0, 256)² is drawn per terrain so the
//!   Perlin lattice (where f = 0 exactly) does not sit on the same cells in
//!   every terrain.
//! * Everything derives from one `u64` seed through
//!   `Xoshiro256PlusPlus::seed_from_u64`, in this order: the Perlin seed
//!   (`u32`), a, ox, oy. Same seed → same terrain on every machine.
//! * The always-free squares: every cell overlapping (with positive area) the
//!   10 × 10 square centred on the start, and on the goal. For a centre c on
//!   a cell centre that is 11 cells per axis, c − 5.5 … c + 4.5, e.g. cells
//!   10..=20 around (15.5, 15.5) and 39..=49 around (44.5, 44.5).
//!
//! Scale choice: [`DEFAULT_SCALE`] = 4.5 cells. The sweep needs 100 feasible
//! terrains in every minimum-path-width bin 1, 1.5, …, 5; small features make
//! narrow bins abundant and wide ones rare, large features the reverse (at
//! 12 cells two thirds of feasible terrains measure ≥ 8 and bins 2.5 and 3.5
//! get under 1 % each; at 4 cells bin 4.5 gets 0.9 %). Scanning 4…8 in steps
//! of 0.5 (2000 seeds) and 4.25…5.5 (10 000 seeds), 4.5 maximised the
//! smallest bin. Over the first 2000 seeds (975 feasible), widths measured
//! with the default disc model (see `width`;
//! `cargo bench -p bycoms-sim --bench width_histogram`):
//!
//! ```text
//! [1.0, 1.5)    81   8.3% ########
//! [1.5, 2.0)    34   3.5% ###
//! [2.0, 2.5)    75   7.7% ########
//! [2.5, 3.0)    50   5.1% #####
//! [3.0, 3.5)   122  12.5% #############
//! [3.5, 4.0)    41   4.2% ####
//! [4.0, 4.5)    68   7.0% #######
//! [4.5, 5.0)    66   6.8% #######
//! [5.0, 5.5)    78   8.0% ########
//! [5.5, 6.0)    11   1.1% #
//! [6.0, 6.5)    34   3.5% ###
//! [6.5, 7.0)    14   1.4% #
//! [7.0, 7.5)    28   2.9% ###
//! [7.5, 8.0]   273  28.0% ############################  (8.0 = capped)
//! ```
//!
//! (With the literal square model bins 1.5 and 4.5 stay empty at every
//! scale; `width` explains why.)
//!
//! Cost per candidate (release, one core): generation + feasibility ≈ 0.19 ms,
//! minimum path width ≈ 0.3 ms per feasible terrain.

use super::grid::Terrain;
use crate::geom::Vec2;
use noise::{NoiseFn, Perlin};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Perlin feature size in cells (see the module doc for why).
pub const DEFAULT_SCALE: f64 = 4.5;

/// Half the side of the always-free squares around start and goal.
pub const CLEAR_HALF_SIDE: f64 = 5.0;

/// Size of the generated grid and the Perlin feature size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GenParams {
    pub width: usize,
    pub height: usize,
    /// Feature size in cells: noise is sampled at `cell_centre / scale`.
    pub scale: f64,
}

impl Default for GenParams {
    /// The paper's 60 × 60 arena with [`DEFAULT_SCALE`].
    fn default() -> Self {
        GenParams { width: 60, height: 60, scale: DEFAULT_SCALE }
    }
}

/// A generated terrain, its threshold a and whether it is feasible.
#[derive(Clone, Debug, PartialEq)]
pub struct Generated {
    pub terrain: Terrain,
    /// The Perlin threshold a: cells with f > a are impassable.
    pub threshold: f64,
    /// A 4-connected path of free cells joins start and goal.
    pub feasible: bool,
}

/// Generates the terrain of `seed` (default start and goal).
///
/// # Panics
/// If `params.width` or `params.height` is zero.
pub fn generate(seed: u64, params: &GenParams) -> Generated {
    let field = Field::new(seed, params);
    let mut terrain = Terrain::new(params.width, params.height);
    for iy in 0..params.height {
        for ix in 0..params.width {
            if field.above(ix, iy) {
                terrain.set_blocked(ix, iy, true);
            }
        }
    }
    let (start, goal) = (terrain.start(), terrain.goal());
    clear_square(&mut terrain, start);
    clear_square(&mut terrain, goal);
    let feasible = is_connected(&terrain);
    Generated { terrain, threshold: field.threshold, feasible }
}

/// [`generate`] for the feasible candidates only (`None` for the others),
/// the same terrain bit for bit. The Perlin field is evaluated lazily while
/// the flood fill looks for a path, so an infeasible candidate (about half
/// of a sweep's, most of them blocked around the start) costs only the
/// cells its start's region reaches; a feasible one is then completed.
pub fn generate_feasible(seed: u64, params: &GenParams) -> Option<Generated> {
    let field = Field::new(seed, params);
    let mut terrain = Terrain::new(params.width, params.height);
    let (w, h) = (params.width, params.height);
    let squares = [terrain.start(), terrain.goal()]
        .map(|c| (overlapping(c.x, CLEAR_HALF_SIDE, w), overlapping(c.y, CLEAR_HALF_SIDE, h)));
    let cleared = |ix: usize, iy: usize| {
        squares.iter().any(|&(xs, ys)| match (xs, ys) {
            (Some((x0, x1)), Some((y0, y1))) => (x0..=x1).contains(&ix) && (y0..=y1).contains(&iy),
            _ => false,
        })
    };
    // Per cell: 0 not evaluated yet, 1 free, 2 impassable.
    let mut state = vec![0u8; w * h];
    let mut blocked = |ix: usize, iy: usize| {
        if ix >= w || iy >= h {
            return true;
        }
        let cell = &mut state[iy * w + ix];
        if *cell == 0 {
            *cell = if !cleared(ix, iy) && field.above(ix, iy) { 2 } else { 1 };
        }
        *cell == 2
    };
    let (s, g) = (terrain.cell_of(terrain.start())?, terrain.cell_of(terrain.goal())?);
    if !connected(w, h, s, g, &mut blocked) {
        return None;
    }
    for iy in 0..h {
        for ix in 0..w {
            if blocked(ix, iy) {
                terrain.set_blocked(ix, iy, true);
            }
        }
    }
    Some(Generated { terrain, threshold: field.threshold, feasible: true })
}

/// The Perlin field of one candidate and its threshold, drawn from its seed.
struct Field {
    perlin: Perlin,
    threshold: f64,
    ox: f64,
    oy: f64,
    scale: f64,
}

impl Field {
    fn new(seed: u64, params: &GenParams) -> Self {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let perlin = Perlin::new(rng.gen::<u32>());
        let threshold: f64 = rng.gen_range(-1.0..1.0);
        let ox: f64 = rng.gen_range(0.0..256.0);
        let oy: f64 = rng.gen_range(0.0..256.0);
        Self { perlin, threshold, ox, oy, scale: params.scale }
    }

    /// f > a at the centre of cell (ix, iy): impassable unless cleared.
    #[inline]
    fn above(&self, ix: usize, iy: usize) -> bool {
        let y = self.oy + (iy as f64 + 0.5) / self.scale;
        let x = self.ox + (ix as f64 + 0.5) / self.scale;
        self.perlin.get([x, y]) > self.threshold
    }
}

/// Cells `lo..=hi` overlapping the open interval (c − half, c + half), clamped
/// to `0..n`; `None` if there are none.
fn overlapping(c: f64, half: f64, n: usize) -> Option<(usize, usize)> {
    // Cell i overlaps iff i < c + half and i + 1 > c − half.
    let lo = ((c - half - 1.0).floor() + 1.0).max(0.0);
    let hi = ((c + half).ceil() - 1.0).min(n as f64 - 1.0);
    (lo <= hi).then_some((lo as usize, hi as usize))
}

/// Frees every cell overlapping the square of side `2·CLEAR_HALF_SIDE`
/// centred on `c`.
fn clear_square(t: &mut Terrain, c: Vec2) {
    let xs = overlapping(c.x, CLEAR_HALF_SIDE, t.width());
    let ys = overlapping(c.y, CLEAR_HALF_SIDE, t.height());
    if let (Some((x0, x1)), Some((y0, y1))) = (xs, ys) {
        for iy in y0..=y1 {
            for ix in x0..=x1 {
                t.set_blocked(ix, iy, false);
            }
        }
    }
}

/// Whether a 4-connected path of free cells joins the start cell and the
/// goal cell (false if either is outside the arena or impassable).
///
/// A flood fill from the start over a flat grid of seen cells (the sweep
/// asks this of every candidate terrain; a search keyed by hashing the
/// cells took a third of the time of generating it).
pub fn is_connected(t: &Terrain) -> bool {
    let (Some(s), Some(g)) = (t.cell_of(t.start()), t.cell_of(t.goal())) else {
        return false;
    };
    connected(t.width(), t.height(), s, g, |x, y| t.cell_blocked(x, y))
}

/// Whether a 4-connected path of cells that are not `blocked` joins cells
/// `s` and `g` of a `w` × `h` grid (`blocked` answers for cells just
/// outside it too, as impassable).
fn connected(
    w: usize,
    h: usize,
    s: (usize, usize),
    g: (usize, usize),
    mut blocked: impl FnMut(usize, usize) -> bool,
) -> bool {
    if blocked(s.0, s.1) || blocked(g.0, g.1) {
        return false;
    }
    let mut seen = vec![false; w * h];
    let mut todo = vec![s];
    seen[s.1 * w + s.0] = true;
    while let Some((x, y)) = todo.pop() {
        if (x, y) == g {
            return true;
        }
        let left = x.checked_sub(1).map(|x| (x, y));
        let down = y.checked_sub(1).map(|y| (x, y));
        for (nx, ny) in [Some((x + 1, y)), Some((x, y + 1)), left, down].into_iter().flatten() {
            if !blocked(nx, ny) && !seen[ny * w + nx] {
                seen[ny * w + nx] = true;
                todo.push((nx, ny));
            }
        }
    }
    false
}
