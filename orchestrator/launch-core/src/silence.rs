//! Motion capture gone: the launch of real robots ends when the room's
//! motion capture falls silent, and says so.
//!
//! Why: with real robots (`agents.source = "real"`) the gate sees the
//! robots only through motion capture. When the room goes away at once —
//! the emulated lab (`sim-agent lab`: the robots *and* the cameras) killed,
//! Motive closed, the mocap host unplugged — every gateway also stops
//! hearing its robot, reports its link lost and the robots die one by one:
//! the launch used to end "robots exhausted", each robot's death saying
//! "link lost", which sends the operator after the WiFi. The cause is the
//! motion capture, and the launch must name it (an error: exit 1).
//!
//! What counts: a pose of a robot whose agent is alive, as the pose source
//! handed it over (before the plausibility check: an implausible pose is
//! still motion capture speaking). Poses of dead robots do not count: the
//! launch republishes their last pose itself (`Output::Relay`), and on the
//! bus those come back. The clock starts with the first such pose (before
//! a robot is placed the emulated lab sees no body) and stops while no
//! live robot has been seen (after the only visible robot died, while the
//! next is carried in).
//!
//! Two thresholds, both in wall time (divided by the run's speed, as the
//! gateways' link timer and the gate's mocap clock are):
//!
//! * **with a lost link**: a robot reported gone for its lost link
//!   (`Gone::RobotLinkLost`, 300 ms after its last frame and 150 ms of
//!   `LINK_GRACE` (`bycoms_launch::agents::gateways`) later: 450 ms after the cut) while motion capture has
//!   been silent at least the gateways' own link timeout, [`SILENCE`]
//!   (300 ms), was lost with the room: the launch ends there, naming
//!   motion capture, and no robot is judged dead for its link. The last
//!   pose and the last robot frame come from the same moment (the lab's
//!   frames every 50 ms, its robots' heartbeats every 100 ms), so at that
//!   death the silence is 350 ms or more. A robot whose own link is lost
//!   while the cameras still stream (its WiFi) dies as before.
//! * **alone**: motion capture silent for the gate's dwell (`gate.dwell`,
//!   2 s of mocap time in the lab) ends the launch too (the cameras gone,
//!   the robots' links not): no stop could be judged in that time. Not
//!   shorter, because a lone robot occluded for a moment (the lab's NatNet
//!   faults hide one for 1 s) is not a room gone; a robot that stands
//!   still is still seen.
//!
//! Not applied in lockstep, nor with simulated agents: there the agents'
//! own poses are the motion capture, and silence means the agents wait.

use super::*;

/// How long a gateway hears nothing from its robot before it reports the
/// robot's link lost (`Link { up: false }`), in robot time (the gateway
/// divides it by the run's speed): the gateway's own default (its
/// `--link-timeout-ms`), which the launch starts its gateways with
/// (`bycoms_launch::agents::gateways`, which re-exports this and checks that
/// it is the gateway's default when it compiles).
pub const LINK_TIMEOUT: std::time::Duration = std::time::Duration::from_millis(300);

/// How long motion capture may be silent, at speed 1, when a robot's link
/// is lost (see the module docs).
pub const SILENCE: std::time::Duration = LINK_TIMEOUT;

impl LaunchCore {
    /// How long motion capture may be silent in this launch, wall µs:
    /// `(with a lost link, alone)`; none when it is not the robots' only
    /// witness (lockstep, simulated agents).
    pub(super) fn mocap_limits_us(&self) -> Option<(u64, u64)> {
        let real = !self.setup.lockstep && self.setup.agents.placement.is_some();
        let wall = |us: u64| ((us as f64 / self.setup.speed) as u64).max(1);
        let link = wall(SILENCE.as_micros() as u64);
        real.then(|| (link, wall(self.setup.params.dwell_us).max(link)))
    }

    /// Motion capture handed over a pose for robot `topic` at `now`.
    pub(super) fn mocap_heard(&mut self, now: u64, topic: u32) {
        if self.slot_ref(topic).is_some_and(|s| s.alive) {
            if let Some(heard) = topic.checked_sub(1).and_then(|i| self.mocap_heard.get_mut(i as usize)) {
                *heard = Some(now);
            }
        }
    }

    /// The newest pose of a live robot, µs: when motion capture last spoke.
    fn mocap_last_us(&self) -> Option<u64> {
        self.slots.iter().zip(&self.mocap_heard).filter(|(s, _)| s.alive).filter_map(|(_, h)| *h).max()
    }

    /// When motion capture will have been silent too long on its own, if
    /// it is watched.
    pub(super) fn mocap_due(&self) -> Option<u64> {
        Some(self.mocap_last_us()?.saturating_add(self.mocap_limits_us()?.1))
    }

    /// The error that ends the launch when motion capture has been silent
    /// too long at `now`: for its limit alone, or, when robot `lost_link`'s
    /// link is lost, for the gateways' link timeout.
    pub(super) fn mocap_gone(&self, now: u64, lost_link: Option<u32>) -> Option<Fault> {
        let (last, (link, alone)) = (self.mocap_last_us()?, self.mocap_limits_us()?);
        let silent = now.saturating_sub(last);
        let (silent_ms, dwell_ms) = (silent / 1000, alone / 1000);
        match lost_link {
            Some(_) if silent >= link => Some(Fault::MocapGone { silent_ms, lost_link, dwell_ms }),
            _ if silent >= alone => Some(Fault::MocapGone { silent_ms, lost_link: None, dwell_ms }),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    //! The launch config's defaults (above this crate) written out where a
    //! setup needs them: `gate.on_agent_death`, `supervision.missing`,
    //! `unreachable_grace`, `register_timeout`.

    use super::*;
    use bycoms_protocol::msg::{LinkStatus, RobotKind};

    const PERIOD_US: u64 = 125_000;
    const FRAME_US: u64 = 50_000;

    /// A launch of two real robots (gateways, placed by an operator) at
    /// speed 1.
    fn real_robots() -> Setup {
        let (start, goal) = (Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0));
        Setup {
            robots: 2,
            lockstep: false,
            params: GateParams {
                goal,
                goal_radius: 0.15,
                stop_speed: 0.02,
                stop_turn_rate: 0.1,
                dwell_us: 2_000_000,
                period_us: PERIOD_US,
            },
            step_limit: 10_000,
            wall_period_us: PERIOD_US,
            speed: 1.0,
            tick_timeout_us: 5_000_000,
            on_death: OnDeath::Beacon,
            missing: Missing::Skip,
            prespawn: false,
            start,
            goal,
            max_speed: 1.0,
            register_timeout_s: 10.0,
            agents: AgentTraits {
                kind: "gateway".into(),
                all_at_once: true,
                stop_when_stuck: true,
                start_hint: String::new(),
                placement: Some(PlacementConfig { radius: 0.5, hold: 0.2, timeout: 60.0 }),
                forward_poses: false,
                beacons: false,
            },
            unix_base_ms: 0,
            settings: 0,
            // The robots' links are lost by hand here (`Input::Gone`): the
            // timers that judge them are `timers.rs`'s tests.
            supervision: Supervision::never(2_000_000),
            clocks: ClockLimits::default(),
            commands: Default::default(),
            starts: Default::default(),
            members: Default::default(),
        }
    }

    /// The lab in virtual time: its motion capture streams robot 1 every
    /// 50 ms, driving away from the start at 0.2 m/s once deployed.
    struct Lab {
        core: LaunchCore,
        now: u64,
        frame: u64,
        deployed: bool,
        x: f64,
        /// The robots the operator was asked to place.
        asked: Vec<u32>,
        /// Robot 1's pose time per wall time: its agent's speed-up over the
        /// launch's (a simulated member at `--sim-speed`).
        clock: u64,
        /// Poses the core refused.
        refused: usize,
    }

    impl Lab {
        fn new(setup: Setup) -> Self {
            Self {
                core: LaunchCore::new(setup),
                now: 0,
                frame: 0,
                deployed: false,
                x: 0.0,
                asked: Vec::new(),
                clock: 1,
                refused: 0,
            }
        }

        fn step(&mut self, input: Option<Input>) {
            if let Some(input) = input {
                self.core.handle(self.now, input);
            }
            self.core.advance(self.now);
            while let Some(out) = self.core.poll() {
                match out {
                    Output::Start(id) => {
                        let how = "gateway started".to_string();
                        self.core.handle(self.now, Input::Started { robot: id, pid: None, how });
                        let r = Register {
                            robot: RobotId(id),
                            kind: RobotKind::Real,
                            protocol_version: PROTOCOL_VERSION,
                            instance: u64::from(id),
                            settings: 0,
                            failsafe_grace_ms: 0,
                        };
                        self.core.handle(self.now, Input::Report(FromAgent::Register(r)));
                    }
                    Output::Send(1, ToAgent::Deploy(_)) => self.deployed = true,
                    Output::AskOperator(d) => self.asked.push(d.robot.0),
                    Output::Bad(BadKind::Refused, _) => self.refused += 1,
                    _ => {}
                }
            }
        }

        /// Runs the lab (its mocap on, `frames`) until `until` µs.
        fn run(&mut self, until: u64, frames: bool) {
            while self.now < until {
                self.now += FRAME_US.min(until - self.now);
                self.step(None);
                if frames && self.now.is_multiple_of(FRAME_US) {
                    self.frame += 1;
                    if self.deployed {
                        self.x += 0.2 * FRAME_US as f64 / 1e6;
                    }
                    let pose = Pose {
                        robot: RobotId(1),
                        x: self.x,
                        y: 0.0,
                        heading: 0.0,
                        step: self.frame,
                        time_us: self.now * self.clock,
                    };
                    self.step(Some(Input::Pose { topic: 1, pose }));
                }
            }
        }

        fn link_lost(&mut self, id: u32) {
            let l = LinkStatus { robot: RobotId(id), up: false, silent_ms: 300, refused: 0 };
            self.step(Some(Input::Report(FromAgent::Link(l))));
        }
    }

    /// The lab killed while robot 1 drives: motion capture stops and, 300
    /// ms later, both gateways say their links are lost; 150 ms after that
    /// both robots are gone. The launch ends at the first of them, naming
    /// motion capture, and no robot is judged dead for its link.
    #[test]
    fn a_lab_killed_mid_launch_ends_saying_motion_capture_is_gone() {
        let mut lab = Lab::new(real_robots());
        lab.run(3_000_000, true);
        assert_eq!(lab.core.phase(), Phase::Watching, "robot 1 drives");
        let cut = lab.now;
        lab.run(cut + 300_000, false);
        lab.link_lost(1);
        lab.link_lost(2);
        assert!(lab.core.ending().is_none(), "a link lost is not an ending yet");
        lab.now = cut + 450_000;
        lab.step(Some(Input::Gone(2, Gone::RobotLinkLost)));
        lab.step(Some(Input::Gone(1, Gone::RobotLinkLost)));
        let ending = lab.core.ending().expect("the launch ended");
        assert_eq!(ending.outcome, Outcome::Error);
        let fault = Fault::MocapGone { silent_ms: 450, lost_link: Some(2), dwell_ms: 2_000 };
        assert_eq!(ending.error, Some(fault));
        assert!(lab.core.slots().iter().all(|s| s.death.is_none()), "no robot judged dead for its link");
    }

    /// A robot's own link lost while motion capture still sees it (its
    /// WiFi, not the room): that robot dies as before and the launch goes
    /// on; with no live robot seen (the only one seen is dead; its relayed
    /// poses are not motion capture) silence says nothing.
    #[test]
    fn a_lost_link_with_motion_capture_on_is_one_dead_robot() {
        let mut lab = Lab::new(real_robots());
        lab.run(3_000_000, true);
        let cut = lab.now;
        lab.run(cut + 450_000, true);
        lab.link_lost(1);
        lab.step(Some(Input::Gone(1, Gone::RobotLinkLost)));
        assert!(lab.core.ending().is_none(), "{:?}", lab.core.ending());
        assert!(lab.core.slots()[0].death.is_some(), "robot 1 died");
        lab.run(cut + 10_000_000, true);
        assert!(lab.core.ending().is_none(), "{:?}", lab.core.ending());
        assert_eq!(lab.core.mocap_due(), None);
    }

    /// The only robot seen hidden for 1 s goes on; the cameras silent for
    /// the gate's dwell (2 s) with every link up end the launch.
    #[test]
    fn motion_capture_silent_for_the_dwell_ends_the_launch() {
        let mut lab = Lab::new(real_robots());
        lab.run(3_000_000, true);
        let hidden = lab.now;
        lab.run(hidden + 1_000_000, false);
        lab.run(hidden + 2_000_000, true);
        assert!(lab.core.ending().is_none(), "{:?}", lab.core.ending());
        let cut = lab.now;
        lab.run(cut + 1_950_000, false);
        assert!(lab.core.ending().is_none(), "{:?}", lab.core.ending());
        assert_eq!(lab.core.mocap_due(), Some(cut + 2_000_000), "the core's deadline includes it");
        lab.run(cut + 2_000_000, false);
        let ending = lab.core.ending().expect("the launch ended");
        let fault = ending.error.clone().expect("an error");
        assert_eq!(fault, Fault::MocapGone { silent_ms: 2_000, lost_link: None, dwell_ms: 2_000 });
        let said = "motion capture gone: no pose of any robot for 2000 ms (the gate's dwell is 2000 ms)";
        assert_eq!(fault.to_string(), said, "in words at the edge");
    }

    /// Lockstep and simulated agents: silence is the agents waiting.
    /// A mixed swarm (this lab's harness serves, its motion capture
    /// streaming robot 1 at the start): a simulated robot 1 is deployed
    /// without asking the operator; a real one is placed first.
    #[test]
    fn a_simulated_member_is_deployed_without_an_operator_and_a_real_one_is_placed() {
        let mut simulated = real_robots();
        simulated.members.simulated = vec![1];
        let mut lab = Lab::new(simulated);
        lab.run(1_000_000, true);
        assert!(lab.deployed && lab.asked.is_empty(), "deployed {}, asked {:?}", lab.deployed, lab.asked);
        let mut lab = Lab::new(real_robots());
        lab.run(1_000_000, true);
        assert_eq!(lab.asked, [1], "the real robot 1 is placed");
        assert!(lab.deployed, "then deployed, motion capture seeing it at the start");
    }

    /// `--sim-speed`: a simulated member's agent runs 4 times faster than
    /// the launch, so its pose time runs 4 times as fast as the wall. Each
    /// pose is judged against its robot's own clock: after 1.5 s of wall
    /// time without a frame (a loaded host), the next pose is 6 s of pose
    /// time on, within the rule at the member's speed-up (2 × 1.5 × 4 s +
    /// slack) and beyond it at the launch's (2 × 1.5 s + 0.5 s).
    #[test]
    fn a_simulated_members_poses_are_judged_at_its_own_speed_up() {
        for (sim_speed, refused) in [(4.0, false), (1.0, true)] {
            let mut setup = real_robots();
            setup.members = Members { simulated: vec![1], sim_speed };
            let mut lab = Lab::new(setup);
            lab.clock = 4;
            lab.run(1_000_000, true);
            assert!(
                lab.deployed && lab.refused == 0,
                "poses 4× the wall, one frame at a time: {}",
                lab.refused
            );
            let gap = lab.now;
            lab.run(gap + 1_500_000, false);
            lab.run(gap + 1_500_000 + FRAME_US, true);
            assert_eq!(lab.refused > 0, refused, "sim_speed {sim_speed}: refused {}", lab.refused);
        }
    }

    #[test]
    fn without_real_robots_silence_is_not_watched() {
        let mut setup = real_robots();
        setup.agents.placement = None;
        assert_eq!(LaunchCore::new(setup.clone()).mocap_limits_us(), None);
        setup.agents.placement = Some(PlacementConfig::default());
        setup.lockstep = true;
        assert_eq!(LaunchCore::new(setup.clone()).mocap_limits_us(), None);
        setup.lockstep = false;
        setup.speed = 2.0;
        let halved = Some((150_000, 1_000_000));
        assert_eq!(
            LaunchCore::new(setup).mocap_limits_us(),
            halved,
            "the gateways' timer and the mocap clock follow the speed"
        );
    }
}
