//! The snapshot of one run, like the paper's `fig:sim_result`: terrain
//! (impassable cells light blue), start (cross), goal (star), every robot's
//! trajectory, and the beacons with their ε circles.

use super::svg::Svg;
use bycoms_sim::runner::{RobotEnd, RunResult};
use bycoms_sim::terrain::Terrain;
use bycoms_sim::Vec2;

/// Pixels per cell.
const SCALE: f64 = 10.0;
/// Room for the two title lines above the arena.
const TOP: f64 = 46.0;
const MARGIN: f64 = 10.0;
const PALETTE: &[&str] =
    &["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"];

/// Renders the run as an SVG document with a two-line title.
pub fn render(terrain: &Terrain, result: &RunResult, eps: f64, title: [&str; 2]) -> String {
    let (w, h) = (terrain.width() as f64, terrain.height() as f64);
    let mut svg = Svg::new(w * SCALE + 2.0 * MARGIN, h * SCALE + TOP + MARGIN);
    let px = |p: Vec2| (MARGIN + p.x * SCALE, TOP + (h - p.y) * SCALE);
    svg.text(MARGIN, 18.0, 13.0, "start", title[0]);
    svg.text(MARGIN, 36.0, 13.0, "start", title[1]);
    svg.rect(MARGIN, TOP, w * SCALE, h * SCALE, r##"fill="none" stroke="#444" stroke-width="1""##);
    // Impassable cells, one rectangle per horizontal run.
    for iy in 0..terrain.height() {
        let mut ix = 0;
        while ix < terrain.width() {
            if terrain.cell_blocked(ix, iy) {
                let start = ix;
                while ix < terrain.width() && terrain.cell_blocked(ix, iy) {
                    ix += 1;
                }
                let (x, y) = px(Vec2::new(start as f64, iy as f64 + 1.0));
                svg.rect(x, y, (ix - start) as f64 * SCALE, SCALE, r##"fill="#a6d8f0""##);
            } else {
                ix += 1;
            }
        }
    }
    for (i, robot) in result.robots.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let pts = decimate(&robot.trajectory, 0.2);
        svg.polyline(pts.iter().map(|&p| px(p)), &format!(r#"stroke="{colour}" stroke-width="1.2""#));
    }
    for (i, robot) in result.robots.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let (x, y) = px(robot.position);
        if robot.end == RobotEnd::Stuck {
            svg.circle(
                x,
                y,
                eps * SCALE,
                &format!(r#"fill="none" stroke="{colour}" stroke-dasharray="4 3""#),
            );
        }
        svg.circle(x, y, 3.5, &format!(r##"fill="{colour}" stroke="#000" stroke-width="0.5""##));
    }
    let (sx, sy) = px(terrain.start());
    let d = 6.0;
    svg.line(sx - d, sy - d, sx + d, sy + d, r#"stroke="black" stroke-width="2""#);
    svg.line(sx - d, sy + d, sx + d, sy - d, r#"stroke="black" stroke-width="2""#);
    let (gx, gy) = px(terrain.goal());
    svg.polygon(star(gx, gy, 9.0, 4.0), r##"fill="#ffd700" stroke="black" stroke-width="1""##);
    svg.finish()
}

/// Keeps the first and last points and every point at least `min_step` from the last kept one.
fn decimate(points: &[Vec2], min_step: f64) -> Vec<Vec2> {
    let mut out: Vec<Vec2> = Vec::new();
    for (i, &p) in points.iter().enumerate() {
        let keep = match out.last() {
            None => true,
            Some(&last) => i + 1 == points.len() || last.distance(p) >= min_step,
        };
        if keep {
            out.push(p);
        }
    }
    out
}

fn star(cx: f64, cy: f64, outer: f64, inner: f64) -> Vec<(f64, f64)> {
    (0..10)
        .map(|i| {
            let r = if i % 2 == 0 { outer } else { inner };
            let a = -std::f64::consts::FRAC_PI_2 + f64::from(i) * std::f64::consts::PI / 5.0;
            (cx + r * a.cos(), cy + r * a.sin())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_ends_and_thins_the_middle() {
        let pts: Vec<Vec2> = (0..=100).map(|i| Vec2::new(f64::from(i) * 0.01, 0.0)).collect();
        let d = decimate(&pts, 0.2);
        assert_eq!(d.first(), pts.first());
        assert_eq!(d.last(), pts.last());
        assert!(d.len() <= 7, "{}", d.len());
    }
}
