//! The lab world: bodies, sound and one emulated ESP32 per robot, on the
//! lab's own clock.
//!
//! Why one loop: physics (5 ms steps), sound (one 125 ms microphone window
//! per control period) and the robots' link must see one consistent time.
//! [`Lab::step`] advances it by [`PHYSICS_DT`]: every robot's socket is
//! pumped, the emulated operator places a robot at the start when asked
//! ([`Lab::place`]) or at the latest the first time its firmware is enabled
//! (until then it waits off the arena, silent and out of the way), control periods feed each placed robot's microphones
//! with the sound of every placed robot's speaker, and bodies move. A
//! caller that wants real time sleeps between steps; tests don't.
//!
//! A lab of ROS 2 robots ([`Lab::ros2`]) has no ESP32 and no sound: its
//! robots are [`DiffDrive`] bodies that their agents drive by `cmd_vel`
//! ([`Lab::command`]), placed by the same operator and moved by the same
//! physics steps, colliding with the acoustic bodies as with each other.

use super::body::{arena_walls, Crawler, Obstacle};
use super::esp32::{EmulatedEsp32, LISTENED};
use super::ros2_body::{DiffDrive, DiffDriveConfig};
use super::scenario::{Pose, Scenario};
use super::sound::{mic_positions, sample_frames, Room, Speaker};
use bycoms_agent::firmware::FirmwareConfig;
use bycoms_agent::wheeled::Velocity;
use bycoms_protocol::link::LinkKey;
use bycoms_protocol::RobotId;
use core::time::Duration;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::io;
use std::net::SocketAddr;

/// Physics step.
pub const PHYSICS_DT: Duration = Duration::from_millis(5);
/// Control period: 512 samples at 4096 Hz.
pub const CONTROL_PERIOD: Duration = Duration::from_millis(125);

/// One robot of the lab.
#[derive(Debug)]
pub struct LabRobot {
    /// Its microcontroller.
    pub esp: EmulatedEsp32,
    /// Its body, once the operator has placed it.
    pub body: Option<Crawler>,
    phase: f64,
}

/// One ROS 2 robot of the lab: a body its agent drives by `cmd_vel`.
#[derive(Debug)]
pub struct Ros2Robot {
    /// Its robot id.
    pub id: RobotId,
    /// Its body, once the operator has placed it.
    pub body: Option<DiffDrive>,
    config: DiffDriveConfig,
    /// Its body's slip seed.
    seed: u64,
}

/// How one emulated robot is wired: its key, the UDP address it binds
/// (port 0: any free port) and the gateway it talks to.
#[derive(Clone, Debug)]
pub struct Wiring {
    /// The robot's pre-shared link key.
    pub key: LinkKey,
    /// The robot's own UDP address.
    pub bind: SocketAddr,
    /// Its gateway's UDP address.
    pub gateway: SocketAddr,
}

/// The emulated lab.
#[derive(Debug)]
pub struct Lab {
    scenario: Scenario,
    /// The scenario's frames and the arena's wall.
    obstacles: Vec<Obstacle>,
    robots: Vec<LabRobot>,
    ros2: Vec<Ros2Robot>,
    now: Duration,
    next_control: Duration,
    rng: Xoshiro256PlusPlus,
}

impl Lab {
    /// Boots one emulated ESP32 per scenario tone on 127.0.0.1:0; robot k
    /// (1-based) uses `keys[k-1]` and sends to `gateways[k-1]`.
    pub fn new(scenario: Scenario, keys: &[LinkKey], gateways: &[SocketAddr], seed: u64) -> io::Result<Self> {
        let any = SocketAddr::from(([127, 0, 0, 1], 0));
        let wiring: Vec<Wiring> = keys
            .iter()
            .zip(gateways)
            .map(|(key, &gateway)| Wiring { key: key.clone(), bind: any, gateway })
            .collect();
        Self::wired(scenario, &wiring, seed)
    }

    /// Boots one emulated ESP32 per scenario tone; robot k (1-based) is
    /// wired as `wiring[k-1]` says.
    pub fn wired(scenario: Scenario, wiring: &[Wiring], seed: u64) -> io::Result<Self> {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let tones = scenario.tones.clone();
        let mut robots = Vec::with_capacity(tones.len());
        for (i, (&own, w)) in tones.iter().zip(wiring).enumerate() {
            let mut others = [0.0; LISTENED];
            let listened: Vec<f64> = tones.iter().copied().filter(|&t| t != own).collect();
            // Fewer than LISTENED other robots: listen to unused paper tones too (silent).
            let spare: Vec<f64> = [224.0, 320.0, 512.0, 416.0]
                .into_iter()
                .filter(|t| *t != own && !listened.contains(t))
                .collect();
            for (slot, t) in others.iter_mut().zip(listened.into_iter().chain(spare)) {
                *slot = t;
            }
            let mut config = FirmwareConfig::paper(RobotId(i as u32 + 1), own, others);
            config.tones.sample_rate = scenario.sound.sample_rate;
            config.tones.gain = scenario.sound.gain;
            let entropy: [u8; 32] = rng.gen();
            let esp =
                EmulatedEsp32::bind(config, w.key.clone(), entropy, w.bind, w.gateway).map_err(|e| {
                    // Which robot and which address (issue 49): an address of
                    // another host cannot be bound here, nor one in use.
                    io::Error::new(e.kind(), format!("robot {}'s address {}: {e}", i + 1, w.bind))
                })?;
            robots.push(LabRobot { esp, body: None, phase: rng.gen_range(0.0..core::f64::consts::TAU) });
        }
        if robots.len() != tones.len() {
            let why =
                format!("the scenario has {} robots (tones) but {} are wired", tones.len(), wiring.len());
            return Err(io::Error::new(io::ErrorKind::InvalidInput, why));
        }
        let mut obstacles = scenario.obstacles.clone();
        obstacles.extend(arena_walls(scenario.width, scenario.height));
        let (ros2, next_control) = (Vec::new(), CONTROL_PERIOD);
        Ok(Self { scenario, obstacles, robots, ros2, now: Duration::ZERO, next_control, rng })
    }

    /// A lab of ROS 2 robots only: one [`DiffDrive`] body per `(id,
    /// config)`, off the arena until placed; no ESP32, no sound.
    pub fn ros2(scenario: Scenario, robots: &[(RobotId, DiffDriveConfig)], seed: u64) -> Self {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let ros2 = robots
            .iter()
            .map(|&(id, config)| Ros2Robot { id, body: None, config, seed: rng.gen() })
            .collect();
        let mut obstacles = scenario.obstacles.clone();
        obstacles.extend(arena_walls(scenario.width, scenario.height));
        let (robots, next_control) = (Vec::new(), CONTROL_PERIOD);
        Self { scenario, obstacles, robots, ros2, now: Duration::ZERO, next_control, rng }
    }

    /// The scenario.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// Lab time.
    pub fn now(&self) -> Duration {
        self.now
    }

    /// The robots, in id order.
    pub fn robots(&self) -> &[LabRobot] {
        &self.robots
    }

    /// The ROS 2 robots, in id order.
    pub fn ros2_robots(&self) -> &[Ros2Robot] {
        &self.ros2
    }

    /// Every robot's id and its body's pose (`None`: not placed yet):
    /// the acoustic robots (ids 1, 2, … in order), then the ROS 2 ones.
    pub fn poses(&self) -> Vec<(RobotId, Option<Pose>)> {
        let acoustic = self.robots.iter().enumerate().map(|(i, r)| {
            (RobotId(i as u32 + 1), r.body.map(|b| Pose { x: b.x, y: b.y, heading: b.heading }))
        });
        let ros2 = self
            .ros2
            .iter()
            .map(|r| (r.id, r.body.as_ref().map(|b| Pose { x: b.x, y: b.y, heading: b.heading })));
        acoustic.chain(ros2).collect()
    }

    /// Hands ROS 2 robot `id` a velocity command that arrived at lab time
    /// `at`. False when there is no such robot or it is not placed yet
    /// (its driver is off the arena: the command is lost).
    pub fn command(&mut self, id: RobotId, at: Duration, command: Velocity) -> bool {
        match self.ros2.iter_mut().find(|r| r.id == id).and_then(|r| r.body.as_mut()) {
            Some(body) => {
                body.command(at, command);
                true
            }
            None => false,
        }
    }

    /// The emulated operator puts robot `index` (0-based) on the start mark,
    /// as the orchestrator's placement request asks (`bycoms/<swarm>/operator`):
    /// a still, silent body until its firmware is enabled; a ROS 2 robot
    /// (id `index + 1`), a still body until commanded. False when there
    /// is no such robot or it is already in the arena (a body is placed once).
    pub fn place(&mut self, index: usize) -> bool {
        let s = self.scenario.placement(index);
        match self.robots.get_mut(index) {
            Some(r) if r.body.is_none() => {
                r.body = Some(Crawler::new(s.x, s.y, s.heading));
                true
            }
            Some(_) => false,
            None => {
                let id = RobotId(index as u32 + 1);
                match self.ros2.iter_mut().find(|r| r.id == id) {
                    Some(r) if r.body.is_none() => {
                        r.body = Some(DiffDrive::new(r.config, s.x, s.y, s.heading, r.seed));
                        true
                    }
                    _ => false,
                }
            }
        }
    }

    /// Advances the lab by one physics step.
    pub fn step(&mut self) -> io::Result<()> {
        let now = self.now;
        for (index, r) in self.robots.iter_mut().enumerate() {
            r.esp.pump(now)?;
            if r.body.is_none() && r.esp.tone().is_some() {
                let s = self.scenario.placement(index);
                r.body = Some(Crawler::new(s.x, s.y, s.heading));
            }
        }
        if now >= self.next_control {
            self.control(now)?;
            self.next_control += CONTROL_PERIOD;
        }
        let dt = PHYSICS_DT.as_secs_f64();
        let centres: Vec<Option<(f64, f64)>> = self
            .robots
            .iter()
            .map(|r| r.body.map(|b| (b.x, b.y)))
            .chain(self.ros2.iter().map(|r| r.body.as_ref().map(|b| (b.x, b.y))))
            .collect();
        let others = |i: usize| -> Vec<(f64, f64)> {
            centres.iter().enumerate().filter(|&(j, _)| j != i).filter_map(|(_, c)| *c).collect()
        };
        for (i, r) in self.robots.iter_mut().enumerate() {
            let m = r.esp.motors();
            if let Some(b) = r.body.as_mut() {
                b.step(&self.scenario.body, (m.left, m.right), dt, &self.obstacles, &others(i));
            }
        }
        let first = self.robots.len();
        for (k, r) in self.ros2.iter_mut().enumerate() {
            if let Some(b) = r.body.as_mut() {
                b.step(now, PHYSICS_DT, &self.obstacles, &others(first + k));
            }
        }
        self.now += PHYSICS_DT;
        Ok(())
    }

    fn control(&mut self, now: Duration) -> io::Result<()> {
        let speakers: Vec<Speaker> = self
            .robots
            .iter()
            .filter_map(|r| {
                let (b, f) = (r.body?, r.esp.tone()?);
                Some(Speaker { x: b.x, y: b.y, freq: f, phase: r.phase })
            })
            .collect();
        let room = Room { width: self.scenario.width, height: self.scenario.height };
        let t0 = now.saturating_sub(CONTROL_PERIOD).as_secs_f64();
        for r in &mut self.robots {
            let Some(b) = r.body else { continue };
            let mics = mic_positions(b.x, b.y, b.heading, 0.1);
            let motor = r.esp.motors().left.abs().max(r.esp.motors().right.abs());
            let frames =
                sample_frames(&self.scenario.sound, &room, &speakers, &mics, motor, t0, &mut self.rng);
            r.esp.control(&frames, now)?;
        }
        Ok(())
    }
}
