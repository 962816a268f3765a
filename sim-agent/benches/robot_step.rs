//! ns per simulated robot-step with 0, 10, 100 and 1000 beacons.
//!
//! One "robot-step" is what the runner does per control period: goal
//! bearing, field sample over all beacons (+ noise when on), controller,
//! kinematics, terrain check. Run: `cargo bench -p bycoms-sim --bench robot_step`.

use bycoms_agent::ControllerConfig;
use bycoms_sim::body::{HeadingTable, Kinematics};
use bycoms_sim::field::Beacons;
use bycoms_sim::robot::SimRobot;
use bycoms_sim::sensing::{NoiseModel, SensingNoise};
use bycoms_sim::terrain::Terrain;
use bycoms_sim::Vec2;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

fn main() {
    divan::main();
}

/// `n` beacons scattered over the arena, seeded.
fn beacons(n: usize) -> Beacons {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(42);
    let mut b = Beacons::new(1.0);
    for _ in 0..n {
        b.push(Vec2::new(rng.gen_range(0.0..60.0), rng.gen_range(0.0..60.0)));
    }
    b
}

fn bench_steps(bencher: divan::Bencher, n: usize, noise: bool) {
    let terrain = Terrain::paper();
    let kin = Kinematics::paper();
    let goal = terrain.goal();
    let table = HeadingTable::new(&kin, terrain.start().bearing_to(goal)).expect("paper kinematics");
    let field = beacons(n);
    let noise = noise.then(|| SensingNoise::new(NoiseModel::paper(), 7));
    let fresh = SimRobot::new(terrain.start(), ControllerConfig::paper(1.0), noise, kin.dt);
    let mut robot = fresh.clone();
    bencher.bench_local(move || {
        let bearing = robot.body.pos.bearing_to(goal);
        robot.step(&table, &field, bearing);
        if terrain.is_blocked_at(robot.body.pos) || robot.body.pos.distance(goal) < 0.5 {
            robot = fresh.clone();
        }
        divan::black_box(robot.body.pos)
    });
}

#[divan::bench(args = [0, 10, 100, 1000])]
fn step(bencher: divan::Bencher, beacons: usize) {
    bench_steps(bencher, beacons, false);
}

#[divan::bench(args = [0, 10, 100, 1000])]
fn step_with_noise(bencher: divan::Bencher, beacons: usize) {
    bench_steps(bencher, beacons, true);
}
