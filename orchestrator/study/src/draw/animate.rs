//! The run as a movie, like the paper's Movie1/Movie2: an animated SVG
//! (SMIL), self-contained, that any browser plays in a loop.
//!
//! One clock drives everything: the whole run is mapped onto `seconds` of
//! movie time, and every element animates over that duration with key
//! times, so the loop restarts cleanly. Each robot appears at its
//! deployment, walks its (thinned) trajectory along a motion path and
//! stops; a stuck robot's ε circle and the bold threshold contour of the
//! beacons' field appear when it gets stuck; a bar at the bottom shows the
//! simulated time. Why SVG and not HTML + script: one file, no code to run,
//! and the same drawing primitives as the snapshot.

use super::contour::Grid;
use super::snapshot::decimate;
use super::svg::{number, Svg};
use super::timeline::first_steps;
use bycoms_sim::runner::{RobotRunEnd, RunResult};
use bycoms_sim::terrain::Terrain;
use bycoms_sim::Vec2;
use std::fmt::Write as _;

const SCALE: f64 = 10.0;
const TOP: f64 = 46.0;
const MARGIN: f64 = 10.0;
const BAR: f64 = 30.0;
const PALETTE: &[&str] =
    &["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"];

/// How the movie is made.
#[derive(Debug, Clone, Copy)]
pub struct Movie {
    /// Movie length in seconds (the whole run is fitted into it).
    pub seconds: f64,
    /// The field constant c of g = c/d².
    pub field_constant: f64,
}

/// Renders the run as an animated SVG with a two-line title. Needs the
/// run's trajectories.
pub fn render(terrain: &Terrain, result: &RunResult, eps: f64, title: [&str; 2], movie: &Movie) -> String {
    let (w, h) = (terrain.width() as f64, terrain.height() as f64);
    let mut svg = Svg::new(w * SCALE + 2.0 * MARGIN, h * SCALE + TOP + BAR + MARGIN);
    let px = |p: Vec2| (MARGIN + p.x * SCALE, TOP + (h - p.y) * SCALE);
    svg.text(MARGIN, 18.0, 13.0, "start", title[0]);
    svg.text(MARGIN, 36.0, 13.0, "start", title[1]);
    svg.rect(MARGIN, TOP, w * SCALE, h * SCALE, r##"fill="none" stroke="#444" stroke-width="1""##);
    for iy in 0..terrain.height() {
        for ix in 0..terrain.width() {
            if terrain.cell_blocked(ix, iy) {
                let (x, y) = px(Vec2::new(ix as f64, iy as f64 + 1.0));
                svg.rect(x, y, SCALE, SCALE, &format!(r#"fill="{}""#, super::snapshot::BLOCKED));
            }
        }
    }
    let total = result.steps.max(1) as f64;
    // Key time (0–1) of global step s.
    let key = |s: u64| (s as f64 / total).clamp(0.0, 1.0);
    let dur = format!("{:.3}s", movie.seconds);
    contour_frames(&mut svg, terrain, result, eps, movie.field_constant, &key, &dur, &px);
    for ((run, first), i) in result.robots.iter().zip(first_steps(result)).zip(0..) {
        let colour = PALETTE[i % PALETTE.len()];
        let (t0, t1) = (key(first), key(first + run.steps));
        let pts = decimate(&run.trajectory, 0.2);
        let mut path = String::new();
        for (k, &p) in pts.iter().enumerate() {
            let (x, y) = px(p);
            let _ = write!(path, "{}{x:.1},{y:.1}", if k == 0 { "M" } else { "L" });
        }
        let appear = format!(
            r#"<animate attributeName="opacity" values="0;1" keyTimes="0;{t0:.5}" calcMode="discrete" dur="{dur}" repeatCount="indefinite"/>"#
        );
        // The trail draws itself as the robot walks (dash offset from full to none).
        svg.raw(&format!(
            r#"<path d="{path}" fill="none" stroke="{colour}" stroke-width="1.2" pathLength="1" stroke-dasharray="1 1" stroke-dashoffset="1" opacity="0">{appear}<animate attributeName="stroke-dashoffset" values="1;1;0;0" keyTimes="0;{t0:.5};{t1:.5};1" dur="{dur}" repeatCount="indefinite"/></path>"#
        ));
        let mut robot = format!(
            r##"<g class="robot" opacity="0">{appear}<circle r="3.5" fill="{colour}" stroke="#000" stroke-width="0.5"/><text x="4.5" y="-4.5" font-family="sans-serif" font-size="9">{}</text>"##,
            run.id
        );
        if pts.len() > 1 {
            let _ = write!(
                robot,
                r#"<animateMotion path="{path}" keyPoints="0;0;1;1" keyTimes="0;{t0:.5};{t1:.5};1" calcMode="linear" dur="{dur}" repeatCount="indefinite"/>"#
            );
        } else if let Some(&p) = pts.first() {
            let (x, y) = px(p);
            let _ = write!(
                robot,
                r#"<animateMotion path="M{x:.1},{y:.1}" dur="{dur}" repeatCount="indefinite"/>"#
            );
        }
        robot.push_str("</g>");
        svg.raw(&robot);
        if run.end == RobotRunEnd::Stuck {
            let (x, y) = px(run.position);
            svg.raw(&format!(
                r#"<circle cx="{x:.2}" cy="{y:.2}" r="{:.2}" fill="none" stroke="{colour}" stroke-dasharray="4 3" opacity="0"><animate attributeName="opacity" values="0;1" keyTimes="0;{t1:.5}" calcMode="discrete" dur="{dur}" repeatCount="indefinite"/></circle>"#,
                eps * SCALE
            ));
        }
    }
    let (sx, sy) = px(terrain.start());
    svg.line(sx - 6.0, sy - 6.0, sx + 6.0, sy + 6.0, r#"stroke="black" stroke-width="2""#);
    svg.line(sx - 6.0, sy + 6.0, sx + 6.0, sy - 6.0, r#"stroke="black" stroke-width="2""#);
    let (gx, gy) = px(terrain.goal());
    let star: String = (0..10)
        .map(|i| {
            let r = if i % 2 == 0 { 9.0 } else { 4.0 };
            let a = -std::f64::consts::FRAC_PI_2 + f64::from(i) * std::f64::consts::PI / 5.0;
            format!("{:.2},{:.2} ", gx + r * a.cos(), gy + r * a.sin())
        })
        .collect();
    svg.raw(&format!(
        r##"<polygon points="{}" fill="#ffd700" stroke="black" stroke-width="1"/>"##,
        star.trim_end()
    ));
    time_bar(&mut svg, w * SCALE, TOP + h * SCALE + 8.0, result.time, &dur);
    svg.finish()
}

/// The bold threshold contour of the beacons' field, one frame per beacon
/// count, each shown from its beacon's stop to the next one's.
#[allow(clippy::too_many_arguments)]
fn contour_frames(
    svg: &mut Svg,
    terrain: &Terrain,
    result: &RunResult,
    eps: f64,
    c: f64,
    key: &impl Fn(u64) -> f64,
    dur: &str,
    px: &impl Fn(Vec2) -> (f64, f64),
) {
    let stops: Vec<(u64, Vec2)> = result
        .robots
        .iter()
        .zip(first_steps(result))
        .filter(|(r, _)| r.end == RobotRunEnd::Stuck)
        .map(|(r, first)| (first + r.steps, r.position))
        .collect();
    let mut grid = Grid::new(terrain.width(), terrain.height());
    let threshold = c / (eps * eps);
    svg.open_group("potential-contours");
    for (k, &(stop, at)) in stops.iter().enumerate() {
        grid.add_source(at, c);
        let mut d = String::new();
        for (a, b) in grid.isoline(threshold) {
            let ((x1, y1), (x2, y2)) = (px(a), px(b));
            let _ = write!(d, "M{x1:.1},{y1:.1}L{x2:.1},{y2:.1}");
        }
        let from = key(stop);
        let values = match stops.get(k + 1) {
            Some(&(next, _)) => format!(r#"values="0;1;0" keyTimes="0;{from:.5};{:.5}""#, key(next)),
            None => format!(r#"values="0;1" keyTimes="0;{from:.5}""#),
        };
        svg.raw(&format!(
            r##"<path d="{d}" fill="none" stroke="#7b2fbe" stroke-width="1.4" opacity="0"><animate attributeName="opacity" {values} calcMode="discrete" dur="{dur}" repeatCount="indefinite"/></path>"##
        ));
    }
    svg.close_group();
}

/// A bar that fills over the movie, labelled with the run's simulated time.
fn time_bar(svg: &mut Svg, width: f64, y: f64, time: f64, dur: &str) {
    svg.rect(MARGIN, y, width, 6.0, r##"fill="#eee""##);
    svg.raw(&format!(
        r##"<rect x="{MARGIN}" y="{y:.2}" width="0" height="6" fill="#555"><animate attributeName="width" values="0;{width:.2}" dur="{dur}" repeatCount="indefinite"/></rect>"##
    ));
    svg.text(MARGIN, y + 20.0, 11.0, "start", "0 s");
    svg.text(MARGIN + width, y + 20.0, 11.0, "end", &format!("{} s simulated", number(time)));
}
