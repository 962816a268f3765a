//! Whether a pose can follow the last one accepted for its robot.
//!
//! Why: the gate keeps the newest step it has seen and judges arrival from a
//! single pose, so one forged message could stall a run for ever (a step of
//! `u64::MAX`: every later real pose looks old) or win it (a pose at the
//! goal). A robot's poses cannot jump: its steps advance with its clock, its
//! pose time with the launch's time, and it cannot move faster than it
//! drives. A pose that breaks one of these is refused and counted as bad
//! traffic, never applied. The rules, per robot, against the last accepted
//! pose (the *anchor*):
//!
//! * every coordinate is finite;
//! * lockstep: its step is not ahead of the tick in flight, its pose time
//!   not ahead of that step's end (a simulated agent's pose time is its
//!   step × the period);
//! * real time: its pose time is not ahead of the anchor's by more than
//!   twice the launch time since the anchor arrived, plus a slack of two
//!   periods or half a second of wall time at the launch's speed, whichever
//!   is more (an agent's clock runs at the launch's speed; mocap frames
//!   come in bursts; on a loaded machine the orchestrator may read the
//!   anchor late and the next pose, after the agent skipped periods, at
//!   once);
//!   its step advances at most once per millisecond of pose time (no clock
//!   we know of runs faster than 1 kHz), so a huge step cannot pass with a
//!   small time;
//! * it moved no faster than `gate.max_speed` from the anchor: world units
//!   (cells in simulation, arena units — metres — in a lab) per second of
//!   pose time (simulated seconds), over at least one period.
//!
//! Why this jump rule is not the motion-capture tracker's
//! (`tracker.max_speed`, `orchestrator/mocap/src/tracker.rs`), though both
//! say "a robot cannot move faster than it drives": they guard different
//! things at different places, and one setting could not serve both. This
//! one judges every pose of every source (the bus's too: a forged pose
//! anyone can publish) against the last pose the core *accepted* for a
//! *deployed* robot, over the pose's own clock, with no slack, and a
//! refusal is bad traffic; its default (5 units/s) is a ceiling well above
//! any robot (a simulated one drives 1 cell/s). The tracker exists only
//! with motion capture, judges every frame of a body (deployed or not,
//! carried by hand or not: `PoseSource::carried`)
//! against its last *trusted* sample, in the capture's frame time, with a
//! noise slack (`jump_slack`), and what it rejects (an identity swap)
//! reaches neither the core nor an agent's bearing; its settings are the
//! crawlers' real top speed (0.6 m/s in the lab's configs). Feeding the
//! tracker's tight bound to this rule (no slack, any source) would refuse
//! real poses over mocap noise; feeding this one's ceiling to the tracker
//! would let swaps through. A pose the tracker passes still meets this
//! rule, which is the last word.
//!
//! Where anchors come from: only from a deployed robot. A robot's first
//! anchor is its start pose ([`Anchors::accept_start`]), which must lie
//! where the robot was put at its deployment (a simulated robot exactly at
//! its `Deploy`'s position; a real one within the placement radius the
//! operator's placement was checked against). A pose of a robot before its
//! deployment anchors nothing ([`Anchors::check_alone`]: what the
//! placement check reads), and [`Anchors::forget`] drops what a robot had
//! when it is deployed. Why: anyone may publish on a robot's pose topic, and
//! a pose at the goal published before the robot was deployed became its
//! start pose (the run "won"), or its time became the reference its agent's
//! own poses were then refused against ("ahead of the launch's clock").
//! A refused pose never becomes an anchor.

use bycoms_protocol::msg::Pose;

/// Why a pose was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Implausible {
    /// A coordinate is NaN or infinite.
    NotFinite,
    /// A step or time ahead of what the clock allows.
    FromTheFuture,
    /// A jump faster than `gate.max_speed` (world units per simulated
    /// second, as measured).
    TooFast(f64),
    /// A start pose this far (units) from where the robot was deployed.
    NotWhereDeployed(f64),
}

impl std::fmt::Display for Implausible {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NotFinite => write!(f, "a coordinate is not a finite number"),
            Self::FromTheFuture => write!(f, "its step or time is ahead of the launch's clock"),
            Self::TooFast(v) => write!(f, "it would have moved at {v:.2} units/s"),
            Self::NotWhereDeployed(d) => write!(f, "it is {d:.2} units from where the robot was deployed"),
        }
    }
}

/// Real time: wall time (µs) a pose may be ahead of its anchor beyond
/// what the launch's clock allows (see the module docs).
const REALTIME_SLACK_US: f64 = 500_000.0;

/// The clock a pose is checked against.
#[derive(Clone, Copy, Debug)]
pub enum PoseClock {
    /// Lockstep: the newest tick a pose may carry.
    Lockstep {
        /// The tick in flight (or the last completed one).
        newest_step: u64,
    },
    /// Real time: launch time now (µs) and the speed-up.
    Realtime {
        /// Launch time, µs.
        now_us: u64,
        /// Simulated seconds per wall second.
        speed: f64,
    },
}

#[derive(Clone, Copy, Debug)]
struct Anchor {
    pose: Pose,
    /// Launch time it was accepted at, µs.
    at_us: u64,
}

/// Where a robot was put at its deployment, and how far from there its
/// start pose may lie (units).
#[derive(Clone, Copy, Debug)]
pub struct StartAt {
    /// The deployment's position.
    pub x: f64,
    /// The deployment's position.
    pub y: f64,
    /// The largest distance from it.
    pub tolerance: f64,
}

/// The last accepted pose of every deployed robot.
#[derive(Clone, Debug)]
pub struct Anchors {
    period_us: u64,
    max_speed: f64,
    anchors: Vec<Option<Anchor>>,
}

impl Anchors {
    /// No pose seen yet for `robots` robots.
    pub fn new(robots: u32, period_us: u64, max_speed: f64) -> Self {
        Self { period_us: period_us.max(1), max_speed, anchors: vec![None; robots as usize] }
    }

    /// Robot `id` is being deployed: whatever it had is dropped, its start
    /// pose ([`Anchors::accept_start`]) is its first anchor.
    pub fn forget(&mut self, id: u32) {
        if let Some(slot) = self.slot(id) {
            *slot = None;
        }
    }

    fn slot(&mut self, id: u32) -> Option<&mut Option<Anchor>> {
        id.checked_sub(1).and_then(|i| self.anchors.get_mut(i as usize))
    }

    /// Checks a pose on its own, against no anchor (finite, and in
    /// lockstep not ahead of the tick), and keeps nothing: a pose of a robot
    /// not deployed yet (what a placement check reads).
    pub fn check_alone(&self, pose: &Pose, clock: PoseClock) -> Result<(), Implausible> {
        check_clock(pose, None, clock, self.period_us)
    }

    /// Robot `id`'s start pose after its deployment: plausible on its own
    /// and within `at.tolerance` of where it was put; it becomes the anchor.
    pub fn accept_start(
        &mut self,
        id: u32,
        pose: &Pose,
        clock: PoseClock,
        at: StartAt,
    ) -> Result<(), Implausible> {
        check_clock(pose, None, clock, self.period_us)?;
        let distance = (pose.x - at.x).hypot(pose.y - at.y);
        if distance > at.tolerance {
            return Err(Implausible::NotWhereDeployed(distance));
        }
        if let Some(slot) = self.slot(id) {
            *slot = Some(Anchor { pose: *pose, at_us: at_us(clock) });
        }
        Ok(())
    }

    /// Checks deployed robot `id`'s `pose` against its anchor and, if it is
    /// plausible and newer, makes it the anchor: `Ok(true)`. A plausible
    /// pose that is not newer (a repeat, a late sample) is `Ok(false)`: not
    /// an error, but nothing to apply. A robot without an anchor (no start
    /// pose yet) has nothing to apply either.
    pub fn accept(&mut self, id: u32, pose: &Pose, clock: PoseClock) -> Result<bool, Implausible> {
        let (period, max_speed) = (self.period_us, self.max_speed);
        let Some(slot) = self.slot(id) else { return Ok(false) };
        let Some(anchor) = *slot else {
            check_clock(pose, None, clock, period)?;
            return Ok(false);
        };
        check_clock(pose, Some(&anchor), clock, period)?;
        // An older pose (a repeat, a late sample) is plausible but does not
        // move the anchor back.
        if pose.step <= anchor.pose.step {
            return Ok(false);
        }
        let dt_us = pose.time_us.saturating_sub(anchor.pose.time_us).max(period);
        let distance = (pose.x - anchor.pose.x).hypot(pose.y - anchor.pose.y);
        let speed = distance / (dt_us as f64 * 1e-6);
        if speed > max_speed {
            return Err(Implausible::TooFast(speed));
        }
        *slot = Some(Anchor { pose: *pose, at_us: at_us(clock) });
        Ok(true)
    }
}

/// The launch time an anchor is taken at (lockstep: no wall time).
fn at_us(clock: PoseClock) -> u64 {
    match clock {
        PoseClock::Realtime { now_us, .. } => now_us,
        PoseClock::Lockstep { .. } => 0,
    }
}

/// A pose's coordinates and its step and time against the clock (and, in
/// real time, against the anchor when there is one).
fn check_clock(
    pose: &Pose,
    anchor: Option<&Anchor>,
    clock: PoseClock,
    period: u64,
) -> Result<(), Implausible> {
    if !(pose.x.is_finite() && pose.y.is_finite() && pose.heading.is_finite()) {
        return Err(Implausible::NotFinite);
    }
    match clock {
        PoseClock::Lockstep { newest_step } => {
            let end_us = newest_step.saturating_add(1).saturating_mul(period);
            if pose.step > newest_step || pose.time_us > end_us {
                return Err(Implausible::FromTheFuture);
            }
        }
        PoseClock::Realtime { now_us, speed } => {
            if let Some(a) = anchor {
                let waited = now_us.saturating_sub(a.at_us) as f64 * speed * 2.0;
                let slack = (2.0 * period as f64).max(REALTIME_SLACK_US * speed);
                let allowed = a.pose.time_us as f64 + waited + slack;
                if pose.time_us as f64 > allowed {
                    return Err(Implausible::FromTheFuture);
                }
                let steps = pose.step.saturating_sub(a.pose.step);
                let ms = pose.time_us.saturating_sub(a.pose.time_us) / 1000;
                if steps > ms + 1 {
                    return Err(Implausible::FromTheFuture);
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::RobotId;

    fn pose(step: u64, x: f64) -> Pose {
        Pose { robot: RobotId(1), x, y: 0.0, heading: 0.0, step, time_us: step.saturating_mul(100_000) }
    }

    fn lockstep(newest_step: u64) -> PoseClock {
        PoseClock::Lockstep { newest_step }
    }

    /// Deployed at (x, 0), exactly.
    fn at(x: f64) -> StartAt {
        StartAt { x, y: 0.0, tolerance: 1e-9 }
    }

    #[test]
    fn lockstep_refuses_steps_and_times_ahead_of_the_tick() {
        let mut a = Anchors::new(2, 100_000, 5.0);
        assert_eq!(a.accept_start(1, &pose(3, 0.0), lockstep(3), at(0.0)), Ok(()));
        assert_eq!(a.accept(1, &pose(u64::MAX, 0.0), lockstep(4)), Err(Implausible::FromTheFuture));
        let mut late = pose(4, 0.1);
        late.time_us = 10_000_000_000;
        assert_eq!(a.accept(1, &late, lockstep(4)), Err(Implausible::FromTheFuture));
        assert_eq!(a.accept(1, &pose(4, 0.1), lockstep(4)), Ok(true));
        assert_eq!(
            a.accept_start(2, &pose(5, 0.0), lockstep(4), at(0.0)),
            Err(Implausible::FromTheFuture),
            "a start pose is held to the clock too"
        );
    }

    #[test]
    fn a_jump_faster_than_a_robot_drives_is_refused() {
        let mut a = Anchors::new(1, 100_000, 5.0);
        a.accept_start(1, &pose(1, 0.0), lockstep(1), at(0.0)).unwrap();
        assert!(
            matches!(a.accept(1, &pose(2, 20.0), lockstep(2)), Err(Implausible::TooFast(v)) if v > 100.0)
        );
        assert_eq!(a.accept(1, &pose(2, 0.1), lockstep(2)), Ok(true), "1 unit/s");
        assert_eq!(a.accept(1, &pose(2, 0.1), lockstep(2)), Ok(false), "a repeat: nothing new");
        assert!(a.accept(1, &pose(3, 20.0), lockstep(3)).is_err(), "the refused jump anchored nothing");
    }

    /// The forgery: poses at the goal before the robot was
    /// deployed. They anchor nothing, the deployment's start pose must lie
    /// where the robot was put, and the genuine poses that follow are
    /// judged against the genuine start pose.
    #[test]
    fn a_robot_starts_where_it_was_deployed_whatever_was_said_before() {
        let mut a = Anchors::new(1, 100_000, 5.0);
        let rt = |now_us| PoseClock::Realtime { now_us, speed: 1.0 };
        let goal = |step| Pose { y: 44.5, ..pose(step, 44.5) };
        assert_eq!(a.check_alone(&goal(5), rt(60_000_000)), Ok(()), "plausible on its own");
        assert_eq!(a.accept(1, &goal(5), rt(60_000_000)), Ok(false), "but nothing to apply");
        a.forget(1);
        assert_eq!(
            a.accept_start(1, &goal(6), rt(60_100_000), at(1.5)),
            Err(Implausible::NotWhereDeployed(43.0_f64.hypot(44.5)))
        );
        // The genuine agent's clock ran for a minute: its start pose is not
        // "ahead" of the forgery, which never became a reference.
        assert_eq!(a.accept_start(1, &pose(600, 1.5), rt(60_150_000), at(1.5)), Ok(()));
        assert_eq!(a.accept(1, &pose(601, 1.6), rt(60_250_000)), Ok(true));
        assert!(a.accept(1, &goal(602), rt(60_350_000)).is_err(), "and the goal is far");
        // A placed robot may be within the placement radius.
        let placed = StartAt { x: 1.5, y: 0.0, tolerance: 0.5 };
        a.forget(1);
        assert_eq!(a.accept_start(1, &pose(700, 1.9), rt(70_000_000), placed), Ok(()));
    }

    #[test]
    fn non_finite_coordinates_are_refused() {
        let mut a = Anchors::new(1, 100_000, 5.0);
        for bad in [f64::NAN, f64::INFINITY] {
            let mut p = pose(1, 0.0);
            p.y = bad;
            assert_eq!(a.accept_start(1, &p, lockstep(1), at(0.0)), Err(Implausible::NotFinite));
            assert_eq!(a.check_alone(&p, lockstep(1)), Err(Implausible::NotFinite));
            p.y = 0.0;
            p.heading = bad;
            assert_eq!(a.accept_start(1, &p, lockstep(1), at(0.0)), Err(Implausible::NotFinite));
        }
    }

    #[test]
    fn real_time_refuses_a_huge_step_or_a_time_ahead_of_the_clock() {
        let mut a = Anchors::new(1, 100_000, 5.0);
        let rt = |now_us| PoseClock::Realtime { now_us, speed: 5.0 };
        assert_eq!(a.accept_start(1, &pose(10, 0.0), rt(0), at(0.0)), Ok(()));
        // 20 ms of launch time at 5x: 0.2 s of pose time allowed (+0.2 s).
        assert_eq!(a.accept(1, &pose(11, 0.1), rt(20_000)), Ok(true));
        let mut huge = pose(12, 0.2);
        huge.step = u64::MAX;
        assert_eq!(a.accept(1, &huge, rt(40_000)), Err(Implausible::FromTheFuture));
        assert_eq!(a.accept(1, &pose(100, 0.2), rt(40_000)), Err(Implausible::FromTheFuture));
        assert_eq!(a.accept(1, &pose(12, 0.2), rt(40_000)), Ok(true));
    }

    /// A loaded machine: the orchestrator read the anchor late, the agent
    /// skipped five periods, and its next pose is read 5 ms later. Genuine:
    /// accepted (seen refused once in twenty loaded test runs).
    #[test]
    fn real_time_accepts_a_pose_after_skipped_periods_read_right_after_a_late_anchor() {
        let mut a = Anchors::new(1, 100_000, 5.0);
        let rt = |now_us| PoseClock::Realtime { now_us, speed: 10.0 };
        assert_eq!(a.accept_start(1, &pose(10, 0.0), rt(45_000), at(0.0)), Ok(()));
        assert_eq!(a.accept(1, &pose(16, 0.3), rt(50_000)), Ok(true));
        // Still no further than half a second of wall time ahead.
        assert_eq!(a.accept(1, &pose(100, 0.3), rt(55_000)), Err(Implausible::FromTheFuture));
    }
}
