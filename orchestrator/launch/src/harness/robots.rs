//! The real robots of a gateway schedule in the world: each robot's
//! [`RealRobot`] (its real gateway and firmware), motion capture seeing
//! every robot's body, and the operator who places robots when the launch
//! asks (promptly, late, never, beside the start, or moved off again).
//!
//! Why apart from `world.rs`: a gateway schedule adds a physical world
//! (bodies, a camera, an operator) that simulated agents do not have; the
//! world calls in here only where a launch of real robots differs.

use super::real::Body;
use super::world::{Event, World};
use super::*;
use bycoms_runtime::failsafe::FailsafeArgs;

/// Motion capture's frame period, µs.
const MOCAP_US: u64 = 50_000;

impl World<'_> {
    /// Where robot `id` waits before it is placed: along the arena's lower
    /// edge, well away from the start.
    fn parked(id: u32) -> Body {
        Body { at: Vec2::new(0.5 + f64::from(id), 0.5), heading: 0.0 }
    }

    /// Starts robot `id`'s gateway (its robot is already powered).
    pub(super) fn start_real(&mut self, id: u32) {
        let i = id as usize - 1;
        let delay = self.schedule.register_delay_us.get(i).copied().unwrap_or(Some(50_000));
        let cuts: Vec<(u64, u64)> = self
            .schedule
            .robot_cuts
            .iter()
            .filter(|c| c.robot == id)
            .map(|c| (c.from_us, c.until_us))
            .collect();
        // zenoh gateways watch the orchestrator; ipc ones are tied to it.
        let failsafe = self.schedule.remote.then(|| FailsafeArgs::default().failsafe()).and_then(Result::ok);
        let body = self.reals[i].as_ref().map_or(Self::parked(id), |r| r.body);
        let robot =
            RealRobot::new(id, 0x1000 + u64::from(id), delay.map(|d| self.now + d), failsafe, body, cuts);
        self.reals[i] = Some(robot);
    }

    /// Whether robot `id`'s gateway runs.
    pub(super) fn real_alive(&self, id: u32) -> bool {
        self.reals.get(id as usize - 1).and_then(Option::as_ref).is_some_and(|r| r.alive)
    }

    /// When a real robot or motion capture next does something.
    pub(super) fn reals_deadline(&self) -> Option<u64> {
        if !self.schedule.gateways {
            return None;
        }
        let robots = self.reals.iter().flatten().map(RealRobot::deadline).min();
        Some(robots.map_or(self.next_mocap, |r| r.min(self.next_mocap)))
    }

    /// Everything the real robots and motion capture do now.
    pub(super) fn advance_reals(&mut self) {
        let now = self.now;
        let mut out = Vec::new();
        for r in self.reals.iter_mut().flatten().filter(|r| r.deadline() <= now) {
            r.advance(now, &self.case.terrain, &mut out);
            for report in out.drain(..) {
                self.net.send(now, r.id(), Packet::Report(report));
            }
        }
        if self.schedule.gateways && now >= self.next_mocap {
            self.next_mocap = now + MOCAP_US;
            self.mocap_frames += 1;
            let poses: Vec<Pose> = self
                .reals
                .iter()
                .flatten()
                .map(|r| Pose {
                    robot: RobotId(r.id()),
                    x: r.body.at.x,
                    y: r.body.at.y,
                    heading: bycoms_agent::angle::wrap(r.body.heading),
                    step: self.mocap_frames,
                    time_us: now,
                })
                .collect();
            // A lab whose motion capture is not running: the frames' clock
            // runs on, no pose reaches the launch.
            for pose in poses.into_iter().filter(|_| !self.schedule.mocap_silent) {
                self.core.handle(now, Input::Pose { topic: pose.robot.0, pose });
            }
        }
    }

    /// Hands robot `id`'s gateway what came for it; its answers go out.
    pub(super) fn tell_real(&mut self, id: u32, what: impl FnOnce(&mut RealRobot, u64, &mut Vec<FromAgent>)) {
        let now = self.now;
        let mut out = Vec::new();
        if let Some(Some(r)) = self.reals.get_mut(id as usize - 1) {
            what(r, now, &mut out);
        }
        for report in out {
            self.net.send(now, id, Packet::Report(report));
        }
    }

    /// The launch asks the operator to place robot `id` (the first time:
    /// the schedule says what the operator does).
    pub(super) fn ask_operator(&mut self, id: u32) {
        let i = id as usize - 1;
        if self.report.asked_us.get(i).is_none_or(Option::is_some) {
            return;
        }
        self.report.asked_us[i] = Some(self.now);
        let start = self.case.terrain.start();
        let beside = Vec2::new(start.x, start.y + 1.2);
        let hold_us = (PLACEMENT.hold * 1e6) as u64;
        match self.schedule.placing.get(i).copied().unwrap_or(Placing::Prompt(0)) {
            Placing::Prompt(after) => self.at(self.now + after, Event::Place(id, start)),
            Placing::Never => {}
            Placing::OffStart(after) => self.at(self.now + after, Event::Place(id, beside)),
            Placing::MovedOff(after) => {
                self.at(self.now + after, Event::Place(id, start));
                self.at(self.now + after + hold_us / 2, Event::Place(id, beside));
            }
        }
    }

    /// The operator puts robot `id` down at `at`, facing along x.
    pub(super) fn place(&mut self, id: u32, at: Vec2) {
        if let Some(Some(r)) = self.reals.get_mut(id as usize - 1) {
            r.body = Body { at, heading: 0.0 };
        }
    }

    /// A `Deploy` to robot `id` now: motion capture must see it at the
    /// start (the core deploys placed robots only).
    pub(super) fn check_placed(&mut self, id: u32) {
        let start = self.case.terrain.start();
        let Some(Some(r)) = self.reals.get(id as usize - 1) else { return };
        let off = r.body.at.distance(start);
        if off > PLACEMENT.radius {
            self.report
                .violations
                .push(format!("robot {id} deployed {off:.2} from the start at {} µs", self.now));
        }
    }

    /// Robot `id`'s robot link is cut now: a cut of a link that was up,
    /// long enough to be judged
    /// (the gateway's 300 ms timeout and the launch's grace) must be
    /// noticed within [`NOTICE_US`], as a crash is.
    pub(super) fn robot_cut(&mut self, id: u32, until_us: u64) {
        let judged = 300_000 + crate::agents::gateways::LINK_GRACE.as_micros() as u64 + NOTICE_US;
        let up = self.reals.get(id as usize - 1).and_then(Option::as_ref).is_some_and(RealRobot::link_up);
        if until_us >= self.now + judged && up && self.core.is_running(id) {
            self.fault(id);
        }
    }

    /// The real robots' broken promises, into the report.
    pub(super) fn collect_violations(&mut self) {
        for r in self.reals.iter().flatten() {
            self.report.violations.extend(r.violations.iter().cloned());
            if r.drove {
                self.report.drove.push(r.id());
            }
            if r.failsafe_tripped() {
                self.report.tripped.push(r.id());
            }
        }
    }
}
