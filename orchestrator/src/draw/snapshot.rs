//! The snapshot of one run as the paper draws it (`fig:exp_sample`,
//! `fig:sim_result`): terrain (impassable cells dark slate), start (cross),
//! goal (star), every robot's trajectory and number, the beacons with their
//! ε circles, and the purple contours of the beacons' potential field
//! g = c Σ 1/d² — the field a moving robot senses (the threshold contour
//! g = g_th = 1/ε² drawn bold: the "virtual wall" it turns along). Below the
//! arena a scale bar and a legend.
//!
//! [`render_strip`] draws the same at several moments side by side, like
//! the panels of `fig:sim_result`; the moments come from the recorded
//! trajectories ([`super::timeline`]), not from re-running.

use super::contour::Grid;
use super::svg::{number, text_width, Svg};
use super::timeline::{robots_at, RobotAt};
use bycoms_sim::runner::RunResult;
use bycoms_sim::terrain::Terrain;
use bycoms_sim::Vec2;

/// Pixels per cell.
const SCALE: f64 = 10.0;
/// Room for the two title lines above the arena.
const TOP: f64 = 46.0;
const MARGIN: f64 = 10.0;
const GAP: f64 = 16.0;
const PALETTE: &[&str] =
    &["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"];
const CONTOUR: &str = "#7b2fbe";
/// Impassable cells: dark slate, so a wall reads as a wall under the contours.
pub const BLOCKED: &str = "#4d5d6e";
/// Contour levels as multiples of the threshold g_th (1 is drawn bold).
const LEVELS: [f64; 3] = [0.25, 1.0, 4.0];
const LEGEND_FONT: f64 = 11.0;
const LEGEND_ROW: f64 = 18.0;

/// What to draw besides the run itself.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Draw the potential contours.
    pub contours: bool,
    /// The field constant c of g = c/d² (the paper's c = 1).
    pub field_constant: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self { contours: true, field_constant: 1.0 }
    }
}

/// Renders the run as an SVG document with a two-line title (the end of the run).
pub fn render(terrain: &Terrain, result: &RunResult, eps: f64, title: [&str; 2]) -> String {
    render_with(terrain, result, eps, title, &Options::default())
}

/// [`render`] with options.
pub fn render_with(
    terrain: &Terrain,
    result: &RunResult,
    eps: f64,
    title: [&str; 2],
    opts: &Options,
) -> String {
    let arena_w = terrain.width() as f64 * SCALE;
    let width = arena_w.max(legend_width()) + 2.0 * MARGIN;
    let legend_top = TOP + terrain.height() as f64 * SCALE + GAP;
    let height = legend_top + legend_height(width - 2.0 * MARGIN) + MARGIN;
    let mut svg = Svg::new(width, height);
    svg.text(MARGIN, 18.0, 13.0, "start", title[0]);
    svg.text(MARGIN, 36.0, 13.0, "start", title[1]);
    panel(&mut svg, MARGIN, TOP, terrain, result, eps, result.steps, opts);
    scale_and_legend(&mut svg, MARGIN, legend_top, width - 2.0 * MARGIN, terrain, eps);
    svg.finish()
}

/// The run at several moments (global control periods `steps`), side by
/// side, each captioned with its time `captions[i]`; one legend below.
pub fn render_strip(
    terrain: &Terrain,
    result: &RunResult,
    eps: f64,
    title: [&str; 2],
    moments: &[(u64, String)],
    opts: &Options,
) -> String {
    let arena_w = terrain.width() as f64 * SCALE;
    let arena_h = terrain.height() as f64 * SCALE;
    let panels = moments.len().max(1) as f64;
    let strip_w = panels * arena_w + (panels - 1.0) * GAP;
    let width = strip_w.max(legend_width()) + 2.0 * MARGIN;
    let caption = 18.0;
    let legend_top = TOP + caption + arena_h + GAP;
    let height = legend_top + legend_height(width - 2.0 * MARGIN) + MARGIN;
    let mut svg = Svg::new(width, height);
    svg.text(MARGIN, 18.0, 13.0, "start", title[0]);
    svg.text(MARGIN, 36.0, 13.0, "start", title[1]);
    for (i, (step, label)) in moments.iter().enumerate() {
        let x = MARGIN + i as f64 * (arena_w + GAP);
        svg.open_group(&format!("moment-{}", i + 1));
        svg.text(x + arena_w / 2.0, TOP + 12.0, 12.0, "middle", label);
        panel(&mut svg, x, TOP + caption, terrain, result, eps, *step, opts);
        svg.close_group();
    }
    scale_and_legend(&mut svg, MARGIN, legend_top, width - 2.0 * MARGIN, terrain, eps);
    svg.finish()
}

/// Maps world points into the panel whose top-left corner is (ox, oy).
fn to_px(ox: f64, oy: f64, height: f64) -> impl Fn(Vec2) -> (f64, f64) {
    move |p: Vec2| (ox + p.x * SCALE, oy + (height - p.y) * SCALE)
}

/// One arena at global step `step`, top-left corner at (ox, oy).
#[allow(clippy::too_many_arguments)]
fn panel(
    svg: &mut Svg,
    ox: f64,
    oy: f64,
    terrain: &Terrain,
    result: &RunResult,
    eps: f64,
    step: u64,
    opts: &Options,
) {
    let (w, h) = (terrain.width() as f64, terrain.height() as f64);
    let px = to_px(ox, oy, h);
    svg.rect(ox, oy, w * SCALE, h * SCALE, r##"fill="none" stroke="#444" stroke-width="1""##);
    blocked_cells(svg, terrain, &px);
    let robots = robots_at(result, step);
    if opts.contours {
        contours(svg, terrain, &robots, eps, opts.field_constant, &px);
    }
    for robot in &robots {
        let colour = PALETTE[(robot.id as usize - 1) % PALETTE.len()];
        // By number: a robot lost before deployment leaves a gap in the ids.
        if let Some(run) = result.robots.iter().find(|r| r.id == robot.id) {
            let walked = &run.trajectory[..robot.trail.min(run.trajectory.len())];
            let pts = decimate(walked, 0.2);
            svg.polyline(pts.iter().map(|&p| px(p)), &format!(r#"stroke="{colour}" stroke-width="1.2""#));
        }
    }
    for robot in &robots {
        let colour = PALETTE[(robot.id as usize - 1) % PALETTE.len()];
        let (x, y) = px(robot.position);
        if robot.stuck {
            let style = format!(r#"fill="none" stroke="{colour}" stroke-dasharray="4 3""#);
            svg.circle(x, y, eps * SCALE, &style);
        }
        svg.circle(x, y, 3.5, &format!(r##"fill="{colour}" stroke="#000" stroke-width="0.5""##));
        let label = robot.id.to_string();
        let (lx, ly) = number_spot((x, y), &label, px(terrain.goal()));
        svg.raw(&format!(
            r#"<text x="{lx:.2}" y="{ly:.2}" font-family="sans-serif" font-size="{NUMBER_FONT}" fill="black" stroke="white" stroke-width="2" paint-order="stroke" class="robot-number">{label}</text>"#,
        ));
    }
    start_mark(svg, px(terrain.start()));
    goal_mark(svg, px(terrain.goal()));
}

/// Font size of the robot numbers.
const NUMBER_FONT: f64 = 9.0;
/// Outer radius of the goal star, px.
const STAR: f64 = 9.0;

/// Where a robot's number goes: up and right of the robot, or, if that
/// would cover the goal star (the robot that arrived sits on it), the
/// first other corner that does not; else beside the star.
fn number_spot((x, y): (f64, f64), label: &str, (gx, gy): (f64, f64)) -> (f64, f64) {
    let w = text_width(label, NUMBER_FONT);
    let clear = |(lx, ly): (f64, f64)| {
        // The label's box (baseline at ly) against the star's, with 1 px to spare.
        let (x0, y0, x1, y1) = (lx, ly - NUMBER_FONT, lx + w, ly + 0.25 * NUMBER_FONT);
        x1 < gx - STAR - 1.0 || x0 > gx + STAR + 1.0 || y1 < gy - STAR - 1.0 || y0 > gy + STAR + 1.0
    };
    [(x + 4.5, y - 4.5), (x - 4.5 - w, y - 4.5), (x + 4.5, y + 12.0), (x - 4.5 - w, y + 12.0)]
        .into_iter()
        .find(|&spot| clear(spot))
        .unwrap_or((gx + STAR + 2.0, gy - STAR - 2.0))
}

/// Impassable cells, one rectangle per horizontal run.
fn blocked_cells(svg: &mut Svg, terrain: &Terrain, px: &impl Fn(Vec2) -> (f64, f64)) {
    for iy in 0..terrain.height() {
        let mut ix = 0;
        while ix < terrain.width() {
            if terrain.cell_blocked(ix, iy) {
                let start = ix;
                while ix < terrain.width() && terrain.cell_blocked(ix, iy) {
                    ix += 1;
                }
                let (x, y) = px(Vec2::new(start as f64, iy as f64 + 1.0));
                svg.rect(x, y, (ix - start) as f64 * SCALE, SCALE, &format!(r#"fill="{BLOCKED}""#));
            } else {
                ix += 1;
            }
        }
    }
}

/// The contours of the stuck robots' field (what a moving robot senses).
fn contours(
    svg: &mut Svg,
    terrain: &Terrain,
    robots: &[RobotAt],
    eps: f64,
    c: f64,
    px: &impl Fn(Vec2) -> (f64, f64),
) {
    let beacons: Vec<Vec2> = robots.iter().filter(|r| r.stuck).map(|r| r.position).collect();
    if beacons.is_empty() {
        return;
    }
    let mut grid = Grid::new(terrain.width(), terrain.height());
    for &b in &beacons {
        grid.add_source(b, c);
    }
    let threshold = c / (eps * eps);
    svg.open_group("potential-contours");
    for level in LEVELS {
        let mut d = String::new();
        for (a, b) in grid.isoline(threshold * level) {
            let ((x1, y1), (x2, y2)) = (px(a), px(b));
            d.push_str(&format!("M{x1:.1},{y1:.1}L{x2:.1},{y2:.1}"));
        }
        let width = if level == 1.0 { 1.4 } else { 0.6 };
        svg.raw(&format!(
            r#"<path d="{d}" fill="none" stroke="{CONTOUR}" stroke-width="{width}" data-level="{}"/>"#,
            threshold * level
        ));
    }
    svg.close_group();
}

fn start_mark(svg: &mut Svg, (sx, sy): (f64, f64)) {
    let d = 6.0;
    svg.line(sx - d, sy - d, sx + d, sy + d, r#"stroke="black" stroke-width="2""#);
    svg.line(sx - d, sy + d, sx + d, sy - d, r#"stroke="black" stroke-width="2""#);
}

fn goal_mark(svg: &mut Svg, (gx, gy): (f64, f64)) {
    svg.polygon(star(gx, gy, STAR, 4.0), r##"fill="#ffd700" stroke="black" stroke-width="1""##);
}

const LEGEND: [&str; 7] = [
    "start",
    "goal",
    "robot (number: deployment order)",
    "trajectory",
    "stuck robot (beacon), ε circle",
    "impassable cell",
    "potential contours (bold: g = 1/ε²)",
];

fn legend_item_width() -> f64 {
    LEGEND.iter().map(|l| text_width(l, LEGEND_FONT)).fold(0.0, f64::max) + 32.0
}

fn legend_width() -> f64 {
    legend_item_width()
}

fn legend_columns(width: f64) -> usize {
    ((width / legend_item_width()).floor() as usize).clamp(1, LEGEND.len())
}

/// Scale bar row plus legend rows.
fn legend_height(width: f64) -> f64 {
    let rows = LEGEND.len().div_ceil(legend_columns(width));
    LEGEND_ROW * (1 + rows) as f64
}

/// A scale bar of a round number of cells, then the legend in columns.
fn scale_and_legend(svg: &mut Svg, x: f64, y: f64, width: f64, terrain: &Terrain, eps: f64) {
    let cells = [1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0]
        .into_iter()
        .rfind(|&c| c <= terrain.width() as f64 / 3.0)
        .unwrap_or(1.0);
    svg.open_group("scale-bar");
    let (bx, by) = (x, y + 6.0);
    svg.line(bx, by, bx + cells * SCALE, by, r#"stroke="black" stroke-width="2""#);
    for tick in [bx, bx + cells * SCALE] {
        svg.line(tick, by - 4.0, tick, by + 4.0, r#"stroke="black" stroke-width="1.5""#);
    }
    let label =
        format!("{} cell{} (ε = {})", number(cells), if cells == 1.0 { "" } else { "s" }, number(eps));
    svg.text(bx + cells * SCALE + 8.0, by + 4.0, LEGEND_FONT, "start", &label);
    svg.close_group();
    svg.open_group("legend");
    let columns = legend_columns(width);
    let item_w = legend_item_width();
    for (i, label) in LEGEND.iter().enumerate() {
        let ix = x + (i % columns) as f64 * item_w;
        let iy = y + LEGEND_ROW * (1 + i / columns) as f64 + 4.0;
        let (cx, cy) = (ix + 10.0, iy);
        match i {
            0 => {
                let d = 5.0;
                svg.line(cx - d, cy - d, cx + d, cy + d, r#"stroke="black" stroke-width="2""#);
                svg.line(cx - d, cy + d, cx + d, cy - d, r#"stroke="black" stroke-width="2""#);
            }
            1 => goal_mark(svg, (cx, cy)),
            2 => svg.circle(
                cx,
                cy,
                3.5,
                &format!(r##"fill="{}" stroke="#000" stroke-width="0.5""##, PALETTE[0]),
            ),
            3 => svg.line(
                cx - 9.0,
                cy,
                cx + 9.0,
                cy,
                &format!(r#"stroke="{}" stroke-width="1.2""#, PALETTE[0]),
            ),
            4 => {
                svg.circle(
                    cx,
                    cy,
                    6.0,
                    &format!(r#"fill="none" stroke="{}" stroke-dasharray="3 2""#, PALETTE[1]),
                );
                svg.circle(
                    cx,
                    cy,
                    3.0,
                    &format!(r##"fill="{}" stroke="#000" stroke-width="0.5""##, PALETTE[1]),
                );
            }
            5 => svg.rect(cx - 5.0, cy - 5.0, 10.0, 10.0, &format!(r#"fill="{BLOCKED}""#)),
            _ => svg.line(cx - 9.0, cy, cx + 9.0, cy, &format!(r#"stroke="{CONTOUR}" stroke-width="1.4""#)),
        }
        svg.text(ix + 24.0, iy + 4.0, LEGEND_FONT, "start", label);
    }
    svg.close_group();
}

/// Keeps the first and last points and every point at least `min_step` from the last kept one.
pub fn decimate(points: &[Vec2], min_step: f64) -> Vec<Vec2> {
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
