//! ns per simulated robot-step with 0, 10, 100 and 1000 beacons.
//!
//! One "robot-step" is what the runner does per control period: a
//! [`Deployment::step`] (noise when on, field sample over all beacons, goal
//! bearing and controller when needed, kinematics), then, after a move, the
//! terrain check and the arrival test (squared distance, as the runner). Run:
//! `cargo bench -p bycoms-sim --bench robot_step`.
//!
//! A deployment's periods differ in cost (a turn in place reuses the last
//! sample; a straight period in mode 1 far from the beacons needs only a
//! bound; others sum exactly), so every bench runs the same 100 000 periods
//! of the same trajectories (100 samples of 1000): the mean is the cost per
//! period of that mix, the median that of a typical 1000-period stretch.
//!
//! `plain_step` is the same period done by `SimRobot::step` with the bearing
//! computed every period (what the agent process does), for comparison.

use bycoms_agent::{ControllerConfig, Motion};
use bycoms_sim::body::{HeadingTable, Kinematics};
use bycoms_sim::field::Beacons;
use bycoms_sim::robot::{Deployment, MotionCones, SimRobot};
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
    let config = ControllerConfig::paper(1.0);
    let cones = MotionCones::new(&table, config.straight_tolerance);
    let field = beacons(n);
    let noise = noise.then(|| SensingNoise::new(NoiseModel::paper(), 7));
    let fresh = SimRobot::new(terrain.start(), config, noise, kin.dt);
    let (table, cones, field) = (&table, &cones, &field);
    let mut d = Deployment::new(fresh.clone(), table, cones, field, goal);
    bencher.bench_local(move || {
        // As the runner: the checks follow a move (a turn stays where they passed).
        let moved = d.step() == Motion::Straight;
        let p = d.robot.body.pos;
        let (dx, dy) = (p.x - goal.x, p.y - goal.y);
        if moved && (terrain.is_blocked_at(p) || dx * dx + dy * dy <= 0.25) {
            d = Deployment::new(fresh.clone(), table, cones, field, goal);
        }
        divan::black_box(p)
    });
}

fn bench_plain_steps(bencher: divan::Bencher, n: usize) {
    let terrain = Terrain::paper();
    let kin = Kinematics::paper();
    let goal = terrain.goal();
    let table = HeadingTable::new(&kin, terrain.start().bearing_to(goal)).expect("paper kinematics");
    let field = beacons(n);
    let fresh = SimRobot::new(terrain.start(), ControllerConfig::paper(1.0), None, kin.dt);
    let mut robot = fresh.clone();
    bencher.bench_local(move || {
        let bearing = robot.body.pos.bearing_to(goal);
        robot.step(&table, &field, bearing);
        let p = robot.body.pos;
        let (dx, dy) = (p.x - goal.x, p.y - goal.y);
        if terrain.is_blocked_at(p) || dx * dx + dy * dy <= 0.25 {
            robot = fresh.clone();
        }
        divan::black_box(p)
    });
}

#[divan::bench(args = [0, 10, 100, 1000], sample_count = 100, sample_size = 1000)]
fn step(bencher: divan::Bencher, beacons: usize) {
    bench_steps(bencher, beacons, false);
}

#[divan::bench(args = [0, 10, 100, 1000], sample_count = 100, sample_size = 1000)]
fn step_with_noise(bencher: divan::Bencher, beacons: usize) {
    bench_steps(bencher, beacons, true);
}

#[divan::bench(args = [0, 10, 100, 1000], sample_count = 100, sample_size = 1000)]
fn plain_step(bencher: divan::Bencher, beacons: usize) {
    bench_plain_steps(bencher, beacons);
}
