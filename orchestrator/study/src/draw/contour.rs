//! Contour lines of the robots' potential field, as the paper's
//! `fig:exp_sample` draws them (purple lines): marching squares over a
//! sampled grid.
//!
//! Written here rather than taken from the `contour` crate: that one returns
//! `geo-types` multipolygons (another dependency tree) where a picture needs
//! only line segments, and marching squares is forty lines.

use bycoms_sim::Vec2;

/// Samples per cell along each axis.
pub const SAMPLES_PER_CELL: usize = 4;

/// A scalar field sampled on a regular grid over `[0, width] × [0, height]`.
pub struct Grid {
    nx: usize,
    ny: usize,
    step: f64,
    values: Vec<f64>,
}

impl Grid {
    /// An all-zero grid over a `width × height` arena.
    pub fn new(width: usize, height: usize) -> Self {
        let (nx, ny) = (width * SAMPLES_PER_CELL + 1, height * SAMPLES_PER_CELL + 1);
        Self { nx, ny, step: 1.0 / SAMPLES_PER_CELL as f64, values: vec![0.0; nx * ny] }
    }

    fn point(&self, i: usize, j: usize) -> Vec2 {
        Vec2::new(i as f64 * self.step, j as f64 * self.step)
    }

    /// Adds the field `c / d²` of one source (the paper's g(x, y)).
    pub fn add_source(&mut self, source: Vec2, c: f64) {
        for j in 0..self.ny {
            for i in 0..self.nx {
                let d2 = self.point(i, j).distance(source).powi(2);
                // At the source itself the field is infinite; a huge finite
                // value keeps the contours closed around it.
                self.values[j * self.nx + i] += c / d2.max(1e-9);
            }
        }
    }

    fn value(&self, i: usize, j: usize) -> f64 {
        self.values[j * self.nx + i]
    }

    /// The segments where the field crosses `level`, in world coordinates.
    pub fn isoline(&self, level: f64) -> Vec<(Vec2, Vec2)> {
        let mut out = Vec::new();
        for j in 0..self.ny - 1 {
            for i in 0..self.nx - 1 {
                let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
                let v = corners.map(|(a, b)| self.value(a, b));
                // Where the level crosses each edge (corner k to corner k+1).
                let mut crossings = Vec::with_capacity(4);
                for k in 0..4 {
                    let (a, b) = (v[k], v[(k + 1) % 4]);
                    if (a >= level) != (b >= level) {
                        let t = (level - a) / (b - a);
                        let (p, q) = (
                            self.point(corners[k].0, corners[k].1),
                            self.point(corners[(k + 1) % 4].0, corners[(k + 1) % 4].1),
                        );
                        crossings.push(Vec2::new(p.x + t * (q.x - p.x), p.y + t * (q.y - p.y)));
                    }
                }
                match crossings.as_slice() {
                    [a, b] => out.push((*a, *b)),
                    // A saddle: pair the crossings by the centre's side.
                    [a, b, c, d] => {
                        let centre = v.iter().sum::<f64>() / 4.0;
                        if (centre >= level) == (v[0] >= level) {
                            out.push((*a, *d));
                            out.push((*b, *c));
                        } else {
                            out.push((*a, *b));
                            out.push((*c, *d));
                        }
                    }
                    _ => {}
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_contour_of_one_source_is_its_circle() {
        // g = 1/d² = 1/ε² on the circle of radius ε = 3.
        let mut g = Grid::new(20, 20);
        let centre = Vec2::new(10.0, 10.0);
        g.add_source(centre, 1.0);
        let segments = g.isoline(1.0 / 9.0);
        assert!(segments.len() > 40, "{}", segments.len());
        for (a, b) in &segments {
            for p in [a, b] {
                assert!((p.distance(centre) - 3.0).abs() < 0.05, "{p:?}");
            }
        }
        assert!(g.isoline(1e6).len() < 8, "only the cells at the source itself");
    }
}
