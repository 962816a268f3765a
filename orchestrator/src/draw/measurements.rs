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
        let points = self.positions.values().flatten().chain(std::iter::once(&goal));
        let (mut lo, mut hi) = (Vec2::new(f64::MAX, f64::MAX), Vec2::new(f64::MIN, f64::MIN));
        for p in points {
            lo = Vec2::new(lo.x.min(p.x), lo.y.min(p.y));
            hi = Vec2::new(hi.x.max(p.x), hi.y.max(p.y));
        }
        let span = (hi.x - lo.x).max(hi.y - lo.y).max(1e-3);
        // Arrows: the largest V_ave is a tenth of the picture.
        let v_max = self.samples.values().flatten().map(|s| s.v_ave).fold(0.0, f64::max);
        let arrow_per_v = if v_max > 0.0 { 0.1 * span / v_max } else { 0.0 };
        let margin = 0.12 * span;
        let (lo, hi) = (Vec2::new(lo.x - margin, lo.y - margin), Vec2::new(hi.x + margin, hi.y + margin));
        // The plot keeps the run's aspect (1 m is as long across as up),
        // between a quarter and 1.25 of its width high.
        let (size, top) = (640.0, 40.0);
        let scale = (size / (hi.x - lo.x)).min(1.25 * size / (hi.y - lo.y));
        let plot_h = ((hi.y - lo.y) * scale).max(0.25 * size);
        let px = |p: Vec2| ((p.x - lo.x) * scale, top + plot_h / 2.0 - (p.y - (lo.y + hi.y) / 2.0) * scale);
        let size_h = plot_h;
        let mut svg = Svg::new(size, size_h + top + 30.0);
        svg.rect(0.0, 0.0, size, size_h + top + 30.0, r#"fill="white""#);
        svg.text(size / 2.0, 24.0, 15.0, "middle", &escape(title));
        for (&id, positions) in &self.positions {
            let colour = COLOURS[(id as usize).saturating_sub(1) % COLOURS.len()];
            svg.open_group(&format!("robot-{id}"));
            for &p in positions {
                let (x, y) = px(p);
                svg.circle(x, y, 1.6, &format!(r#"fill="{colour}""#));
            }
            for s in self.samples(id) {
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
        let legend: Vec<String> = self.positions.keys().map(|id| format!("robot {id}")).collect();
        for (i, (id, label)) in self.positions.keys().zip(&legend).enumerate() {
            let colour = COLOURS[(*id as usize).saturating_sub(1) % COLOURS.len()];
            svg.text_coloured(10.0 + 90.0 * i as f64, size_h + top + 20.0, 12.0, "start", colour, label);
        }
        let note = format!("arrows: measured gradient, length V_ave (max {})", number(v_max));
        svg.text(size - 10.0, size_h + top + 20.0, 11.0, "end", &escape(&note));
        svg.raw(r#"<defs><marker id="head" markerWidth="6" markerHeight="6" refX="5" refY="3" orient="auto"><path d="M0,0 L6,3 L0,6 z" fill="context-stroke"/></marker></defs>"#);
        svg.finish()
    }
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
}
