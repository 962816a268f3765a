//! The snapshot of one run as the paper draws it (`fig:exp_sample`,
//! `fig:sim_result`): terrain (impassable cells dark slate), start (cross),
//! goal (star), every robot's trajectory and number, the beacons with their
//! ε circles, and the purple contours of the beacons' potential field
//! g = c Σ 1/d² — the field a moving robot senses (the threshold contour
//! g = g_th = 1/ε² drawn bold: the "virtual wall" it turns along). Below the
//! arena a scale bar and a legend.
//!
//! A lab's run (metres) is drawn in its room when the lab's scenario is
//! known ([`Options::room`]): the room's own size, not the whole metres
//! the launch's terrain rounds it up to, and its frames, which the launch's
//! terrain does not hold (the orchestrator knows no obstacle), so robots
//! stuck at a frame are drawn against it. A stuck robot is ringed (its ε
//! circle in cells, a fixed ring in metres), as the legend shows. A robot
//! with a real body ([`Options::real`]: a lab's, or a mixed swarm's real
//! members) is a square, a simulated one a dot, so a mixed swarm's picture
//! shows which were which.
//!
//! [`render_strip`] draws the same at several moments side by side, like
//! the panels of `fig:sim_result`; the moments come from the recorded
//! trajectories ([`super::timeline`]), not from re-running.

use super::contour::Grid;
use super::svg::{number, text_width, Svg};
use super::timeline::{robots_at, RobotAt};
use bycoms_lab::scenario::Scenario;
use bycoms_sim::runner::RunResult;
use bycoms_sim::terrain::Terrain;
use bycoms_sim::Vec2;

/// Pixels per unit (cell or metre) at least: the paper's 60-cell grid at 600 px.
const SCALE: f64 = 10.0;
/// A small arena (a lab's room of a few metres) is enlarged to about this
/// many pixels on its longer side.
const ARENA_PX: f64 = 600.0;
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

/// What a unit of the world is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Unit {
    /// A grid cell of the simulated world (ε, contours: the simulator's).
    #[default]
    Cell,
    /// A metre of a lab: real robots, whose fields are their own, so no ε
    /// circles or contours of the simulator's field are drawn.
    Metre,
}

/// What to draw besides the run itself.
#[derive(Debug, Clone, Copy)]
pub struct Options<'a> {
    /// Draw the potential contours.
    pub contours: bool,
    /// The field constant c of g = c/d² (the paper's c = 1).
    pub field_constant: f64,
    /// Cells or metres.
    pub unit: Unit,
    /// A lab's room (metres): its size and frames are drawn instead of the
    /// terrain's whole cells.
    pub room: Option<&'a Scenario>,
    /// The robots with a real body (a lab's; in a mixed swarm its real
    /// members): drawn as squares, the simulated ones as dots.
    pub real: &'a [u32],
}

impl Default for Options<'_> {
    fn default() -> Self {
        Self { contours: true, field_constant: 1.0, unit: Unit::Cell, room: None, real: &[] }
    }
}

impl<'a> Options<'a> {
    /// The options of a run in `unit`.
    pub fn in_unit(unit: Unit) -> Self {
        Self { contours: unit == Unit::Cell, unit, ..Self::default() }
    }

    /// The options of a lab's run in `room` (metres), or in `unit` without one.
    pub fn in_room(unit: Unit, room: Option<&'a Scenario>) -> Self {
        Self { room: room.filter(|_| unit == Unit::Metre), ..Self::in_unit(unit) }
    }

    /// The arena's width and height in units: the room's, else the terrain's.
    fn arena(&self, terrain: &Terrain) -> (f64, f64) {
        match self.room {
            Some(r) => (r.width, r.height),
            None => (terrain.width() as f64, terrain.height() as f64),
        }
    }
}

/// Pixels per unit for an arena of `(w, h)` units: 10, or more for a small arena.
fn scale_of((w, h): (f64, f64)) -> f64 {
    let longer = w.max(h).max(1.0);
    (ARENA_PX / longer).floor().max(SCALE)
}

/// The width the two title lines need.
fn title_width(title: [&str; 2]) -> f64 {
    title.iter().map(|t| text_width(t, 13.0)).fold(0.0, f64::max)
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
    let (w, h) = opts.arena(terrain);
    let scale = scale_of((w, h));
    let arena_w = w * scale;
    let width = arena_w.max(legend_width(opts)).max(title_width(title)) + 2.0 * MARGIN;
    let legend_top = TOP + h * scale + GAP;
    let height = legend_top + legend_height(width - 2.0 * MARGIN, opts) + MARGIN;
    let mut svg = Svg::new(width, height);
    svg.text(MARGIN, 18.0, 13.0, "start", title[0]);
    svg.text(MARGIN, 36.0, 13.0, "start", title[1]);
    panel(&mut svg, (MARGIN, TOP, scale), terrain, result, eps, result.steps, opts);
    scale_and_legend(&mut svg, (MARGIN, legend_top, scale), width - 2.0 * MARGIN, terrain, eps, opts);
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
    let (w, h) = opts.arena(terrain);
    let scale = scale_of((w, h));
    let (arena_w, arena_h) = (w * scale, h * scale);
    let panels = moments.len().max(1) as f64;
    let strip_w = panels * arena_w + (panels - 1.0) * GAP;
    let width = strip_w.max(legend_width(opts)).max(title_width(title)) + 2.0 * MARGIN;
    let caption = 18.0;
    let legend_top = TOP + caption + arena_h + GAP;
    let height = legend_top + legend_height(width - 2.0 * MARGIN, opts) + MARGIN;
    let mut svg = Svg::new(width, height);
    svg.text(MARGIN, 18.0, 13.0, "start", title[0]);
    svg.text(MARGIN, 36.0, 13.0, "start", title[1]);
    for (i, (step, label)) in moments.iter().enumerate() {
        let x = MARGIN + i as f64 * (arena_w + GAP);
        svg.open_group(&format!("moment-{}", i + 1));
        svg.text(x + arena_w / 2.0, TOP + 12.0, 12.0, "middle", label);
        panel(&mut svg, (x, TOP + caption, scale), terrain, result, eps, *step, opts);
        svg.close_group();
    }
    scale_and_legend(&mut svg, (MARGIN, legend_top, scale), width - 2.0 * MARGIN, terrain, eps, opts);
    svg.finish()
}

/// Maps world points into the panel whose top-left corner is (ox, oy), at
/// `scale` pixels per unit.
fn to_px(ox: f64, oy: f64, height: f64, scale: f64) -> impl Fn(Vec2) -> (f64, f64) {
    move |p: Vec2| (ox + p.x * scale, oy + (height - p.y) * scale)
}

/// One arena at global step `step`, top-left corner at (ox, oy), `scale`
/// pixels per unit.
fn panel(
    svg: &mut Svg,
    (ox, oy, scale): (f64, f64, f64),
    terrain: &Terrain,
    result: &RunResult,
    eps: f64,
    step: u64,
    opts: &Options,
) {
    let (w, h) = opts.arena(terrain);
    let px = to_px(ox, oy, h, scale);
    svg.rect(ox, oy, w * scale, h * scale, r##"fill="none" stroke="#444" stroke-width="1""##);
    match opts.room {
        Some(room) => frames(svg, &px, room),
        None => blocked_cells(svg, terrain, &px, scale),
    }
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
            // Its ε circle in cells; in metres (a lab's own field) a ring.
            let radius = if opts.unit == Unit::Cell { eps * scale } else { RING };
            let style =
                format!(r#"fill="none" stroke="{colour}" stroke-dasharray="4 3" class="beacon-ring""#);
            svg.circle(x, y, radius, &style);
        }
        robot_mark(svg, (x, y), colour, opts.real.contains(&robot.id));
        let label = robot.id.to_string();
        let (lx, ly) = number_spot((x, y), &label, px(terrain.goal()));
        svg.raw(&format!(
            r#"<text x="{lx:.2}" y="{ly:.2}" font-family="sans-serif" font-size="{NUMBER_FONT}" fill="black" stroke="white" stroke-width="2" paint-order="stroke" class="robot-number">{label}</text>"#,
        ));
    }
    start_mark(svg, px(terrain.start()));
    goal_mark(svg, px(terrain.goal()));
}

/// A robot at `(x, y)`: a dot, or a square when it has a `real` body.
fn robot_mark(svg: &mut Svg, (x, y): (f64, f64), colour: &str, real: bool) {
    let style = format!(r##"fill="{colour}" stroke="#000" stroke-width="0.5""##);
    if real {
        svg.rect(x - 4.0, y - 4.0, 8.0, 8.0, &format!(r#"{style} class="real-robot""#));
    } else {
        svg.circle(x, y, 3.5, &style);
    }
}

/// Font size of the robot numbers.
const NUMBER_FONT: f64 = 9.0;
/// Radius of the ring around a stuck robot of a lab (metres), px.
const RING: f64 = 8.0;

/// A lab room's frames (obstacles), `px` placing a point of the room: what
/// the robots of a lab get stuck at (`measurements` draws them too).
pub(super) fn frames(svg: &mut Svg, px: &impl Fn(Vec2) -> (f64, f64), room: &Scenario) {
    for o in &room.obstacles {
        let ((x0, y0), (x1, y1)) = (px(Vec2::new(o.x0, o.y1)), px(Vec2::new(o.x1, o.y0)));
        svg.rect(x0, y0, x1 - x0, y1 - y0, &format!(r#"class="obstacle" fill="{BLOCKED}""#));
    }
}
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
fn blocked_cells(svg: &mut Svg, terrain: &Terrain, px: &impl Fn(Vec2) -> (f64, f64), scale: f64) {
    for iy in 0..terrain.height() {
        let mut ix = 0;
        while ix < terrain.width() {
            if terrain.cell_blocked(ix, iy) {
                let start = ix;
                while ix < terrain.width() && terrain.cell_blocked(ix, iy) {
                    ix += 1;
                }
                let (x, y) = px(Vec2::new(start as f64, iy as f64 + 1.0));
                svg.rect(x, y, (ix - start) as f64 * scale, scale, &format!(r#"fill="{BLOCKED}""#));
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

const LEGEND: [&str; 8] = [
    "start",
    "goal",
    "robot (number: deployment order)",
    "trajectory",
    "stuck robot (beacon), ε circle",
    "impassable cell",
    "potential contours (bold: g = 1/ε²)",
    "robot with a real body",
];

/// The legend's entry of a real robot (index into [`LEGEND`]).
const REAL_ITEM: usize = 7;

/// The legend's entries (index into [`LEGEND`] for the swatch, label): a
/// lab's run has no ε circles, cells or contours of the simulator; a run
/// with real robots says which mark is theirs.
fn legend(opts: &Options) -> Vec<(usize, &'static str)> {
    let mut items = legend_of_unit(opts);
    if !opts.real.is_empty() {
        items.push((REAL_ITEM, LEGEND[REAL_ITEM]));
    }
    items
}

fn legend_of_unit(opts: &Options) -> Vec<(usize, &'static str)> {
    match opts.unit {
        Unit::Cell => LEGEND[..REAL_ITEM]
            .iter()
            .copied()
            .enumerate()
            .filter(|&(i, _)| i != 6 || opts.contours)
            .collect(),
        Unit::Metre => {
            let mut items = vec![
                (0, LEGEND[0]),
                (1, LEGEND[1]),
                (2, LEGEND[2]),
                (3, LEGEND[3]),
                (4, "stuck robot (beacon)"),
            ];
            if opts.room.is_some_and(|r| !r.obstacles.is_empty()) {
                items.push((5, "frame (obstacle)"));
            }
            items
        }
    }
}

fn legend_item_width(opts: &Options) -> f64 {
    legend(opts).iter().map(|(_, l)| text_width(l, LEGEND_FONT)).fold(0.0, f64::max) + 32.0
}

fn legend_width(opts: &Options) -> f64 {
    legend_item_width(opts)
}

fn legend_columns(width: f64, opts: &Options) -> usize {
    ((width / legend_item_width(opts)).floor() as usize).clamp(1, legend(opts).len())
}

/// Scale bar row plus legend rows.
fn legend_height(width: f64, opts: &Options) -> f64 {
    let rows = legend(opts).len().div_ceil(legend_columns(width, opts));
    LEGEND_ROW * (1 + rows) as f64
}

/// A scale bar of a round length (a third of the arena at most), then the
/// legend in columns.
fn scale_and_legend(
    svg: &mut Svg,
    (x, y, scale): (f64, f64, f64),
    width: f64,
    terrain: &Terrain,
    eps: f64,
    opts: &Options,
) {
    let length = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0]
        .into_iter()
        .rfind(|&c| c <= opts.arena(terrain).0 / 3.0)
        .unwrap_or(1.0);
    svg.open_group("scale-bar");
    let (bx, by) = (x, y + 6.0);
    svg.line(bx, by, bx + length * scale, by, r#"stroke="black" stroke-width="2""#);
    for tick in [bx, bx + length * scale] {
        svg.line(tick, by - 4.0, tick, by + 4.0, r#"stroke="black" stroke-width="1.5""#);
    }
    let label = match opts.unit {
        Unit::Cell => {
            format!("{} cell{} (ε = {})", number(length), if length == 1.0 { "" } else { "s" }, number(eps))
        }
        Unit::Metre => format!("{} m", number(length)),
    };
    svg.text(bx + length * scale + 8.0, by + 4.0, LEGEND_FONT, "start", &label);
    svg.close_group();
    svg.open_group("legend");
    let columns = legend_columns(width, opts);
    let item_w = legend_item_width(opts);
    for (k, (i, label)) in legend(opts).into_iter().enumerate() {
        let ix = x + (k % columns) as f64 * item_w;
        let iy = y + LEGEND_ROW * (1 + k / columns) as f64 + 4.0;
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
            REAL_ITEM => robot_mark(svg, (cx, cy), PALETTE[0], true),
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

    /// The arena frame's (x, y, width, height) in `svg`.
    fn arena(svg: &str) -> (f64, f64, f64, f64) {
        let tag = svg.split("<rect ").find(|r| r.contains(r##"fill="none" stroke="#444""##)).unwrap();
        let num = |k: &str| {
            let at = tag.find(&format!(" {k}=\"")).or_else(|| tag.find(&format!("{k}=\""))).unwrap();
            let rest = &tag[at..];
            let v = &rest[rest.find('"').unwrap() + 1..];
            v[..v.find('"').unwrap()].parse::<f64>().unwrap()
        };
        (num("x"), num("y"), num("width"), num("height"))
    }

    #[test]
    fn a_small_arena_is_drawn_large_enough_to_see() {
        // A lab's 3 m × 2 m room, in whole metres.
        let terrain = bycoms_sim::terrain::parse("...\n...\n").unwrap();
        let result = RunResult {
            success: false,
            outcome: bycoms_sim::RunOutcome::RobotsExhausted,
            steps: 0,
            time: 0.0,
            robots_used: 0,
            beacons: Vec::new(),
            robots: Vec::new(),
        };
        let svg =
            render(&terrain, &result, 3.0, ["a heading long enough to be clipped in a narrow picture", "v"]);
        let (_, _, w, h) = arena(&svg);
        assert!(w >= 400.0 && (w / h - 1.5).abs() < 1e-9, "arena {w} × {h} px");
    }

    /// Issue 49: exp-long's run drawn in its room: the frame the robots
    /// stuck at, the room's 3.5 m × 2.5 m (not the terrain's 4 × 3 whole
    /// metres), each robot numbered, each stuck one ringed, as the legend says.
    #[test]
    fn a_lab_run_is_drawn_in_its_room_with_its_frames_numbers_and_rings() {
        let room = bycoms_lab::process::load_scenario("exp-long").expect("built in");
        // The launch's terrain: the room rounded up to whole metres, no frame.
        let terrain = bycoms_sim::terrain::parse("....\n....\n....\n").unwrap();
        let run = |id: u32, end, at: Vec2| bycoms_sim::runner::RobotRun {
            id,
            end,
            position: at,
            steps: 2,
            trajectory: vec![Vec2::new(0.4, 1.0), Vec2::new(0.9, at.y), at],
        };
        use bycoms_sim::runner::RobotRunEnd::{Arrived, Stuck};
        let robots = vec![
            run(1, Stuck, Vec2::new(1.47, 1.0)),
            run(2, Stuck, Vec2::new(1.47, 1.6)),
            run(3, Arrived, Vec2::new(3.0, 1.0)),
        ];
        let result = RunResult {
            success: true,
            outcome: bycoms_sim::RunOutcome::Arrived,
            steps: 6,
            time: 0.6,
            robots_used: 3,
            beacons: vec![robots[0].position, robots[1].position],
            robots,
        };
        let svg = render_with(
            &terrain,
            &result,
            3.0,
            ["exp-long", "v"],
            &Options::in_room(Unit::Metre, Some(&room)),
        );
        let (x, y, w, h) = arena(&svg);
        assert!((w / h - 3.5 / 2.5).abs() < 1e-9, "the room's 3.5 m × 2.5 m, not 4 × 3: {w} × {h}");
        assert_eq!(
            svg.matches(r#"class="obstacle""#).count(),
            room.obstacles.len(),
            "the frame the robots stuck at"
        );
        let frame = svg.split("<rect ").find(|r| r.contains(r#"class="obstacle""#)).expect("the frame");
        let left: f64 = frame[frame.find("x=\"").unwrap() + 3..].split('"').next().unwrap().parse().unwrap();
        assert!((left - (x + 1.6 / 3.5 * w)).abs() < 1e-6, "the frame at x = 1.6 m: {frame}");
        assert!(y > 0.0);
        assert_eq!(svg.matches(r#"class="beacon-ring""#).count(), 2, "robots 1 and 2 ringed: {svg}");
        for n in 1..=3 {
            assert!(svg.contains(&format!(r#"class="robot-number">{n}</text>"#)), "robot {n} numbered");
        }
        assert!(svg.contains(">frame (obstacle)<"), "the legend names the frame");
        assert!(!svg.contains("real-robot") && !svg.contains("real body"), "no robot is marked real");
        // A mixed swarm: robots 2 and 3 real, robot 1 simulated.
        let opts = Options { real: &[2, 3], ..Options::in_room(Unit::Metre, Some(&room)) };
        let mixed = render_with(&terrain, &result, 3.0, ["exp-long", "v"], &opts);
        // Two robots and the legend's swatch.
        assert_eq!(mixed.matches(r#"class="real-robot""#).count(), 3, "robots 2 and 3 are squares: {mixed}");
        assert!(mixed.contains(">robot with a real body<"), "the legend says what a square is");
        assert_eq!(mixed.matches("<circle").count(), svg.matches("<circle").count() - 2, "two dots fewer");
    }

    #[test]
    fn a_lab_run_is_drawn_in_metres_without_the_simulators_field() {
        let terrain = bycoms_sim::terrain::parse("...\n...\n").unwrap();
        let stuck = bycoms_sim::runner::RobotRun {
            id: 1,
            end: bycoms_sim::runner::RobotRunEnd::Stuck,
            position: Vec2::new(1.4, 1.0),
            steps: 2,
            trajectory: vec![Vec2::new(0.4, 1.0), Vec2::new(0.9, 1.0), Vec2::new(1.4, 1.0)],
        };
        let result = RunResult {
            success: false,
            outcome: bycoms_sim::RunOutcome::RobotsExhausted,
            steps: 2,
            time: 0.2,
            robots_used: 1,
            beacons: vec![stuck.position],
            robots: vec![stuck],
        };
        let title = ["a lab run's heading, long enough to be clipped in a narrow picture", "v"];
        let svg = render_with(&terrain, &result, 3.0, title, &Options::in_unit(Unit::Metre));
        let bar = &svg[svg.find(r#"<g id="scale-bar">"#).unwrap()..];
        assert!(bar[..bar.find("</g>").unwrap()].contains(">1 m<"), "{svg}");
        assert!(!svg.contains("cell") && !svg.contains("ε"), "no cells, no ε: {svg}");
        assert!(!svg.contains("potential-contours"), "{svg}");
        let ring =
            svg.lines().find(|l| l.contains(r#"class="beacon-ring""#)).expect("the stuck robot ringed");
        assert!(ring.contains(&format!(r#"r="{RING:.2}""#)), "a ring, not the simulator's ε circle: {ring}");
        let width: f64 = svg[svg.find("width=\"").unwrap() + 7..].split('"').next().unwrap().parse().unwrap();
        assert!(width >= text_width(title[0], 13.0) + 2.0 * MARGIN, "the title fits in {width} px");
        let (_, _, w, _) = arena(&svg);
        assert_eq!(w, 600.0, "3 m at 200 px per metre");
    }
}
