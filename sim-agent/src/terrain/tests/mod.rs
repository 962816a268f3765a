//! Tests of the terrain module, one file per submodule.

mod format;
mod generate;
mod grid;
mod read;
mod width;

use super::Terrain;

/// A `w × h` text terrain of '.' with the given (line, column, char) overrides.
pub(super) fn text_with(w: usize, h: usize, marks: &[(usize, usize, char)]) -> String {
    let mut rows: Vec<Vec<char>> = vec![vec!['.'; w]; h];
    for &(line, col, c) in marks {
        rows[line - 1][col - 1] = c;
    }
    rows.into_iter().map(|r| r.into_iter().collect::<String>() + "\n").collect()
}

/// Blocks the rectangle of cells `x0..x1 × y0..y1`.
pub(super) fn block(t: &mut Terrain, xs: std::ops::Range<usize>, ys: std::ops::Range<usize>) {
    for iy in ys {
        for ix in xs.clone() {
            t.set_blocked(ix, iy, true);
        }
    }
}
