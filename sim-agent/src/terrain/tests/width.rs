use super::block;
use crate::terrain::width::MAX_CLEARANCE;
use crate::terrain::{is_connected, min_path_width, min_path_width_of, Terrain, WidthModel};
use crate::Vec2;

/// A 1-cell-thick wall across the paper arena at row 30 with a gap of cells
/// `gap` — the gap is the only way through and the narrowest place.
fn wall_with_gap(gap: std::ops::Range<usize>) -> Terrain {
    let mut t = Terrain::paper();
    for ix in (0..60).filter(|ix| !gap.contains(ix)) {
        t.set_blocked(ix, 30, true);
    }
    t
}

fn near(w: f64, expected: f64, tol: f64) {
    assert!((w - expected).abs() <= tol, "width {w}, expected {expected} ± {tol}");
}

fn squares(t: &Terrain) -> f64 {
    min_path_width_of(t, WidthModel::Squares)
}

#[test]
fn axis_aligned_corridors_are_exact_in_both_models() {
    for model in [WidthModel::Squares, WidthModel::Discs] {
        near(min_path_width_of(&wall_with_gap(30..31), model), 1.0, 1e-12);
        near(min_path_width_of(&wall_with_gap(30..32), model), 2.0, 1e-12);
        near(min_path_width_of(&wall_with_gap(20..23), model), 3.0, 1e-12);
        // At the arena edge the border counts as an obstacle: gap cells 0..2.
        near(min_path_width_of(&wall_with_gap(0..2), model), 2.0, 1e-12);
    }
}

#[test]
fn disc_model_reaches_the_half_bins() {
    // Two blocks whose facing corner cells have centres offset by (2, 2):
    // squares see a √2 gap, discs √8 − 1 ≈ 1.83 (bin 1.5).
    let mut t = Terrain::paper();
    block(&mut t, 0..30, 28..32);
    block(&mut t, 31..60, 33..37);
    near(squares(&t), 2f64.sqrt(), 0.25);
    let w = min_path_width(&t);
    near(w, 8f64.sqrt() - 1.0, 0.25);
    assert!((1.5..2.0).contains(&w), "{w}");
    // Centres offset (4, 2): √20 − 1 ≈ 3.47, the "3.5 corridor" (bin 3 by a hair).
    let mut t = Terrain::paper();
    block(&mut t, 0..30, 26..30);
    block(&mut t, 33..60, 31..35);
    near(min_path_width(&t), 3.5, 0.25);
    near(min_path_width(&t), 20f64.sqrt() - 1.0, 0.25);
    // Centres offset (5, 3): √34 − 1 ≈ 4.83 (bin 4.5).
    let mut t = Terrain::paper();
    block(&mut t, 0..30, 26..30);
    block(&mut t, 34..60, 32..36);
    let w = min_path_width(&t);
    near(w, 34f64.sqrt() - 1.0, 0.25);
    assert!((4.5..5.0).contains(&w), "{w}");
}

#[test]
fn long_winding_one_cell_corridor() {
    // A thick wall rows 25..35 with an S-shaped 1-cell corridor through it.
    let mut t = Terrain::paper();
    block(&mut t, 0..60, 25..35);
    for iy in 25..30 {
        t.set_blocked(20, iy, false);
    }
    for ix in 20..=40 {
        t.set_blocked(ix, 29, false);
    }
    for iy in 29..35 {
        t.set_blocked(40, iy, false);
    }
    assert!(is_connected(&t));
    near(min_path_width(&t), 1.0, 0.25);
}

#[test]
fn diagonal_bottleneck() {
    // Left block: cells x 0..30, y 28..32 (top-right corner (30, 32)).
    // Right block: cells x 32..60, y 35..39 (bottom-left corner (32, 35)).
    // Between them every path passes the corner-to-corner segment, offset
    // (2, 3): true width √13 ≈ 3.606; the 0.25 lattice reads √12.5 ≈ 3.536
    // (both in bin 3.5).
    let mut t = Terrain::paper();
    block(&mut t, 0..30, 28..32);
    block(&mut t, 32..60, 35..39);
    let w = squares(&t);
    near(w, 13f64.sqrt(), 0.25);
    near(w, 12.5f64.sqrt(), 1e-12);
    assert!((3.5..4.0).contains(&w), "{w}");
    // A finer lattice gets closer to √13.
    let fine = crate::terrain::width::min_path_width_sampled(&t, 16, WidthModel::Squares);
    assert!(fine > w && fine <= 13f64.sqrt() + 1e-12, "{fine}");
    // Discs: the corner cells' centres are (3, 4) apart → 5 − 1 = 4; the
    // lattice path cannot follow the gate's bisector exactly and reads 3.95.
    let d = min_path_width(&t);
    near(d, 4.0, 0.25);
    assert!(d <= 4.0, "{d}");
}

#[test]
fn blocked_terrain_has_width_zero() {
    let t = wall_with_gap(0..0);
    assert!(!is_connected(&t));
    assert_eq!(min_path_width(&t), 0.0);
    // A diagonal-only leak lets no disc of positive size through squares,
    // and only a sub-unit one (√2 − 1) between inscribed discs.
    let mut u = Terrain::paper();
    block(&mut u, 0..30, 30..31);
    block(&mut u, 30..60, 31..32);
    assert_eq!(squares(&u), 0.0);
    let leak = min_path_width(&u);
    assert!(leak > 0.0 && leak < 1.0, "{leak}");
}

#[test]
fn free_terrain_is_capped() {
    assert_eq!(min_path_width(&Terrain::paper()), 2.0 * MAX_CLEARANCE);
}

#[test]
fn start_near_the_border_is_limited_by_it() {
    let mut t = Terrain::paper();
    t.set_start(Vec2::new(1.5, 30.5));
    near(min_path_width(&t), 3.0, 1e-12);
    t.set_start(Vec2::new(0.0, 30.0));
    assert_eq!(min_path_width(&t), 0.0);
}

#[test]
fn start_or_goal_inside_a_blocked_cell() {
    let mut t = Terrain::paper();
    t.set_blocked(44, 44, true);
    assert_eq!(min_path_width(&t), 0.0);
}

#[test]
fn feasible_means_at_least_one() {
    let p = crate::terrain::GenParams::default();
    for seed in 0..300 {
        let g = crate::terrain::generate(seed, &p);
        let w = min_path_width(&g.terrain);
        if g.feasible {
            assert!(w >= 1.0, "seed {seed}: feasible but width {w}");
        } else {
            assert!(w < 1.0, "seed {seed}: infeasible but width {w}");
        }
    }
}

/// Brute force on the same lattice: f64 distances to every blocked square and
/// the border, then the largest level whose samples connect start and goal.
fn brute_force_width(t: &Terrain, q: usize, model: WidthModel) -> f64 {
    let (nx, ny) = (t.width() * q + 1, t.height() * q + 1);
    let step = 1.0 / q as f64;
    let mut clear = vec![0.0f64; nx * ny];
    for j in 0..ny {
        for i in 0..nx {
            let (x, y) = (i as f64 * step, j as f64 * step);
            let mut d = x.min(y).min(t.width() as f64 - x).min(t.height() as f64 - y);
            for iy in 0..t.height() {
                for ix in 0..t.width() {
                    if t.cell_blocked(ix, iy) {
                        let c = match model {
                            WidthModel::Squares => {
                                let dx = (ix as f64 - x).max(x - ix as f64 - 1.0).max(0.0);
                                let dy = (iy as f64 - y).max(y - iy as f64 - 1.0).max(0.0);
                                dx.hypot(dy)
                            }
                            WidthModel::Discs => (ix as f64 + 0.5 - x).hypot(iy as f64 + 0.5 - y) - 0.5,
                        };
                        d = d.min(c.max(0.0));
                    }
                }
            }
            clear[j * nx + i] = d.min(MAX_CLEARANCE);
        }
    }
    let node = |p: Vec2| (p.y * q as f64).round() as usize * nx + (p.x * q as f64).round() as usize;
    let (s, g) = (node(t.start()), node(t.goal()));
    let mut levels: Vec<f64> = clear.iter().copied().filter(|&c| c > 0.0).collect();
    levels.sort_by(|a, b| b.total_cmp(a));
    levels.dedup();
    for level in levels {
        let mut seen = vec![false; clear.len()];
        let mut stack = vec![s];
        seen[s] = clear[s] >= level;
        while let Some(u) = stack.pop().filter(|_| seen[s]) {
            let (i, j) = ((u % nx) as i64, (u / nx) as i64);
            for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)] {
                let (a, b) = (i + di, j + dj);
                if a >= 0 && b >= 0 && (a as usize) < nx && (b as usize) < ny {
                    let v = b as usize * nx + a as usize;
                    if !seen[v] && clear[v] >= level {
                        seen[v] = true;
                        stack.push(v);
                    }
                }
            }
        }
        if seen[g] {
            return 2.0 * level;
        }
    }
    0.0
}

#[test]
fn matches_brute_force_on_random_small_terrains() {
    use crate::terrain::width::min_path_width_sampled;
    use rand::{Rng, SeedableRng};
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
    let mut nonzero = 0;
    for case in 0..60 {
        let (w, h) = (rng.gen_range(6..16), rng.gen_range(6..16));
        let mut t = Terrain::new(w, h);
        let density = rng.gen_range(0.05..0.35);
        for iy in 0..h {
            for ix in 0..w {
                t.set_blocked(ix, iy, rng.gen_bool(density));
            }
        }
        let cell = |rng: &mut rand_xoshiro::Xoshiro256PlusPlus| {
            Vec2::new(rng.gen_range(0..w) as f64 + 0.5, rng.gen_range(0..h) as f64 + 0.5)
        };
        t.set_start(cell(&mut rng));
        t.set_goal(cell(&mut rng));
        for (q, model) in [
            (1, WidthModel::Squares),
            (2, WidthModel::Squares),
            (4, WidthModel::Squares),
            (2, WidthModel::Discs),
            (4, WidthModel::Discs),
        ] {
            let fast = min_path_width_sampled(&t, q, model);
            let slow = brute_force_width(&t, q, model);
            assert!((fast - slow).abs() < 1e-9, "case {case}, q {q}, {model:?}: {fast} vs {slow}");
            nonzero += usize::from(fast > 0.0);
        }
    }
    assert!(nonzero > 30, "too few connected cases ({nonzero}) to mean anything");
}
