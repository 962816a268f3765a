//! A fault schedule, drawn from one seed.
//!
//! Why one seed: a failing schedule must be replayed exactly, so every
//! choice (network faults, partitions, crashes, registrations, forgeries,
//! Ctrl-C) comes from one seeded generator, and the schedule is printed
//! with its seed.

use super::net::{NetFaults, Partition};
use crate::agents::AgentProperties;
use crate::setup::Seams;
use bycoms_mocap::PlacementConfig;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// The share of drawn schedules with real gateway agents (each plays
/// seconds of real time at the robots' own rates: kept few, so the
/// schedules per CI run stay within their time).
const GATEWAY_AGENTS: f64 = 0.005;

/// An agent's crash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crash {
    /// The robot.
    pub robot: u32,
    /// When, µs of virtual time.
    pub at_us: u64,
}

/// Foreign or forged traffic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Foreign {
    /// A robot's pose with step and time `u64::MAX`.
    StepFromTheFuture(u32),
    /// A robot's pose with step `u64::MAX` and a plausible time.
    HugeStep(u32),
    /// A robot's pose with a NaN coordinate.
    NotFinite(u32),
    /// A robot's pose at the goal, far from where it is.
    AtTheGoal(u32),
    /// A pose of robot `robot` on robot `topic`'s topic.
    OtherRobotsPose {
        /// The topic's robot.
        topic: u32,
        /// The robot named.
        robot: u32,
    },
    /// A `Register` of another protocol version.
    WrongVersion(u32),
    /// A `Register` of another agent whose failsafe grace is shorter than
    /// the launch's link grace.
    ShortGrace(u32),
    /// A `Register` of another agent started with other run settings.
    OtherSettings(u32),
    /// A report from a robot that is not in the launch.
    UnknownRobot,
    /// Poses of robot `robot` at the goal, one every 0.1 s from its time
    /// on (steps 5, 6, 7, … in real time; the tick in lockstep), most of
    /// them before the robot is deployed: they must neither set where it
    /// starts nor become the reference its own poses are judged against.
    GoalSeries {
        /// The robot.
        robot: u32,
        /// Poses of the series sent so far.
        sent: u32,
    },
    /// A pose of robot `.0` at the goal the moment it is told to deploy (a
    /// forger who watches the bus races its agent's start pose).
    RacesTheDeploy(u32),
}

/// What the operator does when asked to place a robot at the start
/// (real robots: the launch enables one once motion capture sees it there).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placing {
    /// Places it at the start this long after being asked, µs.
    Prompt(u64),
    /// Never places it.
    Never,
    /// Places it beside the start (outside the placement radius), µs.
    OffStart(u64),
    /// Places it at the start, then moves it off before the hold is over, µs.
    MovedOff(u64),
}

/// How the harness's operator places robots: within 0.5 of the start, seen
/// there for 0.2 s, within 3 s (short, so a robot never placed ends its
/// launch quickly). Every harness launch's `[placement]`.
pub const PLACEMENT: PlacementConfig = PlacementConfig { radius: 0.5, hold: 0.2, timeout: 3.0 };

/// Everything that goes wrong in one harness launch.
#[derive(Clone, Debug, PartialEq)]
pub struct Schedule {
    /// The seed it was drawn from (also the network's).
    pub seed: u64,
    /// Robots in the launch.
    pub robots: u32,
    /// Agents exist on their own (remote): all awaited at the start, their
    /// partitions reported as unreachable and back.
    pub remote: bool,
    /// The real-time clock at this speed-up (none: lockstep).
    pub realtime: Option<f64>,
    /// Delays, losses and duplicates.
    pub net_faults: NetFaults,
    /// Partitions.
    pub partitions: Vec<Partition>,
    /// Crashes.
    pub crashes: Vec<Crash>,
    /// Per robot, from its start to its first registration, µs (none: it
    /// never registers).
    pub register_delay_us: Vec<Option<u64>>,
    /// Per robot, how many of its agents die just after they are started,
    /// before they register (each start of a process costs one).
    pub early_deaths: Vec<u32>,
    /// Second agents for a robot, and when they register.
    pub second_agents: Vec<(u32, u64)>,
    /// Forged and foreign traffic, and when.
    pub foreign: Vec<(u64, Foreign)>,
    /// Ctrl-C, and when.
    pub interrupt_at_us: Option<u64>,
    /// The recording fails as the launch ends (the summary must say error).
    pub recording_fails: bool,
    /// The agent source tells a stuck robot to stop (as gateways do).
    pub stop_when_stuck: bool,
    /// Spawned agents are sent one `Tick` a period even for a robot that
    /// creeps once judged (as agents of another build are), not runs of
    /// them (`ToAgent::Ticks`).
    pub one_tick_a_period: bool,
    /// Agents started this many ahead of the robot that moves instead of
    /// the launch's own number ([`Starts::ahead`](crate::core::Starts)).
    pub starts_ahead: Option<u32>,
    /// Real time, remote: the agents have the gateways' properties (all at
    /// once, stuck robots stopped, the launch's poses forwarded to them,
    /// no beacons: real robots hear each other), the poses not on the bus.
    pub gateway_seams: bool,
    /// A stop asked from outside (`orchestrator stop`), when, and whether
    /// `--now`.
    pub stop_at_us: Option<(u64, bool)>,
    /// A robot revoked from outside (`orchestrator revoke`): when, and
    /// which. Not drawn: set by the tests that revoke.
    pub revoke_at_us: Option<(u64, u32)>,
    /// Real robots behind real gateways (`real.rs`): the launch's gateway
    /// setup, placement by an operator, poses from motion capture.
    pub gateways: bool,
    /// Gateway agents: robot links (robot ↔ gateway WiFi) cut.
    pub robot_cuts: Vec<Partition>,
    /// Gateway agents: per robot, what the operator does when asked to
    /// place it.
    pub placing: Vec<Placing>,
    /// Gateway agents: the lab's motion capture is not running (no pose
    /// of any robot ever comes).
    pub mocap_silent: bool,
}

impl Schedule {
    /// What the seams of this schedule's launch say of themselves: what
    /// the sources it plays say (their own `properties` functions, in
    /// `orchestrator/launch/src/agents/`), and what the schedule changes.
    /// Spawned agents or remote ones, with poses on the bus, stuck robots
    /// told to stop when the schedule says so; gateway agents standing in
    /// for agents on the bus (`gateway_seams`: placed by nobody, poses
    /// still forwarded); or real gateways with poses from motion capture
    /// (`gateways`: their placement confirmed by [`PLACEMENT`]).
    pub fn seams(&self) -> Seams {
        use crate::agents::{gateways, remote, spawned};
        // The launch's own agents run creeping robots ahead; remote ones
        // may be of another build.
        let own = spawned::properties(!self.one_tick_a_period);
        let inner = if self.remote { remote::properties() } else { own };
        if self.gateways {
            return Seams { agents: gateways::properties(inner, self.remote), poses_on_the_bus: false };
        }
        let mut agents = match self.gateway_seams {
            true => AgentProperties { needs_placement: false, ..gateways::properties(inner, false) },
            false => inner,
        };
        agents.stop_when_stuck |= self.stop_when_stuck;
        // As the launch's setup does with `[faults]` on: a lossy bus keeps
        // no command.
        agents.keeps_commands &= self.net_faults.drop == 0.0 && self.net_faults.duplicate == 0.0;
        Seams { agents, poses_on_the_bus: !self.gateway_seams }
    }

    /// Makes this schedule one of real robots behind gateways (real time,
    /// speed 1: real robots run on their own clocks), drawing robot-link
    /// cuts and the operator's placements from `rng`.
    fn real_robots(&mut self, rng: &mut Xoshiro256PlusPlus) {
        (self.gateways, self.gateway_seams, self.realtime) = (true, false, Some(1.0));
        // Poses come from motion capture, not the bus: no one forges them.
        self.foreign.retain(|(_, f)| {
            matches!(
                f,
                Foreign::WrongVersion(_)
                    | Foreign::ShortGrace(_)
                    | Foreign::OtherSettings(_)
                    | Foreign::UnknownRobot
            )
        });
        for _ in 0..rng.gen_range(0..3) {
            let from_us = rng.gen_range(0..4_000_000);
            let length = [100_000, 1_000_000, 3_000_000][rng.gen_range(0..3)];
            self.robot_cuts.push(Partition {
                robot: rng.gen_range(1..=self.robots),
                from_us,
                until_us: from_us + length,
            });
        }
        self.placing = (0..self.robots)
            .map(|_| match rng.gen_range(0..20) {
                0 => Placing::Never,
                1 => Placing::OffStart(rng.gen_range(0..1_000_000)),
                2 => Placing::MovedOff(rng.gen_range(0..1_000_000)),
                _ => Placing::Prompt(rng.gen_range(0..2_000_000)),
            })
            .collect();
    }

    /// This schedule with real robots behind real gateways, each placed
    /// the moment the operator is asked, no robot link cut.
    pub fn with_real_robots(mut self) -> Self {
        (self.gateways, self.gateway_seams, self.realtime) = (true, false, Some(1.0));
        self.placing = vec![Placing::Prompt(0); self.robots as usize];
        self
    }

    /// Nothing goes wrong: a perfect 50 µs link, prompt registrations.
    pub fn clean(seed: u64, robots: u32) -> Self {
        Self {
            seed,
            robots,
            remote: false,
            realtime: None,
            net_faults: NetFaults::perfect(50),
            partitions: Vec::new(),
            crashes: Vec::new(),
            register_delay_us: vec![Some(20_000); robots as usize],
            early_deaths: vec![0; robots as usize],
            second_agents: Vec::new(),
            foreign: Vec::new(),
            interrupt_at_us: None,
            recording_fails: false,
            stop_when_stuck: false,
            one_tick_a_period: false,
            starts_ahead: None,
            gateway_seams: false,
            stop_at_us: None,
            revoke_at_us: None,
            gateways: false,
            robot_cuts: Vec::new(),
            placing: Vec::new(),
            mocap_silent: false,
        }
    }

    /// Only forged and foreign traffic, drawn from `seed`, on a perfect link.
    pub fn forgeries(seed: u64, robots: u32, horizon_us: u64) -> Self {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0xf0f0);
        let mut s = Self::clean(seed, robots);
        s.foreign = (0..rng.gen_range(1..12))
            .map(|_| (rng.gen_range(0..horizon_us), foreign(&mut rng, robots)))
            .collect();
        s.foreign.sort_by_key(|f| f.0);
        s.second_agents = (0..rng.gen_range(0..3))
            .map(|_| (rng.gen_range(1..=robots), rng.gen_range(0..horizon_us)))
            .collect();
        s
    }

    /// Anything, drawn from `seed`. Faults fall within the first
    /// `ticks` lockstep ticks (their virtual length follows the link's
    /// delays) or the first second, whichever is longer.
    pub fn draw(seed: u64, robots: u32, ticks: u64) -> Self {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut s = Self::clean(seed, robots);
        let r = robots;
        s.remote = rng.gen_bool(0.3);
        s.realtime = rng.gen_bool(0.3).then(|| [1.0, 5.0, 10.0][rng.gen_range(0..3)]);
        let spread = [0, 200, 5_000, 50_000][rng.gen_range(0..4)];
        let min = rng.gen_range(10..2_000);
        s.net_faults = NetFaults {
            delay_min_us: min,
            delay_max_us: min + spread,
            drop: [0.0, 0.0, 0.01, 0.05][rng.gen_range(0..4)],
            duplicate: [0.0, 0.01, 0.1][rng.gen_range(0..3)],
            // Commands to agents on this host are never lost (the seam
            // keeps them): only remote links lose what they carry out.
            inbound_only: !s.remote,
        };
        let tick_us = match s.realtime {
            Some(speed) => (100_000.0 / speed) as u64,
            None => 2 * (s.net_faults.delay_max_us + 50),
        };
        let horizon_us = (ticks * tick_us).max(1_000_000);
        if s.remote {
            for _ in 0..rng.gen_range(0..3) {
                let from_us = rng.gen_range(0..horizon_us);
                let length = [300_000, 1_500_000, 2_300_000, 6_000_000][rng.gen_range(0..4)];
                s.partitions.push(Partition {
                    robot: rng.gen_range(1..=r),
                    from_us,
                    until_us: from_us + length,
                });
            }
        }
        for _ in 0..rng.gen_range(0..3) {
            s.crashes.push(Crash { robot: rng.gen_range(1..=r), at_us: rng.gen_range(0..horizon_us) });
        }
        for d in s.register_delay_us.iter_mut() {
            *d = match rng.gen_range(0..20) {
                0 => None,
                1 | 2 => Some(rng.gen_range(1_000_000..9_000_000)),
                _ => Some(rng.gen_range(1_000..300_000)),
            };
        }
        let forged = Self::forgeries(rng.gen(), robots, horizon_us);
        if rng.gen_bool(0.5) {
            s.foreign = forged.foreign;
            s.second_agents = forged.second_agents;
        }
        if rng.gen_bool(0.05) {
            s.interrupt_at_us = Some(rng.gen_range(0..horizon_us));
        }
        s.recording_fails = rng.gen_bool(0.05);
        s.stop_when_stuck = rng.gen_bool(0.3);
        s.gateway_seams = s.remote && s.realtime.is_some() && rng.gen_bool(0.5);
        // Drawn last, so the schedules drawn before stops existed are kept.
        if rng.gen_bool(0.05) {
            s.stop_at_us = Some((rng.gen_range(0..horizon_us), rng.gen_bool(0.7)));
        }
        if rng.gen_bool(GATEWAY_AGENTS) {
            s.real_robots(&mut rng);
        }
        s
    }
}

fn foreign(rng: &mut Xoshiro256PlusPlus, robots: u32) -> Foreign {
    let id = rng.gen_range(1..=robots);
    match rng.gen_range(0..11) {
        0 => Foreign::StepFromTheFuture(id),
        1 => Foreign::HugeStep(id),
        2 => Foreign::NotFinite(id),
        3 => Foreign::AtTheGoal(id),
        4 => Foreign::OtherRobotsPose { topic: id, robot: id % robots + 1 },
        5 => Foreign::WrongVersion(id),
        6 => Foreign::ShortGrace(id),
        7 => Foreign::OtherSettings(id),
        8 => Foreign::GoalSeries { robot: id, sent: 0 },
        9 => Foreign::RacesTheDeploy(id),
        _ => Foreign::UnknownRobot,
    }
}
