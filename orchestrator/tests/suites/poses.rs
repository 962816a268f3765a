//! The one conformance suite of the poses seam (`launch::poses`): every
//! [`PoseSource`] passes it. An implementation supplies a [`PoseFixture`]
//! and calls [`run_all`] (see `pose_source_suite.rs`).

use bycoms_orchestrator::launch::poses::{PoseSink, PoseSource};
use bycoms_orchestrator::launch::recording::Recording;
use bycoms_protocol::msg::Pose;
use bycoms_protocol::{RobotId, Swarm};
use bycoms_sim::agent_process::Traffic;
use std::time::{Duration, Instant};

/// How an implementation is put under test.
pub trait PoseFixture {
    /// A fresh source (no robot opened) and the swarm it serves.
    fn source(&mut self) -> (Box<dyn PoseSource>, Swarm);
    /// Makes the source see `pose` for robot `robot` (publish it, send a
    /// mocap frame, append it to a replay, ...).
    fn emit(&mut self, robot: u32, pose: &Pose);
    /// Largest difference allowed between a coordinate emitted and handed
    /// over (0: bit for bit; mocap may carry f32).
    fn tolerance(&self) -> f64;
}

/// Everything drained, until `want` poses came or `timeout` passed.
fn drain_until(
    source: &mut dyn PoseSource,
    swarm: &Swarm,
    want: usize,
    timeout: Duration,
) -> (Vec<(u32, Pose)>, u64, Traffic) {
    let mut recording = Recording::off();
    let mut traffic = Traffic::default();
    let mut got = Vec::new();
    let mut recorded = 0;
    let deadline = Instant::now() + timeout;
    loop {
        let record_decoded = !source.on_the_bus();
        let mut sink = PoseSink::new(&mut recording, &mut traffic, swarm, &mut got, record_decoded);
        let t0 = Instant::now();
        source.drain(&mut sink).expect("drain");
        assert!(t0.elapsed() < Duration::from_millis(500), "drain must not wait");
        recorded += sink.recorded();
        if got.len() >= want || Instant::now() >= deadline {
            return (got, recorded, traffic);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn pose(robot: u32, k: u64) -> Pose {
    // Coordinates that are not short decimals: exactness shows.
    let x = 10.0 + k as f64 / 3.0;
    let y = 20.0 - k as f64 / 7.0;
    Pose { robot: RobotId(robot), x, y, heading: 0.1 * k as f64, step: k, time_us: k * 100_000 }
}

/// Runs every check against `fixture`.
pub fn run_all(fixture: &mut dyn PoseFixture) {
    opened_robots_poses_arrive_in_order_and_are_recorded(fixture);
    a_robot_carried_by_hand_is_handed_every_move(fixture);
}

/// `carried`: while the operator carries a robot, any move is handed over,
/// however fast (a source with a jump check must not take it for a swap);
/// once placed, a plausible move from there is handed over too.
fn a_robot_carried_by_hand_is_handed_every_move(fixture: &mut dyn PoseFixture) {
    let (mut source, swarm) = fixture.source();
    source.open_robot(1).expect("open robot 1");
    fixture.emit(1, &pose(1, 1));
    let (first, _, _) = drain_until(&mut *source, &swarm, 1, Duration::from_secs(5));
    assert_eq!(first.len(), 1, "{first:?}");
    source.carried(1, true);
    // 10 km in 0.1 s: no robot drives that fast; a hand carry is not judged.
    let lifted = Pose { x: 10_000.0, y: -10_000.0, ..pose(1, 2) };
    fixture.emit(1, &lifted);
    let (carried, _, _) = drain_until(&mut *source, &swarm, 1, Duration::from_secs(5));
    assert_eq!(carried.len(), 1, "the carried robot's move is handed over: {carried:?}");
    source.carried(1, false);
    let nudged = Pose { x: lifted.x + 0.01, ..pose(1, 3) };
    fixture.emit(1, &Pose { y: lifted.y, ..nudged });
    let (placed, _, _) = drain_until(&mut *source, &swarm, 1, Duration::from_secs(5));
    assert_eq!(placed.len(), 1, "tracked on from where it was placed: {placed:?}");
}

fn opened_robots_poses_arrive_in_order_and_are_recorded(fixture: &mut dyn PoseFixture) {
    let (mut source, swarm) = fixture.source();
    assert!(!source.kind().is_empty(), "a source names its kind");
    let (none, _, _) = drain_until(&mut *source, &swarm, 1, Duration::from_millis(50));
    assert!(none.is_empty(), "nothing before anything was emitted: {none:?}");
    source.open_robot(1).expect("open robot 1");
    source.open_robot(2).expect("open robot 2");
    source.open_robot(2).expect("opening twice is harmless");
    for k in 1..=3 {
        fixture.emit(2, &pose(2, k));
        fixture.emit(3, &pose(3, k)); // robot 3 is not opened
    }
    for k in 1..=3 {
        fixture.emit(1, &pose(1, k));
    }
    let (got, recorded, traffic) = drain_until(&mut *source, &swarm, 6, Duration::from_secs(5));
    // Whatever else came in the meantime, robot 3 must not.
    let (late, late_recorded, _) = drain_until(&mut *source, &swarm, usize::MAX, Duration::from_millis(200));
    assert!(late.iter().all(|(r, _)| *r != 3), "a robot not opened: {late:?}");
    assert!(got.iter().all(|(r, _)| *r != 3), "a robot not opened: {got:?}");
    assert_eq!(got.len(), 6, "every pose of the opened robots: {got:?}");
    assert_eq!(traffic.total(), 0, "nothing bad: {traffic:?}");
    assert_eq!(recorded + late_recorded, (got.len() + late.len()) as u64, "every pose is recorded once");
    let tol = fixture.tolerance();
    for robot in [1, 2] {
        let mine: Vec<&Pose> = got.iter().filter(|(r, _)| *r == robot).map(|(_, p)| p).collect();
        assert_eq!(mine.len(), 3, "robot {robot}");
        for (k, p) in (1..=3).zip(mine) {
            let want = pose(robot, k);
            assert_eq!((p.robot, p.step), (want.robot, want.step), "robot {robot}'s poses in order");
            let close =
                |a: f64, b: f64| if tol == 0.0 { a.to_bits() == b.to_bits() } else { (a - b).abs() <= tol };
            assert!(
                close(p.x, want.x) && close(p.y, want.y) && close(p.heading, want.heading),
                "{p:?} vs {want:?}"
            );
        }
    }
}
