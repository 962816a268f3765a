//! One simulated robot: body + the shared controller + its noise source.
//!
//! This is the single place where a simulated robot senses and acts, used
//! both by the in-process runner and by the `sim-agent` process, so the two
//! cannot drift apart. Sensing is physical: the field of the other robots at
//! the body's position (plus noise) and the goal bearing handed in from
//! outside (computed by the runner, or by the orchestrator from mocap). The
//! terrain is never an input here.

use crate::body::{Body, HeadingTable};
use crate::field::Beacons;
use crate::sensing::SensingNoise;
use crate::Vec2;
use bycoms_agent::angle::wrap;
use bycoms_agent::{Controller, ControllerConfig, Input, Mode, Output};

/// A simulated robot between deployment and stop.
#[derive(Clone, Debug)]
pub struct SimRobot {
    pub body: Body,
    controller: Controller,
    noise: Option<SensingNoise>,
    dt: f64,
}

impl SimRobot {
    /// A robot placed at `start`, facing the table's initial heading, in mode 1.
    pub fn new(start: Vec2, config: ControllerConfig, noise: Option<SensingNoise>, dt: f64) -> Self {
        Self { body: Body::new(start), controller: Controller::new(config), noise, dt }
    }

    pub fn mode(&self) -> Mode {
        self.controller.mode()
    }

    /// One control period: sense the field of `beacons`, decide, move.
    #[inline]
    pub fn step(&mut self, table: &HeadingTable, beacons: &Beacons, goal_bearing: f64) -> Output {
        let (factor, offset) = match &mut self.noise {
            Some(n) => n.draw(),
            None => (1.0, 0.0),
        };
        let sample = beacons.sample(self.body.pos);
        let intensity = sample.intensity * factor;
        // In mode 1 below threshold the controller never looks at the
        // gradient direction (the 1→2 rule needs g ≥ g_th first), so its
        // atan2 is skipped; the decision is identical either way.
        let needs_direction =
            self.controller.mode() == Mode::Bypass || intensity >= self.controller.config().g_th;
        let field_direction = if needs_direction { wrap(sample.direction() + offset) } else { 0.0 };
        let input = Input {
            goal_bearing,
            field_intensity: intensity,
            field_direction,
            heading: self.body.heading(table),
            dt: self.dt,
        };
        let out = self.controller.step(&input);
        self.body.apply(out.motion, table);
        out
    }
}
