//! Point kinematics of a simulated robot (paper §IV-A): 1 unit/s straight,
//! π/6 rad/s turning in place, dt = 0.1 s.
//!
//! The heading is kept as an exact index `k` into a table of the headings
//! θ0 + k·δ (δ = turn rate · dt, θ0 the heading the robot was placed with),
//! not as a float that accumulates rounding: turning left then right gives
//! back the very same heading, the table's cos/sin save two libm calls per
//! straight step, and a robot's whole state is small and exactly comparable
//!. This needs δ to divide the
//! full circle — true for the paper's π/60 (120 headings).

use crate::Vec2;
use bycoms_agent::angle::wrap;
use bycoms_agent::Motion;
use core::f64::consts::TAU;

/// Speed, turn rate and control period.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Kinematics {
    /// Straight-line speed, units/s.
    pub speed: f64,
    /// Turning rate, rad/s.
    pub turn_rate: f64,
    /// Control period, s.
    pub dt: f64,
}

impl Kinematics {
    pub fn paper() -> Self {
        Self { speed: 1.0, turn_rate: core::f64::consts::PI / 6.0, dt: 0.1 }
    }

    /// Simulated time of `steps` periods, s. With a whole number of periods
    /// per second (the paper's 10) it divides, so 6 periods print as 0.6 s
    /// rather than 0.6000000000000001.
    pub fn time_of(&self, steps: u64) -> f64 {
        let per_second = 1.0 / self.dt;
        if libm::fabs(per_second - libm::round(per_second)) < 1e-9 {
            steps as f64 / libm::round(per_second)
        } else {
            steps as f64 * self.dt
        }
    }

    /// How many turn steps make a full circle, if that is a whole number.
    pub fn headings_per_turn(&self) -> Option<u32> {
        let n = TAU / (self.turn_rate * self.dt);
        let r = libm::round(n);
        ((4.0..=100_000.0).contains(&r) && libm::fabs(n - r) < 1e-9).then_some(r as u32)
    }
}

/// The headings a robot placed with heading θ0 can take, with their steps.
#[derive(Clone, Debug, PartialEq)]
pub struct HeadingTable {
    theta: Vec<f64>,
    dx: Vec<f64>,
    dy: Vec<f64>,
}

impl HeadingTable {
    /// Table for initial heading `theta0`; `None` if the turn step does not
    /// divide the circle.
    pub fn new(kin: &Kinematics, theta0: f64) -> Option<Self> {
        let n = kin.headings_per_turn()?;
        let delta = kin.turn_rate * kin.dt;
        let step = kin.speed * kin.dt;
        let mut t = HeadingTable { theta: Vec::new(), dx: Vec::new(), dy: Vec::new() };
        for k in 0..n {
            let th = wrap(theta0 + f64::from(k) * delta);
            t.theta.push(th);
            t.dx.push(step * libm::cos(th));
            t.dy.push(step * libm::sin(th));
        }
        Some(t)
    }

    pub fn len(&self) -> u32 {
        self.theta.len() as u32
    }

    pub fn is_empty(&self) -> bool {
        self.theta.is_empty()
    }

    #[inline]
    pub fn heading(&self, k: u32) -> f64 {
        self.theta[k as usize]
    }

    /// Where one straight period from `p` with heading `k` ends: the one
    /// place this addition is done ([`Body::apply`], and the runner's
    /// look-ahead), so both get the same bits.
    #[inline]
    pub fn advance(&self, p: Vec2, k: u32) -> Vec2 {
        Vec2::new(p.x + self.dx[k as usize], p.y + self.dy[k as usize])
    }
}

/// A point robot's physical state: position and heading index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BodyState {
    /// Position bits (x, y) — exact comparison, no float equality pitfalls.
    pub x_bits: u64,
    pub y_bits: u64,
    /// Heading index into the robot's [`HeadingTable`].
    pub k: u32,
}

/// A simulated point robot's body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    pub pos: Vec2,
    pub k: u32,
}

impl Body {
    /// A body at `pos` facing the table's initial heading.
    pub fn new(pos: Vec2) -> Self {
        Self { pos, k: 0 }
    }

    #[inline]
    pub fn heading(&self, table: &HeadingTable) -> f64 {
        table.heading(self.k)
    }

    /// Applies one period's motion.
    #[inline]
    pub fn apply(&mut self, motion: Motion, table: &HeadingTable) {
        let n = table.len();
        match motion {
            Motion::Straight => self.pos = table.advance(self.pos, self.k),
            Motion::TurnCcw => self.k = if self.k + 1 == n { 0 } else { self.k + 1 },
            Motion::TurnCw => self.k = if self.k == 0 { n - 1 } else { self.k - 1 },
        }
    }

    pub fn state(&self) -> BodyState {
        BodyState { x_bits: self.pos.x.to_bits(), y_bits: self.pos.y.to_bits(), k: self.k }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::{FRAC_PI_4, PI};

    #[test]
    fn time_of_steps_is_exact_for_whole_rates() {
        assert_eq!(Kinematics::paper().time_of(6).to_string(), "0.6");
        assert_eq!(Kinematics::paper().time_of(100_000), 10_000.0);
    }

    #[test]
    fn paper_kinematics_has_120_headings() {
        assert_eq!(Kinematics::paper().headings_per_turn(), Some(120));
        let odd = Kinematics { turn_rate: 1.0, ..Kinematics::paper() };
        assert_eq!(odd.headings_per_turn(), None);
    }

    #[test]
    fn straight_moves_a_tenth_turns_a_sixtieth_of_pi() {
        let kin = Kinematics::paper();
        let t = HeadingTable::new(&kin, FRAC_PI_4).unwrap();
        let mut b = Body::new(Vec2::new(15.5, 15.5));
        b.apply(Motion::Straight, &t);
        assert!((b.pos.distance(Vec2::new(15.5, 15.5)) - 0.1).abs() < 1e-12);
        b.apply(Motion::TurnCcw, &t);
        assert!((b.heading(&t) - (FRAC_PI_4 + PI / 60.0)).abs() < 1e-12);
        let before = b.state();
        b.apply(Motion::TurnCw, &t);
        b.apply(Motion::TurnCcw, &t);
        assert_eq!(b.state(), before, "left then right is exactly the same heading");
        for _ in 0..120 {
            b.apply(Motion::TurnCw, &t);
        }
        assert_eq!(b.state(), before, "a full circle of turns comes back exactly");
    }
}
