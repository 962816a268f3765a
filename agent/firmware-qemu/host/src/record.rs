//! The recorder: the emulated lab's `exp-short` with the firmware cores in
//! this process, each robot's every firmware call written to the input file.
//!
//! Why not `bycoms_lab::Lab` itself: its emulated ESP32s talk UDP and
//! keep their firmware calls to themselves. This loop is the same lab —
//! its scenario, its sound (`sample_frames`: 1/d, propagation delay, wall
//! echoes, motor vibration, ADC noise), its crawler bodies, its 5 ms
//! physics step and 125 ms control period, the shell calls of its
//! `EmulatedEsp32` (datagrams, then `advance`, then transmit, every
//! step; microphones, then transmit, every period; its clock as the
//! firmware's by the lab's `esp32::micros`) — with the link
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
use bycoms_lab::esp32::micros;
use bycoms_lab::scenario::{Point, Scenario};
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
        self.records.extend_from_slice(&micros(now).to_le_bytes());
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
            self.shell.datagram(&d, micros(now), &mut NoMeter, &mut self.live).expect("live datagram");
        }
        self.record(tag::TIMEOUT, now);
        self.shell.timeout(micros(now), &mut NoMeter, &mut self.live).expect("live timeout");
        self.transmit(now)
    }

    fn transmit(&mut self, now: Duration) -> bool {
        self.record(tag::TRANSMIT, now);
        let mut sent = vec![];
        self.shell
            .transmit(micros(now), &mut NoMeter, &mut self.live, |f| sent.push(f.to_vec()))
            .expect("live tx");
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
        self.shell.mics(samples, micros(now), &mut NoMeter, &mut self.live).expect("live mics");
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
    let mut robots = boot_robots(&scenario, &mut rng);
    let arena = Arena::of(&scenario);
    let mut operator = Operator::new();
    let mut now = Duration::ZERO;
    let mut next_control = CONTROL_PERIOD;
    while now < limit {
        if operator.step(&mut robots, now, &scenario) {
            break;
        }
        let restarted = arena.step(&mut robots, now, &mut next_control, operator.current, &mut rng);
        if restarted && operator.arrived_at.is_none() {
            operator.enabled = false; // a new session starts disabled: enable again
        }
        now += PHYSICS_DT;
    }
    finish(&robots, now, &operator)
}

/// Boots one robot per tone of `scenario`, each listening as the lab's do:
/// the other robots' tones, then unused paper tones.
fn boot_robots(scenario: &Scenario, rng: &mut Xoshiro256PlusPlus) -> Vec<Robot> {
    let mut robots: Vec<Robot> = Vec::new();
    for (i, &own) in scenario.tones.iter().enumerate() {
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
    robots
}

/// The gateway and the operator of the run (the test gateway of
/// sim-agent's lab tests): which robot goes, its enabling and goal
/// bearings, robot 2's hostile network, and who is stuck or arrived.
struct Operator {
    current: usize,
    enabled: bool,
    enabled_at: Duration,
    last_goal: Duration,
    still_since: Duration,
    last_pos: (f64, f64),
    arrived_at: Option<Duration>,
    stuck: Vec<usize>,
    next_battery: Duration,
    faults_done: usize,
    stopped_at_goal: bool,
}

impl Operator {
    fn new() -> Self {
        Self {
            current: 0,
            enabled: false,
            enabled_at: Duration::ZERO,
            last_goal: Duration::ZERO,
            still_since: Duration::ZERO,
            last_pos: (f64::INFINITY, f64::INFINITY),
            arrived_at: None,
            stuck: Vec::new(),
            next_battery: Duration::ZERO,
            faults_done: 0,
            stopped_at_goal: false,
        }
    }

    /// One physics step's decisions; whether the recording ends.
    fn step(&mut self, robots: &mut [Robot], now: Duration, scenario: &Scenario) -> bool {
        // Robot 2's link is cut twice, 1.0–1.7 s and 2.5–3.7 s after it was enabled.
        let cut = self.current == 1 && self.enabled_at > Duration::ZERO && {
            let since = now.saturating_sub(self.enabled_at);
            (Duration::from_millis(1000)..Duration::from_millis(1700)).contains(&since)
                || (Duration::from_millis(2500)..Duration::from_millis(3700)).contains(&since)
        };
        self.command(&mut robots[self.current], now, cut, scenario.goal);
        if self.current == 1 && self.enabled {
            self.faults_done = inject_faults(robots, now.saturating_sub(self.enabled_at), self.faults_done);
            if now >= self.next_battery {
                // A sinking battery: 4.9 V, then 25 mV less every second.
                let secs = now.saturating_sub(self.enabled_at).as_secs();
                robots[1].battery(4900u16.saturating_sub(25 * secs as u16));
                self.next_battery = now + Duration::from_secs(1);
            }
        }
        let last = self.current + 1 == robots.len();
        self.judge(&mut robots[self.current], now, cut, last, scenario)
    }

    /// Enables the current robot once its session is up, and gives it a
    /// goal bearing from its true pose every [`GOAL_EVERY`] while its link
    /// is not cut.
    fn command(&mut self, r: &mut Robot, now: Duration, cut: bool, goal: Point) {
        if !self.enabled && r.link.session().is_some() && self.arrived_at.is_none() {
            self.enabled = r.command(Payload::Enable).is_some();
            if self.enabled && self.enabled_at == Duration::ZERO {
                self.enabled_at = now;
            }
            self.still_since = now;
        }
        if self.enabled && !cut && now >= self.last_goal + GOAL_EVERY {
            if let Some(b) = r.body {
                let bearing = wrap((goal.y - b.y).atan2(goal.x - b.x) - b.heading) as f32;
                r.command(Payload::Goal { bearing });
            }
            self.last_goal = now;
        }
    }

    /// The gate on the current robot `r`: arrived (stopped 1 s later, the
    /// recording ending 1 s after that: `true`), or still for 1 s with its
    /// link up and a robot after it (stopped, a beacon; the next one goes).
    fn judge(&mut self, r: &mut Robot, now: Duration, cut: bool, last: bool, scenario: &Scenario) -> bool {
        let Some(b) = r.body else { return false };
        let goal = scenario.goal;
        if self.arrived_at.is_none() && (b.x - goal.x).hypot(b.y - goal.y) < scenario.goal_radius {
            self.arrived_at = Some(now);
        }
        if let Some(t) = self.arrived_at {
            if now >= t + Duration::from_secs(1) && !self.stopped_at_goal {
                self.stopped_at_goal = r.command(Payload::Stop).is_some();
            }
            return now >= t + Duration::from_secs(2);
        }
        if (b.x - self.last_pos.0).hypot(b.y - self.last_pos.1) > 0.005 {
            self.last_pos = (b.x, b.y);
            self.still_since = now;
        } else if now > self.still_since + Duration::from_secs(1) && !cut && !last {
            r.command(Payload::Stop);
            self.stuck.push(self.current + 1);
            self.current += 1;
            self.enabled = false;
            self.enabled_at = Duration::ZERO;
            self.last_pos = (f64::INFINITY, f64::INFINITY);
        }
        false
    }
}

/// The lab around the robots (`sim-agent/lab/src/world.rs`): the room's
/// sound, the walls and obstacles, the crawler bodies.
struct Arena<'a> {
    scenario: &'a Scenario,
    room: Room,
    obstacles: Vec<Obstacle>,
}

impl<'a> Arena<'a> {
    fn of(scenario: &'a Scenario) -> Self {
        let mut obstacles: Vec<Obstacle> = scenario.obstacles.clone();
        obstacles.extend(arena_walls(scenario.width, scenario.height));
        Self { scenario, room: Room { width: scenario.width, height: scenario.height }, obstacles }
    }

    /// The lab's step at `now`: links pumped, bodies placed, the control
    /// period's microphones when due, the bodies moved. Whether robot
    /// `current` started a new session (it is then disabled).
    fn step(
        &self,
        robots: &mut [Robot],
        now: Duration,
        next_control: &mut Duration,
        current: usize,
        rng: &mut Xoshiro256PlusPlus,
    ) -> bool {
        let start = self.scenario.start;
        let mut restarted = false;
        for (i, r) in robots.iter_mut().enumerate() {
            restarted |= r.pump(now) && i == current;
            if r.body.is_none() && r.tone().is_some() {
                r.body = Some(Crawler::new(start.x, start.y, start.heading));
            }
        }
        if now >= *next_control {
            restarted |= self.listen(robots, now, current, rng);
            *next_control += CONTROL_PERIOD;
        }
        let centres: Vec<Option<(f64, f64)>> = robots.iter().map(|r| r.body.map(|b| (b.x, b.y))).collect();
        for (i, r) in robots.iter_mut().enumerate() {
            let others: Vec<(f64, f64)> =
                centres.iter().enumerate().filter(|&(j, _)| j != i).filter_map(|(_, c)| *c).collect();
            let m = r.shell.firmware().map(|f| f.motors()).unwrap_or_default();
            if let Some(b) = r.body.as_mut() {
                b.step(
                    &self.scenario.body,
                    (m.left, m.right),
                    PHYSICS_DT.as_secs_f64(),
                    &self.obstacles,
                    &others,
                );
            }
        }
        restarted
    }

    /// One control period: every placed robot's microphones hear the
    /// speakers of the last period. Whether robot `current` started a new
    /// session.
    fn listen(
        &self,
        robots: &mut [Robot],
        now: Duration,
        current: usize,
        rng: &mut Xoshiro256PlusPlus,
    ) -> bool {
        let speakers: Vec<Speaker> = robots
            .iter()
            .filter_map(|r| {
                let (b, f) = (r.body?, r.tone()?);
                Some(Speaker { x: b.x, y: b.y, freq: f, phase: r.phase })
            })
            .collect();
        let t0 = now.saturating_sub(CONTROL_PERIOD).as_secs_f64();
        let mut restarted = false;
        for (i, r) in robots.iter_mut().enumerate() {
            let Some(b) = r.body else { continue };
            let mics = mic_positions(b.x, b.y, b.heading, 0.1);
            let sound = &self.scenario.sound;
            let frames = sample_frames(sound, &self.room, &speakers, &mics, r.motor(), t0, rng);
            restarted |= r.control(&to_samples(&frames), now) && i == current;
        }
        restarted
    }
}

/// The recording of the run that ended at `now`.
fn finish(robots: &[Robot], now: Duration, operator: &Operator) -> Recording {
    let mut input = MAGIC.to_vec();
    let mut live = String::new();
    for r in robots {
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
        operator.stuck,
        match operator.arrived_at {
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
