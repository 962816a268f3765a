//! The recorder: the emulated lab's `exp-short` with the firmware cores in
//! this process, each robot's every firmware call written to the input file.
//!
//! Why not `bycoms_lab::Lab` itself: its emulated ESP32s talk UDP and
//! keep their firmware calls to themselves. This loop is the same lab —
//! its scenario, its sound (`sample_frames`: 1/d, propagation delay, wall
//! echoes, motor vibration, ADC noise), its crawler bodies, its 5 ms
//! physics step and 125 ms control period, the shell calls of its
//! `EmulatedEsp32` (datagrams, then `handle_timeout`, then transmit, every
//! step; microphones, then transmit, every period) — with the link
//! delivered in memory one step later, as the sockets do, and every call
//! going through the shared shell so that it is recorded.
//!
//! The run: robot 1 is enabled and given goal bearings every 100 ms from
//! its true pose until it stands still for 1 s (stuck at the frame), then
//! stopped (a beacon); robot 2 then crosses robot 1's field. Robot 2's link
//! also gets what a hostile or flaky network does: a replayed goal, a forged
//! one, a frame for robot 1, a short and an oversized junk datagram, 700 ms
//! without commands (the failsafe), 1.2 s of silence (a new session, so
//! the gateway enables it again), and its battery sinks below the
//! low-battery mark.

use bycoms_agent::acoustic::ADC_MAX;
use bycoms_agent::angle::wrap;
use bycoms_fw_replay::{tag, Boot, NoMeter, Shell, LISTENED, MAGIC, MIC_BYTES};
use bycoms_lab::body::{arena_walls, Crawler, Obstacle};
use bycoms_lab::scenario::Scenario;
use bycoms_lab::sound::{mic_positions, sample_frames, Room, Speaker};
use bycoms_protocol::link::{GatewayEvent, GatewayLink, LinkKey, Payload, SessionId};
use bycoms_protocol::RobotId;
use core::time::Duration;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::collections::VecDeque;

const PHYSICS_DT: Duration = Duration::from_millis(5);
const CONTROL_PERIOD: Duration = Duration::from_millis(125);
const GOAL_EVERY: Duration = Duration::from_millis(100);

/// What a recording holds.
pub struct Recording {
    /// The input file's bytes.
    pub input: Vec<u8>,
    /// The output lines of the live run (what a replay must print).
    pub live: String,
    /// A one-line account of the run.
    pub summary: String,
}

/// One robot: its firmware in the shell, its recorded calls, its body, its gateway.
struct Robot {
    shell: Shell,
    records: Vec<u8>,
    live: String,
    body: Option<Crawler>,
    phase: f64,
    link: GatewayLink,
    /// Datagrams on their way to the robot (delivered at its next pump).
    inbox: VecDeque<Vec<u8>>,
    session: u64,
    last_frame: Option<Vec<u8>>,
}

impl Robot {
    fn boot(boot: &Boot, phase: f64) -> Self {
        let mut shell = Shell::new();
        let mut live = String::new();
        let mut records = vec![tag::BOOT];
        records.extend_from_slice(&boot.encode());
        shell.boot(boot, &mut live).expect("the lab's tones are valid");
        Self {
            shell,
            records,
            live,
            body: None,
            phase,
            link: GatewayLink::new(RobotId(boot.robot), LinkKey::new(&boot.key)),
            inbox: VecDeque::new(),
            session: 1000 * u64::from(boot.robot),
            last_frame: None,
        }
    }

    fn record(&mut self, tag: u8, now: Duration) {
        self.records.push(tag);
        self.records.extend_from_slice(&(now.as_micros() as u64).to_le_bytes());
    }

    /// The gateway sends `payload` in the current session, if any.
    fn command(&mut self, payload: Payload) -> Option<Vec<u8>> {
        let mut out = [0u8; 128];
        let frame = self.link.send(payload, &mut out).ok()?.to_vec();
        self.inbox.push_back(frame.clone());
        self.last_frame = Some(frame.clone());
        Some(frame)
    }

    /// The emulated ESP32's pump: datagrams, timers, transmit. Returns
    /// whether the gateway saw a session start (the robot must be enabled again).
    fn pump(&mut self, now: Duration) -> bool {
        while let Some(d) = self.inbox.pop_front() {
            self.record(tag::DATAGRAM, now);
            self.records.extend_from_slice(&(d.len() as u16).to_le_bytes());
            self.records.extend_from_slice(&d);
            self.shell.datagram(&d, now, &mut NoMeter, &mut self.live).expect("live datagram");
        }
        self.record(tag::TIMEOUT, now);
        self.shell.timeout(now, &mut NoMeter, &mut self.live).expect("live timeout");
        self.transmit(now)
    }

    fn transmit(&mut self, now: Duration) -> bool {
        self.record(tag::TRANSMIT, now);
        let mut sent = vec![];
        self.shell.transmit(now, &mut NoMeter, &mut self.live, |f| sent.push(f.to_vec())).expect("live tx");
        let mut started = false;
        for frame in sent {
            let Ok(accepted) = self.link.receive(&frame) else { continue };
            started |= accepted.session_started.is_some();
            if let GatewayEvent::Hello(nonce) = accepted.event {
                self.session += 1;
                let mut out = [0u8; 128];
                let welcome = self.link.welcome(nonce, SessionId(self.session), &mut out).expect("welcome");
                self.inbox.push_back(welcome.to_vec());
            }
        }
        started
    }

    fn control(&mut self, samples: &[u8; MIC_BYTES], now: Duration) -> bool {
        self.record(tag::MICS, now);
        self.records.extend_from_slice(samples);
        self.shell.mics(samples, now, &mut NoMeter, &mut self.live).expect("live mics");
        self.transmit(now)
    }

    fn battery(&mut self, mv: u16) {
        self.records.push(tag::BATTERY);
        self.records.extend_from_slice(&mv.to_le_bytes());
        self.shell.battery(mv, &mut self.live).expect("live battery");
    }

    fn tone(&self) -> Option<f64> {
        self.shell.firmware().and_then(|f| f.tone())
    }

    fn motor(&self) -> f64 {
        self.shell.firmware().map_or(0.0, |f| f.motors().left.abs().max(f.motors().right.abs()))
    }
}

/// Frames of the six microphones as the ADC's integers, little-endian.
fn to_samples(frames: &bycoms_agent::firmware::MicFrames) -> [u8; MIC_BYTES] {
    let mut out = [0u8; MIC_BYTES];
    for (i, s) in frames.iter().flatten().enumerate() {
        assert!(*s <= ADC_MAX, "not a 12-bit ADC sample: {s}");
        out[2 * i..2 * i + 2].copy_from_slice(&s.to_le_bytes());
    }
    out
}

/// Runs `exp-short` for at most `limit` of lab time (it ends earlier when
/// robot 2 has arrived and been stopped).
pub fn record(limit: Duration, seed: u64) -> Recording {
    let scenario = Scenario::builtin("exp-short").expect("built-in scenario");
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut robots: Vec<Robot> = Vec::new();
    for (i, &own) in scenario.tones.iter().enumerate() {
        // As the lab does: the other robots' tones, then unused paper tones.
        let mut others = [0.0; LISTENED];
        let listened = scenario.tones.iter().copied().filter(|&t| t != own);
        let spare =
            [224.0, 320.0, 512.0, 416.0].into_iter().filter(|t| *t != own && !scenario.tones.contains(t));
        for (slot, t) in others.iter_mut().zip(listened.chain(spare)) {
            *slot = t;
        }
        let robot = i as u32 + 1;
        let boot = Boot {
            robot,
            own_tone: own,
            other_tones: others,
            sample_rate: scenario.sound.sample_rate,
            gain: scenario.sound.gain,
            key: [robot as u8 * 17; 32],
            entropy: rng.gen(),
        };
        robots.push(Robot::boot(&boot, rng.gen_range(0.0..core::f64::consts::TAU)));
    }
    let mut obstacles: Vec<Obstacle> = scenario.obstacles.clone();
    obstacles.extend(arena_walls(scenario.width, scenario.height));
    let room = Room { width: scenario.width, height: scenario.height };
    let start = scenario.start;
    let goal = scenario.goal;

    let mut now = Duration::ZERO;
    let mut next_control = CONTROL_PERIOD;
    let mut current = 0usize;
    let mut enabled = false;
    let mut enabled_at = Duration::ZERO;
    let mut last_goal = Duration::ZERO;
    let (mut still_since, mut last_pos) = (Duration::ZERO, (f64::INFINITY, f64::INFINITY));
    let mut arrived_at: Option<Duration> = None;
    let mut stuck: Vec<usize> = vec![];
    let mut next_battery = Duration::ZERO;
    let mut faults_done = 0usize;
    let mut stopped_at_goal = false;
    let n_robots = robots.len();

    while now < limit {
        // The gateway and the operator (the test gateway of sim-agent's lab tests).
        let cut = current == 1 && enabled_at > Duration::ZERO && {
            let since = now.saturating_sub(enabled_at);
            (Duration::from_millis(1000)..Duration::from_millis(1700)).contains(&since)
                || (Duration::from_millis(2500)..Duration::from_millis(3700)).contains(&since)
        };
        let r = &mut robots[current];
        if !enabled && r.link.session().is_some() && arrived_at.is_none() {
            enabled = r.command(Payload::Enable).is_some();
            if enabled && enabled_at == Duration::ZERO {
                enabled_at = now;
            }
            still_since = now;
        }
        if enabled && !cut && now >= last_goal + GOAL_EVERY {
            if let Some(b) = r.body {
                let bearing = wrap((goal.y - b.y).atan2(goal.x - b.x) - b.heading) as f32;
                r.command(Payload::Goal { bearing });
            }
            last_goal = now;
        }
        if current == 1 && enabled {
            faults_done = inject_faults(&mut robots, now.saturating_sub(enabled_at), faults_done);
            if now >= next_battery {
                // A sinking battery: 4.9 V, then 25 mV less every second.
                let secs = now.saturating_sub(enabled_at).as_secs();
                robots[1].battery(4900u16.saturating_sub(25 * secs as u16));
                next_battery = now + Duration::from_secs(1);
            }
        }
        let r = &mut robots[current];
        if let Some(b) = r.body {
            if arrived_at.is_none() && (b.x - goal.x).hypot(b.y - goal.y) < scenario.goal_radius {
                arrived_at = Some(now);
            }
            if let Some(t) = arrived_at {
                // Stopped 1 s after arriving; the recording ends 1 s later.
                if now >= t + Duration::from_secs(1) && !stopped_at_goal {
                    stopped_at_goal = r.command(Payload::Stop).is_some();
                }
                if now >= t + Duration::from_secs(2) {
                    break;
                }
            } else if arrived_at.is_none() {
                if (b.x - last_pos.0).hypot(b.y - last_pos.1) > 0.005 {
                    last_pos = (b.x, b.y);
                    still_since = now;
                } else if now > still_since + Duration::from_secs(1) && !cut && current + 1 < n_robots {
                    r.command(Payload::Stop);
                    stuck.push(current + 1);
                    current += 1;
                    enabled = false;
                    enabled_at = Duration::ZERO;
                    last_pos = (f64::INFINITY, f64::INFINITY);
                }
            }
        }

        // The lab's step (sim-agent/lab/src/world.rs).
        for (i, r) in robots.iter_mut().enumerate() {
            if r.pump(now) && i == current && arrived_at.is_none() {
                enabled = false; // a new session starts disabled: enable again
            }
            if r.body.is_none() && r.tone().is_some() {
                r.body = Some(Crawler::new(start.x, start.y, start.heading));
            }
        }
        if now >= next_control {
            let speakers: Vec<Speaker> = robots
                .iter()
                .filter_map(|r| {
                    let (b, f) = (r.body?, r.tone()?);
                    Some(Speaker { x: b.x, y: b.y, freq: f, phase: r.phase })
                })
                .collect();
            let t0 = now.saturating_sub(CONTROL_PERIOD).as_secs_f64();
            for (i, r) in robots.iter_mut().enumerate() {
                let Some(b) = r.body else { continue };
                let mics = mic_positions(b.x, b.y, b.heading, 0.1);
                let frames = sample_frames(&scenario.sound, &room, &speakers, &mics, r.motor(), t0, &mut rng);
                if r.control(&to_samples(&frames), now) && i == current && arrived_at.is_none() {
                    enabled = false;
                }
            }
            next_control += CONTROL_PERIOD;
        }
        let centres: Vec<Option<(f64, f64)>> = robots.iter().map(|r| r.body.map(|b| (b.x, b.y))).collect();
        for (i, r) in robots.iter_mut().enumerate() {
            let others: Vec<(f64, f64)> =
                centres.iter().enumerate().filter(|&(j, _)| j != i).filter_map(|(_, c)| *c).collect();
            let m = r.shell.firmware().map(|f| f.motors()).unwrap_or_default();
            if let Some(b) = r.body.as_mut() {
                b.step(&scenario.body, (m.left, m.right), PHYSICS_DT.as_secs_f64(), &obstacles, &others);
            }
        }
        now += PHYSICS_DT;
    }

    let mut input = MAGIC.to_vec();
    let mut live = String::new();
    for r in &robots {
        input.extend_from_slice(&r.records);
        live.push_str(&r.live);
    }
    input.push(tag::END);
    let poses: Vec<String> = robots
        .iter()
        .enumerate()
        .map(|(i, r)| match r.body {
            Some(b) => {
                format!("robot {} at ({:.2}, {:.2}){}", i + 1, b.x, b.y, if b.stuck { " stuck" } else { "" })
            }
            None => format!("robot {} not placed", i + 1),
        })
        .collect();
    let summary = format!(
        "exp-short, {:.1} s of lab time: stuck {:?}, {}; {}",
        now.as_secs_f64(),
        stuck,
        match arrived_at {
            Some(t) => format!("robot 2 arrived at {:.1} s", t.as_secs_f64()),
            None => "no robot arrived".to_owned(),
        },
        poses.join(", ")
    );
    Recording { input, live, summary }
}

/// Robot 2's hostile network, at times since it was first enabled. Returns
/// how many of the faults are done.
fn inject_faults(robots: &mut [Robot], since: Duration, done: usize) -> usize {
    let at = [5000u64, 5100, 5200, 5300, 5400];
    let Some(&due) = at.get(done) else { return done };
    if since < Duration::from_millis(due) {
        return done;
    }
    let (first, second) = robots.split_at_mut(1);
    let (r1, r2) = (&mut first[0], &mut second[0]);
    match done {
        // A sniffer replays robot 2's last command.
        0 => {
            if let Some(old) = r2.last_frame.clone() {
                r2.inbox.push_back(old);
            }
        }
        // A forger without the key: a goal with one bit of its payload flipped.
        1 => {
            let mut out = [0u8; 128];
            if let Ok(f) = r2.link.send(Payload::Goal { bearing: 3.0 }, &mut out) {
                let mut forged = f.to_vec();
                forged[19] ^= 0x40;
                r2.inbox.push_back(forged);
            }
        }
        // Robot 1's gateway's frame, delivered to robot 2.
        2 => {
            let mut out = [0u8; 128];
            if let Ok(f) = r1.link.send(Payload::Enable, &mut out) {
                r2.inbox.push_back(f.to_vec());
            }
        }
        3 => r2.inbox.push_back(b"garbage".to_vec()),
        _ => r2.inbox.push_back(vec![0xA5; 300]),
    }
    done + 1
}
