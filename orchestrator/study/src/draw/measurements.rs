//! The measurement picture of a real-robot run, after the paper's
//! `fig:bag_2robots` / `fig:bag_3robots`: each robot's positions as dots in
//! its own colour (robot 1 blue, 2 red, 3 green, as the paper), the goal as
//! a star, and at every telemetry sample an arrow in the robot's measured
//! gradient direction whose length is its average microphone value V_ave.
//!
//! Why from the recording: a gateway relays every control period of its
//! robot as `FromAgent::Telemetry` (the gradient in the robot's frame, V_ave),
//! motion capture gives the poses, and a launch records both; pairing each
//! sample with its robot's latest pose puts the arrow where the robot was
//! and turns it into the arena frame (heading + gradient). Simulated agents
//! send no telemetry, so their recordings draw positions only.

use super::svg::{escape, number, Svg};
use bycoms_lab::scenario::Scenario;
use bycoms_protocol::msg::{FromAgent, Pose};
use bycoms_sim::Vec2;
use std::collections::BTreeMap;

/// Colours of robots 1, 2, 3, … (the paper's first three, then more).
pub const COLOURS: [&str; 8] =
    ["#1f5fd6", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2"];

/// One telemetry sample placed in the arena.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Where the robot was (its latest pose when the sample arrived).
    pub at: Vec2,
    /// The measured gradient direction in the arena frame, rad (none when
    /// the robot could not measure one).
    pub direction: Option<f64>,
    /// The average microphone value V_ave.
    pub v_ave: f64,
}

/// Poses and telemetry of one run, per robot.
#[derive(Clone, Debug, Default)]
pub struct Measurements {
    latest: BTreeMap<u32, Pose>,
    positions: BTreeMap<u32, Vec<Vec2>>,
    samples: BTreeMap<u32, Vec<Sample>>,
}

impl Measurements {
    /// Nothing yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// A pose from motion capture.
    pub fn pose(&mut self, pose: &Pose) {
        self.latest.insert(pose.robot.0, *pose);
        self.positions.entry(pose.robot.0).or_default().push(Vec2::new(pose.x, pose.y));
    }

    /// An agent report: telemetry is placed at its robot's latest pose
    /// (telemetry before the robot's first pose has nowhere to go).
    pub fn report(&mut self, report: &FromAgent) {
        let FromAgent::Telemetry(t) = report else { return };
        let Some(pose) = self.latest.get(&t.robot.0) else { return };
        let sample = Sample {
            at: Vec2::new(pose.x, pose.y),
            direction: t.gradient.map(|g| pose.heading + f64::from(g)),
            v_ave: f64::from(t.v_ave),
        };
        self.samples.entry(t.robot.0).or_default().push(sample);
    }

    /// The telemetry samples of robot `id`.
    pub fn samples(&self, id: u32) -> &[Sample] {
        self.samples.get(&id).map_or(&[], Vec::as_slice)
    }

    /// Whether any telemetry was placed.
    pub fn has_telemetry(&self) -> bool {
        self.samples.values().any(|s| !s.is_empty())
    }

    /// The picture (SVG), with `goal` as a star and `title` above.
    pub fn picture(&self, goal: Vec2, title: &str) -> String {
        self.picture_in(goal, title, None)
    }

    /// [`Self::picture`] in the lab's room (`room`: its outline, its
    /// obstacles such as the paper's frames, and the start), with metric
    /// axes. Arrows are thinned to one per [`ARROW_SPACING`] travelled, so a
    /// robot standing still (stuck) gets one arrow, not a fan.
    pub fn picture_in(&self, goal: Vec2, title: &str, room: Option<&Scenario>) -> String {
        let mut points: Vec<Vec2> = self.positions.values().flatten().copied().collect();
        points.push(goal);
        if let Some(r) = room {
            points.extend([Vec2::new(0.0, 0.0), Vec2::new(r.width, r.height)]);
        }
        let (mut lo, mut hi) = (Vec2::new(f64::MAX, f64::MAX), Vec2::new(f64::MIN, f64::MIN));
        for p in &points {
            lo = Vec2::new(lo.x.min(p.x), lo.y.min(p.y));
            hi = Vec2::new(hi.x.max(p.x), hi.y.max(p.y));
        }
        let span = (hi.x - lo.x).max(hi.y - lo.y).max(1e-3);
        // Arrows: the largest V_ave is a tenth of the picture.
        let v_max = self.samples.values().flatten().map(|s| s.v_ave).fold(0.0, f64::max);
        let arrow_per_v = if v_max > 0.0 { 0.1 * span / v_max } else { 0.0 };
        let margin = 0.06 * span;
        let (lo, hi) = (Vec2::new(lo.x - margin, lo.y - margin), Vec2::new(hi.x + margin, hi.y + margin));
        // The plot keeps the run's aspect (1 m is as long across as up),
        // between a quarter and 1.25 of its width high; axes left and below.
        // Below the plot: the x axis (≈ 40 px), then the legend's three lines.
        let (size, top, left, bottom) = (640.0, 40.0, 56.0, 40.0 + LEGEND_HEIGHT);
        let plot_w = size - left - 16.0;
        let scale = (plot_w / (hi.x - lo.x)).min(1.25 * plot_w / (hi.y - lo.y));
        let plot_h = ((hi.y - lo.y) * scale).max(0.25 * plot_w);
        let mid_y = (lo.y + hi.y) / 2.0;
        let px = |p: Vec2| (left + (p.x - lo.x) * scale, top + plot_h / 2.0 - (p.y - mid_y) * scale);
        let height = top + plot_h + bottom;
        let mut svg = Svg::new(size, height);
        svg.rect(0.0, 0.0, size, height, r#"fill="white""#);
        svg.text(size / 2.0, 24.0, 15.0, "middle", &escape(title));
        axes(&mut svg, &px, (lo, hi), (top, top + plot_h), span);
        if let Some(r) = room {
            draw_room(&mut svg, &px, r);
        }
        for (&id, positions) in &self.positions {
            let colour = COLOURS[(id as usize).saturating_sub(1) % COLOURS.len()];
            svg.open_group(&format!("robot-{id}"));
            for &p in positions {
                let (x, y) = px(p);
                svg.circle(x, y, 1.6, &format!(r#"fill="{colour}""#));
            }
            for s in thinned(self.samples(id)) {
                let Some(dir) = s.direction else { continue };
                let tip = Vec2::new(
                    s.at.x + dir.cos() * s.v_ave * arrow_per_v,
                    s.at.y + dir.sin() * s.v_ave * arrow_per_v,
                );
                let ((x1, y1), (x2, y2)) = (px(s.at), px(tip));
                svg.line(
                    x1,
                    y1,
                    x2,
                    y2,
                    &format!(
                        r#"class="gradient" stroke="{colour}" stroke-width="1" marker-end="url(#head)""#
                    ),
                );
            }
            svg.close_group();
        }
        let (gx, gy) = px(goal);
        let star = (0..10).map(|k| {
            let r = if k % 2 == 0 { 11.0 } else { 4.5 };
            let a = std::f64::consts::FRAC_PI_2 + k as f64 * std::f64::consts::PI / 5.0;
            (gx + r * a.cos(), gy - r * a.sin())
        });
        svg.polygon(star, r#"id="goal" fill="gold" stroke="black" stroke-width="0.8""#);
        legend(&mut svg, self.positions.keys().copied(), v_max, (size, top + plot_h + 48.0));
        svg.raw(r#"<defs><marker id="head" markerWidth="6" markerHeight="6" refX="5" refY="3" orient="auto"><path d="M0,0 L6,3 L0,6 z" fill="context-stroke"/></marker></defs>"#);
        svg.finish()
    }
}

/// The lab's room in the picture: its outline, its obstacles and the
/// start's cross, `px` placing a point of the room.
fn draw_room(svg: &mut Svg, px: &impl Fn(Vec2) -> (f64, f64), r: &Scenario) {
    svg.open_group("room");
    let ((x0, y0), (x1, y1)) = (px(Vec2::new(0.0, r.height)), px(Vec2::new(r.width, 0.0)));
    svg.rect(x0, y0, x1 - x0, y1 - y0, r##"fill="none" stroke="#444" stroke-width="1.2""##);
    super::snapshot::frames(svg, px, r);
    let (sx, sy) = px(Vec2::new(r.start.x, r.start.y));
    let d = 6.0;
    svg.line(sx - d, sy - d, sx + d, sy + d, r#"class="start" stroke="black" stroke-width="2""#);
    svg.line(sx - d, sy + d, sx + d, sy - d, r#"class="start" stroke="black" stroke-width="2""#);
    svg.close_group();
}

/// Height of the legend under the x axis: the robots' colours, then what an
/// arrow is, then its scale, one line each (on one line the caption ran over
/// the robots' names).
const LEGEND_HEIGHT: f64 = 56.0;

/// What V_ave is measured in: the firmware's V_n are a tone's unwindowed-DFT
/// magnitude, ADC counts × 256 (`FirmwareConfig::paper`: the paper's
/// V_target = 22000 is a tone of about 86 counts).
pub const V_UNIT: &str = "ADC counts × 256";

/// The legend from `(width, y)` down: each robot's colour, what an arrow
/// means, and V_ave's largest value with its unit.
fn legend(svg: &mut Svg, robots: impl Iterator<Item = u32>, v_max: f64, (width, y): (f64, f64)) {
    let mut x = 10.0;
    for id in robots {
        let colour = COLOURS[(id as usize).saturating_sub(1) % COLOURS.len()];
        let label = format!("robot {id}");
        svg.text_coloured(x, y, 12.0, "start", colour, &label);
        x += super::svg::text_width(&label, 12.0) + 14.0;
    }
    let cm = number(ARROW_SPACING * 100.0);
    let arrows = format!("arrows: the measured gradient's direction, one per {cm} cm travelled");
    svg.text(10.0, y + 17.0, 11.0, "start", &arrows);
    let scale = format!("arrow length: V_ave, the mean microphone value in {V_UNIT} (largest {v_max:.0})");
    svg.text(10.0, y + 32.0, 11.0, "start", &scale);
    debug_assert!(super::svg::text_width(&scale, 11.0) < width - 20.0, "the legend fits: {scale}");
}

/// Distance a robot travels between two arrows of the measurement picture, m.
pub const ARROW_SPACING: f64 = 0.05;

/// The samples to draw as arrows: the first, then each one taken at least
/// [`ARROW_SPACING`] from where the last drawn one was.
fn thinned(samples: &[Sample]) -> impl Iterator<Item = &Sample> {
    let mut last: Option<Vec2> = None;
    samples.iter().filter(move |s| {
        let keep = last.is_none_or(|l| l.distance(s.at) >= ARROW_SPACING - 1e-9);
        if keep {
            last = Some(s.at);
        }
        keep
    })
}

/// Metric axes along the plot's left and bottom edges: ticks at a round
/// step (a fifth of the span or less), labelled in metres.
fn axes(
    svg: &mut Svg,
    px: &impl Fn(Vec2) -> (f64, f64),
    (lo, hi): (Vec2, Vec2),
    (y_top, y_bottom): (f64, f64),
    span: f64,
) {
    let step = [0.05, 0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .find(|&s| span / s <= 8.0)
        .unwrap_or(10.0);
    let (x_left, _) = px(lo);
    let (x_right, _) = px(hi);
    svg.open_group("axes");
    let axis = r##"stroke="#444" stroke-width="1""##;
    svg.line(x_left, y_bottom, x_right, y_bottom, axis);
    svg.line(x_left, y_top, x_left, y_bottom, axis);
    let ticks = |from: f64, to: f64| {
        let first = (from / step).ceil() as i64;
        let last = (to / step).floor() as i64;
        (first..=last).map(move |k| k as f64 * step)
    };
    for x in ticks(lo.x, hi.x) {
        let (tx, _) = px(Vec2::new(x, 0.0));
        svg.line(tx, y_bottom, tx, y_bottom + 5.0, axis);
        svg.text(tx, y_bottom + 17.0, 11.0, "middle", &number(x));
    }
    for y in ticks(lo.y, hi.y) {
        let (_, ty) = px(Vec2::new(0.0, y));
        svg.line(x_left - 5.0, ty, x_left, ty, axis);
        svg.text(x_left - 8.0, ty + 4.0, 11.0, "end", &number(y));
    }
    svg.text((x_left + x_right) / 2.0, y_bottom + 33.0, 12.0, "middle", "x [m]");
    // Upright along the axis: level, it ran off the picture's left edge.
    svg.vtext(x_left - 38.0, (y_top + y_bottom) / 2.0, 12.0, "y [m]");
    svg.close_group();
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::msg::{DriveState, Telemetry};
    use bycoms_protocol::RobotId;

    fn pose(id: u32, x: f64, y: f64, heading: f64) -> Pose {
        Pose { robot: RobotId(id), x, y, heading, step: 0, time_us: 0 }
    }

    fn telemetry(id: u32, gradient: Option<f32>, v_ave: f32) -> FromAgent {
        FromAgent::Telemetry(Telemetry {
            robot: RobotId(id),
            period: 0,
            state: DriveState::Driving,
            mode: 1,
            mics: [0.0; 6],
            v_ave,
            gradient,
            left: 0.0,
            right: 0.0,
            battery_mv: 3700,
            health: 0,
            robot_drops: 0,
        })
    }

    #[test]
    fn telemetry_is_placed_at_the_latest_pose_in_the_arena_frame() {
        let mut m = Measurements::new();
        m.report(&telemetry(1, Some(0.5), 10.0)); // no pose yet: nowhere to go
        assert!(!m.has_telemetry());
        m.pose(&pose(1, 1.0, 2.0, 0.25));
        m.report(&telemetry(1, Some(0.5), 10.0));
        m.report(&telemetry(1, None, 4.0));
        let s = m.samples(1);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0], Sample { at: Vec2::new(1.0, 2.0), direction: Some(0.75), v_ave: 10.0 });
        assert_eq!(s[1].direction, None);
        m.report(&FromAgent::Heartbeat(bycoms_protocol::msg::Heartbeat { robot: RobotId(1), seq: 1 }));
        assert_eq!(m.samples(1).len(), 2, "only telemetry is a sample");
    }

    #[test]
    fn the_picture_has_a_dot_per_pose_an_arrow_per_gradient_and_the_goal() {
        let mut m = Measurements::new();
        for (id, x) in [(1, 0.0), (2, 1.0), (3, 2.0)] {
            m.pose(&pose(id, x, 0.0, 0.0));
            m.report(&telemetry(id, Some(0.0), 2.0 * x as f32 + 1.0));
            m.pose(&pose(id, x, 0.5, 0.0));
            m.report(&telemetry(id, None, 1.0));
        }
        let svg = m.picture(Vec2::new(1.0, 3.0), "exp-long");
        assert_eq!(svg.matches("<circle").count(), 6, "two positions per robot");
        assert_eq!(svg.matches(r#"class="gradient""#).count(), 3, "one arrow per measured gradient");
        for colour in &COLOURS[..3] {
            assert!(svg.contains(&format!(r#"stroke="{colour}""#)), "{colour}");
        }
        assert!(svg.contains(r#"id="goal""#));
        // Arrow length is proportional to V_ave: robot 3's (5) is 5× robot 1's (1).
        let lengths: Vec<f64> = svg
            .lines()
            .filter(|l| l.contains(r#"class="gradient""#))
            .map(|l| {
                let attr = |name: &str| -> f64 {
                    let start = l.find(&format!(r#"{name}=""#)).expect("attr") + name.len() + 2;
                    l[start..].split('"').next().expect("value").parse().expect("number")
                };
                (attr("x2") - attr("x1")).hypot(attr("y2") - attr("y1"))
            })
            .collect();
        assert!((lengths[2] / lengths[0] - 5.0).abs() < 0.05, "{lengths:?}");
    }

    #[test]
    fn a_robot_standing_still_gets_one_arrow_and_the_plot_has_metric_axes() {
        let mut m = Measurements::new();
        // 2 m driven in 1 cm steps, a sample each, then 300 samples stuck.
        for k in 0..=200 {
            m.pose(&pose(1, 0.01 * f64::from(k), 0.0, 0.0));
            m.report(&telemetry(1, Some(0.1), 5.0));
        }
        for _ in 0..300 {
            m.report(&telemetry(1, Some(2.0), 5.0));
        }
        let svg = m.picture(Vec2::new(2.5, 0.0), "exp-short");
        let arrows = svg.matches(r#"class="gradient""#).count();
        assert_eq!(arrows, 41, "one per 5 cm travelled over 2 m, none more where it stood");
        assert!(svg.contains("one per 5 cm travelled"), "the caption says so");
        for tick in [">0<", ">0.5<", ">1<", ">1.5<", ">2<"] {
            assert!(svg.contains(tick), "x axis tick {tick}");
        }
        assert!(svg.contains(">x [m]<") && svg.contains(">y [m]<"), "axis titles");
    }

    #[test]
    fn the_lab_room_its_frames_and_the_start_are_drawn() {
        let room = bycoms_lab::process::load_scenario("exp-short").expect("built-in scenario");
        let mut m = Measurements::new();
        m.pose(&pose(1, room.start.x, room.start.y, 0.0));
        let svg = m.picture_in(Vec2::new(room.goal.x, room.goal.y), "exp-short", Some(&room));
        assert!(!room.obstacles.is_empty());
        assert_eq!(svg.matches(r#"class="obstacle""#).count(), room.obstacles.len(), "every frame");
        assert_eq!(svg.matches(r#"class="start""#).count(), 2, "the start cross");
        assert!(svg.contains(r#"<g id="room">"#));
        // The whole room is on the axes: 0 to its width (3 m) along x.
        for tick in [">0<", ">3<"] {
            assert!(svg.contains(tick), "tick {tick}");
        }
    }

    /// The texts of a picture: (left x, baseline y, font size, text) of
    /// every `<text>`, the left edge from its anchor and estimated width.
    fn texts(svg: &str) -> Vec<(f64, f64, f64, String)> {
        svg.split("<text")
            .skip(1)
            .map(|t| {
                let attr = |name: &str| -> f64 {
                    let start = t.find(&format!(r#" {name}=""#)).expect("attr") + name.len() + 3;
                    t[start..].split('"').next().expect("value").parse().expect("number")
                };
                let body = t[t.find('>').expect("tag end") + 1..].split("</text>").next().expect("body");
                let (size, width) =
                    (attr("font-size"), crate::draw::svg::text_width(body, attr("font-size")));
                let left = match t.split(r#"text-anchor=""#).nth(1).and_then(|a| a.split('"').next()) {
                    Some("end") => attr("x") - width,
                    Some("middle") => attr("x") - width / 2.0,
                    _ => attr("x"),
                };
                (left, attr("y"), size, body.to_string())
            })
            .collect()
    }

    #[test]
    fn the_legend_overprints_nothing_and_says_what_v_ave_is_measured_in() {
        let mut m = Measurements::new();
        for id in 1..=3 {
            m.pose(&pose(id, f64::from(id), 0.0, 0.0));
            m.report(&telemetry(id, Some(0.0), 40215.004));
        }
        let svg = m.picture(Vec2::new(3.0, 1.0), "exp-long");
        let width: f64 = svg
            .split(r#"width=""#)
            .nth(1)
            .and_then(|w| w.split('"').next())
            .expect("width")
            .parse()
            .expect("number");
        let legend: Vec<_> = texts(&svg)
            .into_iter()
            .filter(|t| t.3.starts_with("robot ") || t.3.contains("V_ave") || t.3.contains("arrows"))
            .collect();
        assert_eq!(legend.len(), 5, "{legend:?}");
        let extent = |t: &(f64, f64, f64, String)| {
            let w = crate::draw::svg::text_width(&t.3, t.2);
            (t.0, t.0 + w, t.1 - t.2, t.1)
        };
        for (i, a) in legend.iter().enumerate() {
            let (x0, x1, y0, y1) = extent(a);
            assert!(x0 >= 0.0 && x1 <= width, "{a:?} runs off the picture ({width} px)");
            for b in &legend[i + 1..] {
                let (u0, u1, v0, v1) = extent(b);
                let apart = x1 <= u0 || u1 <= x0 || y1 <= v0 || v1 <= y0;
                assert!(apart, "{a:?} overprints {b:?}");
            }
        }
        let scale = legend.iter().find(|t| t.3.contains("V_ave")).expect("the scale");
        assert!(scale.3.contains("(largest 40215)"), "{scale:?}");
        assert!(scale.3.contains("ADC counts"), "the unit: {scale:?}");
    }
}
