//! The crawler body: differential drive with saturation and lag, and
//! "stuck on contact".
//!
//! Why this simple: the paper's robots (DFRobot Devastator tracks) are slow
//! and stop when they hit an aluminium frame or another robot; what the
//! controller must cope with is that a motor command becomes a track speed
//! only after a lag and only up to a maximum. Each track's speed follows
//! v_max · clamp(command / 255, −1, 1) with a first-order lag τ; the body
//! integrates v = (v_l + v_r)/2, ω = (v_r − v_l)/W (more left → clockwise).
//! The footprint is the microphone plate's disc (radius 0.128 m, the paper's
//! 256 mm plate); touching an obstacle rectangle, the arena's wall
//! ([`arena_walls`]) or another body's disc sticks the body where it is,
//! for good ([`Disc::moved`], the rule the ROS 2 bodies of `ros2_body`
//! share).

use serde::{Deserialize, Serialize};

/// Body parameters (scenario files: `[body]`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BodyConfig {
    /// Footprint radius, m (the 256 mm microphone plate).
    pub radius: f64,
    /// Track separation W, m.
    pub track_width: f64,
    /// Track speed at full command (±255), m/s.
    pub max_speed: f64,
    /// Track speed lag time constant, s.
    pub lag: f64,
}

impl Default for BodyConfig {
    fn default() -> Self {
        Self { radius: 0.128, track_width: 0.17, max_speed: 0.3, lag: 0.1 }
    }
}

/// An axis-aligned obstacle (an aluminium frame seen from above), m.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Obstacle {
    /// Lower-left corner x.
    pub x0: f64,
    /// Lower-left corner y.
    pub y0: f64,
    /// Upper-right corner x.
    pub x1: f64,
    /// Upper-right corner y.
    pub y1: f64,
}

impl Obstacle {
    /// Distance from (x, y) to the rectangle (0 inside).
    pub fn distance(&self, x: f64, y: f64) -> f64 {
        let dx = (self.x0 - x).max(x - self.x1).max(0.0);
        let dy = (self.y0 - y).max(y - self.y1).max(0.0);
        dx.hypot(dy)
    }
}

/// The arena's wall, `width` × `height` m from the origin, as four
/// obstacles just outside it (1 m thick): a crawler stops against it as
/// against a frame, and never leaves the arena (whose motion capture would
/// lose it).
pub fn arena_walls(width: f64, height: f64) -> [Obstacle; 4] {
    const T: f64 = 1.0;
    [
        Obstacle { x0: -T, y0: -T, x1: 0.0, y1: height + T },
        Obstacle { x0: width, y0: -T, x1: width + T, y1: height + T },
        Obstacle { x0: -T, y0: -T, x1: width + T, y1: 0.0 },
        Obstacle { x0: -T, y0: height, x1: width + T, y1: height + T },
    ]
}

/// One crawler.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crawler {
    /// Position, m.
    pub x: f64,
    /// Position, m.
    pub y: f64,
    /// Heading, rad (counter-clockwise from +x).
    pub heading: f64,
    /// Current left track speed, m/s.
    pub v_left: f64,
    /// Current right track speed, m/s.
    pub v_right: f64,
    /// Touched something: it never moves again.
    pub stuck: bool,
}

impl Crawler {
    /// A crawler at rest.
    pub fn new(x: f64, y: f64, heading: f64) -> Self {
        Self { x, y, heading, v_left: 0.0, v_right: 0.0, stuck: false }
    }

    /// Advances `dt` seconds under motor commands (left, right) in ±255;
    /// `others` are the other bodies' centres. Sticks on contact.
    pub fn step(
        &mut self,
        config: &BodyConfig,
        command: (f64, f64),
        dt: f64,
        obstacles: &[Obstacle],
        others: &[(f64, f64)],
    ) {
        if self.stuck {
            self.v_left = 0.0;
            self.v_right = 0.0;
            return;
        }
        let target = |c: f64| config.max_speed * (c / 255.0).clamp(-1.0, 1.0);
        let k = if config.lag > 0.0 { 1.0 - (-dt / config.lag).exp() } else { 1.0 };
        self.v_left += k * (target(command.0) - self.v_left);
        self.v_right += k * (target(command.1) - self.v_right);
        let v = (self.v_left + self.v_right) / 2.0;
        let w = (self.v_right - self.v_left) / config.track_width;
        let disc = Disc { x: self.x, y: self.y, heading: self.heading, radius: config.radius };
        let Some((nx, ny)) = disc.moved(v, dt, obstacles, others) else {
            self.stuck = true;
            self.v_left = 0.0;
            self.v_right = 0.0;
            return;
        };
        self.x = nx;
        self.y = ny;
        self.heading = bycoms_agent::angle::wrap(self.heading + w * dt);
    }
}

/// A body's footprint where it stands: the one collision rule of every
/// body of the lab (crawlers and ROS 2 robots alike).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disc {
    /// Centre, m.
    pub x: f64,
    /// Centre, m.
    pub y: f64,
    /// Heading, rad (counter-clockwise from +x).
    pub heading: f64,
    /// Footprint radius, m.
    pub radius: f64,
}

impl Disc {
    /// The centre after moving `v` m/s along the heading for `dt` s, or
    /// `None` when it would touch an obstacle or another body (`others`:
    /// their centres, discs of the same radius), where a body sticks.
    pub fn moved(
        &self,
        v: f64,
        dt: f64,
        obstacles: &[Obstacle],
        others: &[(f64, f64)],
    ) -> Option<(f64, f64)> {
        let (nx, ny) = (self.x + v * self.heading.cos() * dt, self.y + v * self.heading.sin() * dt);
        let hits_obstacle = obstacles.iter().any(|o| o.distance(nx, ny) < self.radius);
        let hits_body = others.iter().any(|&(ox, oy)| (nx - ox).hypot(ny - oy) < 2.0 * self.radius);
        (!hits_obstacle && !hits_body).then_some((nx, ny))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_commands_drive_straight_and_saturate() {
        let c = BodyConfig::default();
        let mut b = Crawler::new(0.0, 0.0, 0.0);
        for _ in 0..1000 {
            b.step(&c, (600.0, 600.0), 0.01, &[], &[]);
        }
        assert!((b.x - 3.0).abs() < 0.05, "{b:?}"); // ~10 s at 0.3 m/s minus the lag
        assert_eq!(b.y, 0.0);
    }

    #[test]
    fn more_left_turns_clockwise_and_contact_sticks() {
        let c = BodyConfig::default();
        let mut b = Crawler::new(0.0, 0.0, 0.0);
        b.step(&c, (200.0, 50.0), 0.1, &[], &[]);
        assert!(b.heading < 0.0);
        let wall = Obstacle { x0: 0.5, y0: -1.0, x1: 0.55, y1: 1.0 };
        let mut b = Crawler::new(0.0, 0.0, 0.0);
        for _ in 0..1000 {
            b.step(&c, (120.0, 120.0), 0.01, &[wall], &[]);
        }
        assert!(b.stuck && b.x < 0.5 - c.radius + 0.01 && b.x > 0.3, "{b:?}");
        let mut b = Crawler::new(0.0, 0.0, 0.0);
        for _ in 0..1000 {
            b.step(&c, (120.0, 120.0), 0.01, &[], &[(1.0, 0.0)]);
        }
        assert!(b.stuck && (1.0 - b.x - 2.0 * c.radius).abs() < 0.01, "{b:?}");
    }

    #[test]
    fn the_arena_wall_stops_a_crawler_inside_the_arena_on_every_side() {
        let c = BodyConfig::default();
        let walls = arena_walls(3.5, 2.5);
        for heading in [0.0, 0.5, 1.6, 3.1, -1.6, -2.5] {
            let mut b = Crawler::new(1.75, 1.25, heading);
            for _ in 0..3000 {
                b.step(&c, (255.0, 255.0), 0.01, &walls, &[]);
            }
            assert!(b.stuck, "heading {heading}: {b:?}");
            let margin = (b.x).min(3.5 - b.x).min(b.y).min(2.5 - b.y);
            assert!(margin >= c.radius - 0.01 && margin < c.radius + 0.01, "heading {heading}: {b:?}");
        }
    }
}
