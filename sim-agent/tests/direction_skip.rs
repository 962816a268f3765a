//! `SimRobot::step` skips the gradient's atan2 in mode 1 below threshold.
//! This checks that the skip is exact: a reference robot that always
//! computes the direction, built from the same public pieces, follows the
//! very same trajectory (bit for bit) with and without noise.

use bycoms_agent::angle::wrap;
use bycoms_agent::{Controller, ControllerConfig, Input};
use bycoms_sim::body::{Body, HeadingTable, Kinematics};
use bycoms_sim::field::Beacons;
use bycoms_sim::robot::SimRobot;
use bycoms_sim::sensing::{NoiseModel, SensingNoise};
use bycoms_sim::Vec2;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

struct Reference {
    body: Body,
    controller: Controller,
    noise: Option<SensingNoise>,
}

impl Reference {
    fn step(&mut self, table: &HeadingTable, beacons: &Beacons, bearing: f64) {
        let (factor, offset) = self.noise.as_mut().map_or((1.0, 0.0), SensingNoise::draw);
        let s = beacons.sample(self.body.pos);
        let input = Input {
            goal_bearing: bearing,
            field_intensity: s.intensity * factor,
            field_direction: wrap(s.direction() + offset),
            heading: self.body.heading(table),
            dt: 0.1,
        };
        let out = self.controller.step(&input);
        self.body.apply(out.motion, table);
    }
}

#[test]
fn skipping_the_direction_below_threshold_changes_nothing() {
    let kin = Kinematics::paper();
    let (start, goal) = (Vec2::new(15.5, 15.5), Vec2::new(44.5, 44.5));
    let table = HeadingTable::new(&kin, start.bearing_to(goal)).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let mut mode_switches = 0;
    for case in 0..40 {
        let mut beacons = Beacons::new(1.0);
        for _ in 0..rng.gen_range(1..12) {
            beacons.push(Vec2::new(rng.gen_range(18.0..42.0), rng.gen_range(18.0..42.0)));
        }
        let eps = rng.gen_range(1.0..5.0);
        let config = ControllerConfig::paper(eps);
        let noise = (case % 2 == 1).then(|| SensingNoise::new(NoiseModel::paper(), case));
        let mut fast = SimRobot::new(start, config, noise.clone(), kin.dt);
        let mut slow = Reference { body: Body::new(start), controller: Controller::new(config), noise };
        let mut last_mode = fast.mode();
        for _ in 0..3000 {
            let bearing = fast.body.pos.bearing_to(goal);
            fast.step(&table, &beacons, bearing);
            slow.step(&table, &beacons, bearing);
            assert_eq!(fast.body.state(), slow.body.state(), "case {case}");
            assert_eq!(fast.mode(), slow.controller.mode(), "case {case}");
            mode_switches += usize::from(fast.mode() != last_mode);
            last_mode = fast.mode();
        }
    }
    assert!(mode_switches > 40, "the cases must exercise both modes ({mode_switches} switches)");
}
