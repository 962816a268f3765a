//! The one conformance suite of the poses seam (`launch::poses`): every
//! [`PoseSource`] passes it. An implementation supplies a [`PoseFixture`]
//! and calls [`run_all`] (see `pose_source_suite.rs`).
//!
//! Why the fixture states what it expects ([`Expected`]): every method of
//! the trait is checked for every implementation, the properties too — the
//! engine records raw bytes or decoded poses by [`PoseSource::on_the_bus`],
//! and only a source that judges speed (motion capture's identity-swap
//! check) needs [`PoseSource::carried`] to let a hand carry through. What a
//! source does not do is stated and checked as well: a source without a
//! speed check hands an implausible move over whether carried or not, so a
//! source that starts rejecting moves fails as surely as one that stops.
//! A check that cannot apply (garbage, for a source only poses can reach)
//! is named in the returned [`Report`] (see `suites/mod.rs`).

use super::Report;
use bycoms_launch::poses::{PoseSink, PoseSource};
use bycoms_launch::recording::Recording;
use bycoms_protocol::msg::Pose;
use bycoms_protocol::{RobotId, Swarm};
use bycoms_runtime::Traffic;
use std::time::{Duration, Instant};

/// What an implementation is expected to be and do (stated by its fixture,
/// checked by the suite).
#[derive(Clone, Copy, Debug)]
pub struct Expected {
    /// [`PoseSource::kind`].
    pub kind: &'static str,
    /// [`PoseSource::on_the_bus`].
    pub on_the_bus: bool,
    /// Whether the source rejects a move faster than a robot drives (an
    /// identity swap), which [`PoseSource::carried`] suspends while a robot
    /// is carried by hand; `false`: it ignores `carried`.
    pub rejects_jumps: bool,
    /// What becomes of bytes the source cannot use.
    pub garbage: Garbage,
}

/// What becomes of bytes a source cannot use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Garbage {
    /// Handed to [`PoseSink::bad`]: counted in the launch's traffic.
    Counted,
    /// Dropped by the source and counted by it, not in the launch's traffic
    /// (never fatal either).
    DroppedBySource,
    /// Nothing but poses can reach the source.
    CannotArrive,
}

/// How an implementation is put under test.
pub trait PoseFixture {
    /// What the implementation is expected to be and do.
    fn expected(&self) -> Expected;
    /// A fresh source (no robot opened) and the swarm it serves.
    fn source(&mut self) -> (Box<dyn PoseSource>, Swarm);
    /// Makes the source see `pose` for robot `robot` (publish it, send a
    /// mocap frame, append it to a replay, ...).
    fn emit(&mut self, robot: u32, pose: &Pose);
    /// Makes the source see something for robot `robot` that is not a pose
    /// (undecodable bytes); not called when [`Expected::garbage`] is
    /// [`Garbage::CannotArrive`].
    fn emit_garbage(&mut self, robot: u32);
    /// Largest difference allowed between a coordinate emitted and handed
    /// over (0: bit for bit; mocap may carry f32).
    fn tolerance(&self) -> f64;
}

/// What one or more drains handed over.
struct Drained {
    poses: Vec<(u32, Pose)>,
    recorded: u64,
    traffic: Traffic,
}

/// Everything drained until `until` says to stop: once what came is
/// complete (panicking at the deadline), or after a span.
fn drain(source: &mut dyn PoseSource, swarm: &Swarm, until: Until<'_>) -> Drained {
    let mut recording = Recording::off();
    let mut traffic = Traffic::default();
    let mut got = Vec::new();
    let mut recorded = 0;
    let (deadline, done) = match until {
        Until::Done(done, timeout) => (Instant::now() + timeout, Some(done)),
        Until::Span(span) => (Instant::now() + span, None),
    };
    loop {
        let record_decoded = !source.on_the_bus();
        let mut sink = PoseSink::new(&mut recording, &mut traffic, swarm, &mut got, record_decoded);
        let t0 = Instant::now();
        source.drain(&mut sink).expect("drain");
        assert!(t0.elapsed() < Duration::from_millis(500), "drain must not wait");
        recorded += sink.recorded();
        match done {
            Some(done) if done(&got) => return Drained { poses: got, recorded, traffic },
            Some(_) => assert!(Instant::now() < deadline, "not everything came within the timeout: {got:?}"),
            None if Instant::now() >= deadline => return Drained { poses: got, recorded, traffic },
            None => {}
        }
        // Polled: a pose source is drained without waiting (the gate drains
        // it each tick); it has no event to block on.
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Whether everything awaited came.
type Done<'a> = &'a dyn Fn(&[(u32, Pose)]) -> bool;

/// When [`drain`] stops.
enum Until<'a> {
    /// Once this holds for what came (panics after the timeout).
    Done(Done<'a>, Duration),
    /// After this long (to show that nothing comes).
    Span(Duration),
}

const WAIT: Duration = Duration::from_secs(5);

/// Drains until robot `robot`'s pose of step `step` came.
fn drain_to_step(source: &mut dyn PoseSource, swarm: &Swarm, robot: u32, step: u64) -> Drained {
    let done = move |got: &[(u32, Pose)]| got.iter().any(|(r, p)| *r == robot && p.step == step);
    drain(source, swarm, Until::Done(&done, WAIT))
}

fn pose(robot: u32, k: u64) -> Pose {
    // Coordinates that are not short decimals: exactness shows.
    let x = 10.0 + k as f64 / 3.0;
    let y = 20.0 - k as f64 / 7.0;
    Pose { robot: RobotId(robot), x, y, heading: 0.1 * k as f64, step: k, time_us: k * 100_000 }
}

/// Pose `k` of robot 1 at `(x, y)`.
fn at(k: u64, x: f64, y: f64) -> Pose {
    Pose { x, y, ..pose(1, k) }
}

/// The steps of what came.
fn steps(got: &[(u32, Pose)]) -> Vec<u64> {
    got.iter().map(|(_, p)| p.step).collect()
}

/// Runs every check against `fixture`; returns the checks that were not
/// applicable (each test asserts that list).
pub fn run_all(fixture: &mut dyn PoseFixture) -> Report {
    let mut report = Report::new("poses", fixture.expected().kind);
    properties_are_as_stated(fixture);
    opened_robots_poses_arrive_in_order_and_are_recorded(fixture);
    a_robot_carried_by_hand_is_handed_every_move(fixture);
    what_a_source_cannot_use_is_never_fatal(fixture, &mut report);
    report
}

fn properties_are_as_stated(fixture: &mut dyn PoseFixture) {
    let want = fixture.expected();
    let (source, _) = fixture.source();
    assert_eq!(source.kind(), want.kind, "kind");
    assert_eq!(source.on_the_bus(), want.on_the_bus, "{}: on_the_bus", want.kind);
}

/// `carried`: while the operator carries a robot, any move is handed over,
/// however fast (a source with a jump check must not take it for a swap);
/// once placed, a plausible move from there is handed over, and the check
/// (if the source has one) is on again. Without a jump check every move is
/// handed over, carried or not. Each wait ends on a later plausible pose
/// (poses of one robot arrive in order), not on a span.
fn a_robot_carried_by_hand_is_handed_every_move(fixture: &mut dyn PoseFixture) {
    let want = fixture.expected();
    let kind = want.kind;
    let (mut source, swarm) = fixture.source();
    source.carried(2, true); // a robot not opened: harmless
    source.carried(3, false); // placed without being carried: harmless
    source.open_robot(1).expect("open robot 1");
    fixture.emit(1, &at(1, 10.0, 20.0));
    assert_eq!(steps(&drain_to_step(&mut *source, &swarm, 1, 1).poses), [1], "{kind}: the first pose");
    // 14 km in 0.1 s, not carried: a swap to a source that judges speed.
    fixture.emit(1, &at(2, 10_000.0, -10_000.0));
    fixture.emit(1, &at(3, 10.01, 20.0));
    let jumped = steps(&drain_to_step(&mut *source, &swarm, 1, 3).poses);
    let expected: &[u64] = if want.rejects_jumps { &[3] } else { &[2, 3] };
    assert_eq!(
        jumped, expected,
        "{kind}: an implausible move, not carried (rejects jumps: {})",
        want.rejects_jumps
    );
    source.carried(1, true);
    let lifted = at(4, 10_000.0, -10_000.0);
    fixture.emit(1, &lifted);
    let carried = drain_to_step(&mut *source, &swarm, 1, 4).poses;
    assert_eq!(steps(&carried), [4], "{kind}: the carried robot's move is handed over: {carried:?}");
    source.carried(1, false);
    fixture.emit(1, &at(5, lifted.x + 0.01, lifted.y));
    let placed = steps(&drain_to_step(&mut *source, &swarm, 1, 5).poses);
    assert_eq!(placed, [5], "{kind}: tracked on from where it was placed");
    // Placed, the check is on again: back to the first spot is a jump.
    fixture.emit(1, &at(6, 10.0, 20.0));
    fixture.emit(1, &at(7, lifted.x + 0.02, lifted.y));
    let after = steps(&drain_to_step(&mut *source, &swarm, 1, 7).poses);
    let expected: &[u64] = if want.rejects_jumps { &[7] } else { &[6, 7] };
    assert_eq!(
        after, expected,
        "{kind}: an implausible move once placed (rejects jumps: {})",
        want.rejects_jumps
    );
}

fn opened_robots_poses_arrive_in_order_and_are_recorded(fixture: &mut dyn PoseFixture) {
    let (mut source, swarm) = fixture.source();
    let none = drain(&mut *source, &swarm, Until::Span(Duration::from_millis(50))).poses;
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
    let six = |got: &[(u32, Pose)]| got.len() >= 6;
    let Drained { poses: got, recorded, traffic } = drain(&mut *source, &swarm, Until::Done(&six, WAIT));
    // Whatever else came in the meantime, robot 3 must not.
    let late = drain(&mut *source, &swarm, Until::Span(Duration::from_millis(200)));
    assert!(late.poses.iter().all(|(r, _)| *r != 3), "a robot not opened: {:?}", late.poses);
    assert!(got.iter().all(|(r, _)| *r != 3), "a robot not opened: {got:?}");
    assert_eq!(got.len(), 6, "every pose of the opened robots: {got:?}");
    assert_eq!(traffic.total(), 0, "nothing bad: {traffic:?}");
    let handed = (got.len() + late.poses.len()) as u64;
    assert_eq!(recorded + late.recorded, handed, "every pose is recorded once");
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

/// `drain`: bytes a source cannot use are never fatal, the poses after
/// them still come, and they are counted where the fixture says (a source
/// on the bus also records them byte for byte, as they crossed the bus).
fn what_a_source_cannot_use_is_never_fatal(fixture: &mut dyn PoseFixture, report: &mut Report) {
    let want = fixture.expected();
    let kind = want.kind;
    if want.garbage == Garbage::CannotArrive {
        return report.skip("what_a_source_cannot_use_is_never_fatal", "nothing but poses can reach it");
    }
    let (mut source, swarm) = fixture.source();
    source.open_robot(1).expect("open robot 1");
    fixture.emit_garbage(1);
    fixture.emit(1, &pose(1, 1));
    let Drained { poses, recorded, traffic } = drain_to_step(&mut *source, &swarm, 1, 1);
    assert_eq!(steps(&poses), [1], "{kind}: the pose after the garbage still comes");
    let counted = u64::from(want.garbage == Garbage::Counted);
    assert_eq!(traffic.total(), counted, "{kind}: garbage counted ({:?}): {traffic:?}", want.garbage);
    let raw = u64::from(want.on_the_bus);
    assert_eq!(recorded, 1 + raw, "{kind}: recorded: the pose, and the garbage if on the bus");
}
