//! The run's settings: everything an agent needs to run a launch's study,
//! as one value with one fingerprint.
//!
//! Why one value: a remote agent used to be started with the launch's
//! terrain, ε, seed, noise, clock, speed and swarm size repeated on its
//! command line, and a mismatch silently gave another run. Now the launch
//! derives its [`RunSettings`] once from its config, gives them to its
//! spawned agents as flags ([`RunSettings::onto`]), puts their
//! [`fingerprint`](RunSettings::fingerprint) in its setup (the launch core
//! refuses a `Register` whose non-zero `settings` differ) and, over zenoh,
//! serves their [encoding](RunSettings::encode) on
//! `bycoms/<swarm>/settings`. An agent builds its settings back from its
//! flags ([`RunSettings::of`]), or fetches the launch's
//! ([`fetch`]), and registers with their fingerprint: the same study
//! gives the same bytes, hence the same fingerprint, on every host.
//!
//! What is in it: what changes the study an agent runs (terrain text, ε,
//! noise, seed, clock, speed), the swarm size (it sizes the bus) and the
//! heartbeat period the launch expects. Not in it: what is the robot's own
//! (its id, its bus endpoints, its failsafe grace, which `Register` carries
//! apart), and the launch's own limits (time limit, budget), which only the
//! orchestrator enforces.
//!
//! The encoding (PROTOCOL.md, "The run's settings"): one format byte
//! ([`FORMAT`]) then the fields in declaration order in postcard's wire
//! format (varint integers, `f64` as 8 little-endian bytes, a bool as one
//! byte, the clock as its variant index, the terrain as a varint length and
//! UTF-8 bytes). The fingerprint is the first 8 bytes of the SHA-256 of
//! that encoding, read little-endian, with 0 (which means "no settings" on
//! the wire) replaced by 1.

use super::options::{AgentArgs, Clock};
use bycoms_protocol::bus::zenoh::settings::SettingsAnswer;
use bycoms_protocol::bus::zenoh::ZenohBus;
use bycoms_protocol::{RobotId, Swarm};
use bycoms_runtime::seconds::Zero;
use bycoms_sim::sensing::NoiseModel;
use bycoms_sim::RunConfig;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::time::{Duration, Instant};

/// The encoding's format byte (its first byte).
pub const FORMAT: u8 = 2;

/// Everything an agent needs to run the launch's study (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunSettings {
    /// The terrain in the text format, as the launch read it.
    pub terrain: String,
    /// Circumferential radius ε.
    pub eps: f64,
    /// The paper's sensing noise on or off.
    pub noise: bool,
    /// Run seed.
    pub seed: u64,
    /// Clock of the control periods.
    pub clock: Clock,
    /// Real-time speed-up (realtime clock; 1 under lockstep, see [`Self::of`]).
    pub speed: f64,
    /// Robots in the swarm.
    pub swarm_size: u32,
    /// Heartbeat period, milliseconds of wall time.
    pub heartbeat_ms: u64,
    /// The world's units per terrain cell (`--cell-size`; 1 in the paper's
    /// world, a few centimetres in a lab's arena in metres).
    pub cell: f64,
    /// Straight-line speed, units per simulated second (`--robot-speed`;
    /// the paper's 1, a lab's real robots' in a mixed swarm).
    pub robot_speed: f64,
}

/// Why bytes are no settings.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    /// Nothing at all.
    #[error("empty settings")]
    Empty,
    /// Another format (another version of BYCOMS).
    #[error("settings of format {found}, this agent reads format {FORMAT} (another BYCOMS version?)")]
    Format {
        /// The format byte found.
        found: u8,
    },
    /// Not a valid encoding.
    #[error("malformed settings: {0}")]
    Malformed(#[from] postcard::Error),
}

impl RunSettings {
    /// The settings of agent arguments `args` with the terrain's `text`:
    /// the one builder of the launch (its template's flags) and of an agent
    /// started with settings flags. `None` when `args` carry no settings
    /// (no `--eps`: the agent takes the orchestrator's).
    pub fn of(args: &AgentArgs, terrain: String) -> Option<Self> {
        Some(Self {
            terrain,
            eps: args.eps?,
            noise: args.noise,
            seed: args.seed,
            clock: args.clock,
            speed: Self::speed_of(args.clock, args.speed),
            swarm_size: args.swarm_size(),
            heartbeat_ms: args.heartbeat_ms,
            cell: args.cell_size,
            robot_speed: args.robot_speed,
        })
    }

    /// The speed-up the settings hold for `speed` on `clock`: under
    /// lockstep it means nothing (the orchestrator's ticks pace the robot),
    /// so it is 1 there: a launch at `--speed 10` and an agent at its
    /// default 1 run the same study.
    pub fn speed_of(clock: Clock, speed: f64) -> f64 {
        match clock {
            Clock::Lockstep => 1.0,
            Clock::Realtime => speed,
        }
    }

    /// `args` (a robot's own flags: swarm, id, bus, failsafe) running these
    /// settings, the terrain read from stdin (`--terrain -`; the starter
    /// writes [`Self::terrain`] there). With [`AgentArgs::to_flags`] this is
    /// the argv of an agent a launch starts; the agent's parser reads it back
    /// into these settings ([`Self::of`]; tested below).
    pub fn onto(&self, args: AgentArgs) -> AgentArgs {
        AgentArgs {
            terrain: Some("-".into()),
            eps: Some(self.eps),
            noise: self.noise,
            seed: self.seed,
            clock: self.clock,
            speed: self.speed,
            swarm_size: Some(self.swarm_size),
            heartbeat_ms: self.heartbeat_ms,
            cell_size: self.cell,
            robot_speed: self.robot_speed,
            ..args
        }
    }

    /// The run parameters these settings give (the in-process runner's for
    /// the same values).
    pub fn run_config(&self) -> RunConfig {
        let mut cfg = RunConfig::paper(self.eps);
        cfg.noise = self.noise.then(NoiseModel::paper);
        cfg.seed = self.seed;
        cfg.cell = self.cell;
        cfg.kinematics.speed = self.robot_speed;
        cfg
    }

    /// Checks the values as the agent's flags are checked.
    pub fn validate(&self) -> Result<(), String> {
        self.run_config().validate().map_err(|e| format!("bad run parameters: {e}"))?;
        bycoms_runtime::cli::check_speed(self.speed)?;
        bycoms_runtime::seconds::check_millis("the heartbeat period", self.heartbeat_ms, Zero::Refused)?;
        if self.swarm_size == 0 {
            return Err("the swarm size must be at least 1".into());
        }
        Ok(())
    }

    /// The canonical encoding (see the module docs).
    pub fn encode(&self) -> Vec<u8> {
        let mut out = vec![FORMAT];
        // Serialising plain fields into a growing vector cannot fail.
        match postcard::to_extend(self, out) {
            Ok(v) => out = v,
            Err(e) => unreachable!("encoding run settings: {e}"),
        }
        out
    }

    /// The settings `bytes` encode.
    pub fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        match bytes.split_first() {
            None => Err(DecodeError::Empty),
            Some((&FORMAT, rest)) => Ok(postcard::from_bytes(rest)?),
            Some((&found, _)) => Err(DecodeError::Format { found }),
        }
    }

    /// The fingerprint: the first 8 bytes of the SHA-256 of the encoding,
    /// little-endian, never 0 (0 on the wire means "no settings").
    pub fn fingerprint(&self) -> u64 {
        fingerprint_of(&self.encode())
    }

    /// The first setting in which `self` (this agent's) differs from
    /// `launch`'s, named with its flag: e.g. "epsilon (--eps): 0.05 here,
    /// 0.1 in the launch". `None` when they are the same.
    pub fn first_difference(&self, launch: &Self) -> Option<String> {
        fn differ<T: PartialEq + std::fmt::Display>(name: &str, here: T, there: T) -> Option<String> {
            (here != there).then(|| format!("{name}: {here} here, {there} in the launch"))
        }
        let on = |b: bool| if b { "on" } else { "off" };
        terrain_difference(&self.terrain, &launch.terrain)
            .or_else(|| {
                // Bit patterns: -0.0 and 0.0, or two NaNs, are told apart
                // as the fingerprint tells them apart.
                (self.eps.to_bits() != launch.eps.to_bits())
                    .then(|| format!("epsilon (--eps): {} here, {} in the launch", self.eps, launch.eps))
            })
            .or_else(|| differ("noise (--noise)", on(self.noise), on(launch.noise)))
            .or_else(|| differ("seed (--seed)", self.seed, launch.seed))
            .or_else(|| differ("clock (--clock)", self.clock.as_str(), launch.clock.as_str()))
            .or_else(|| {
                (self.speed.to_bits() != launch.speed.to_bits())
                    .then(|| format!("speed (--speed): {} here, {} in the launch", self.speed, launch.speed))
            })
            .or_else(|| differ("swarm size (--swarm-size)", self.swarm_size, launch.swarm_size))
            .or_else(|| differ("heartbeat period (--heartbeat-ms)", self.heartbeat_ms, launch.heartbeat_ms))
            .or_else(|| differ("cell size (--cell-size)", self.cell, launch.cell))
            .or_else(|| differ("robot speed (--robot-speed)", self.robot_speed, launch.robot_speed))
    }
}

/// The fingerprint of an encoding (see [`RunSettings::fingerprint`]).
pub fn fingerprint_of(encoded: &[u8]) -> u64 {
    let digest = Sha256::digest(encoded);
    let mut first = [0u8; 8];
    first.copy_from_slice(&digest[..8]);
    match u64::from_le_bytes(first) {
        0 => 1,
        f => f,
    }
}

/// Where two terrain texts first differ, or `None`.
fn terrain_difference(here: &str, launch: &str) -> Option<String> {
    if here == launch {
        return None;
    }
    let short = |line: Option<&str>| match line {
        None => "no line".to_string(),
        Some(l) if l.chars().count() > 40 => format!("{:?}…", l.chars().take(40).collect::<String>()),
        Some(l) => format!("{l:?}"),
    };
    let (mut a, mut b) = (here.split('\n'), launch.split('\n'));
    let mut n = 1;
    loop {
        match (a.next(), b.next()) {
            (x, y) if x != y => {
                return Some(format!(
                    "terrain (--terrain): line {n} is {} here, {} in the launch",
                    short(x),
                    short(y)
                ))
            }
            (None, None) => return Some("terrain (--terrain): differs".into()),
            _ => n += 1,
        }
    }
}

/// Longest wait for one answer before asking again.
const ASK_EVERY: Duration = Duration::from_secs(1);

/// How often the agent says it is still waiting.
const SAY_EVERY: Duration = Duration::from_secs(5);

/// Why the launch's settings could not be had.
#[derive(Debug, thiserror::Error)]
pub enum FetchError {
    /// Nobody answered within the wait.
    #[error(
        "no orchestrator of swarm {swarm} handed over the run's settings on {key} within {} s \
         (is its launch running, over zenoh, with this swarm name? does its access control let robots \
         query bycoms/*/settings?)",
        waited.as_secs_f64()
    )]
    NoAnswer {
        /// The swarm.
        swarm: String,
        /// The key asked.
        key: String,
        /// How long the agent asked.
        waited: Duration,
    },
    /// The orchestrator refused this agent's robot (not one of the launch's).
    #[error("refused by the orchestrator for robot {robot}: {why}")]
    Refused {
        /// The agent's robot.
        robot: u32,
        /// Why, in the orchestrator's words (or the agent's own check).
        why: String,
    },
    /// The orchestrator's answer is no settings this agent reads.
    #[error("the orchestrator's run settings: {0}")]
    Decode(#[from] DecodeError),
    /// The query failed.
    #[error("asking for the run's settings: {0}")]
    Bus(#[from] bycoms_protocol::bus::BusError),
}

/// Asks the orchestrator of `swarm` for the run's settings on `bus` as the
/// agent of `robot`, again every second until it answers (it may not have
/// declared them yet), for up to `wait`; says every few seconds that it is
/// still waiting. A launch without `robot` refuses it (and so does this
/// agent, should an older orchestrator answer anyway: its swarm is smaller).
pub fn fetch(
    bus: &ZenohBus,
    swarm: &Swarm,
    robot: RobotId,
    wait: Duration,
) -> Result<RunSettings, FetchError> {
    let key = swarm.settings();
    let begun = Instant::now();
    let mut said = begun;
    tracing::info!(key = key.as_str(), "asking the orchestrator for the run's settings");
    loop {
        let left = wait.saturating_sub(begun.elapsed());
        if left.is_zero() {
            return Err(FetchError::NoAnswer {
                swarm: swarm.as_str().into(),
                key: key.as_str().into(),
                waited: wait,
            });
        }
        let asked = Instant::now();
        if let Some(answer) = bus.fetch_settings(swarm, Some(robot), left.min(ASK_EVERY))? {
            let settings = launch_settings(answer, robot)?;
            tracing::info!(
                fingerprint = format_args!("{:016x}", settings.fingerprint()),
                eps = settings.eps,
                seed = settings.seed,
                clock = settings.clock.as_str(),
                swarm_size = settings.swarm_size,
                "got the run's settings from the orchestrator after {:.1} s",
                begun.elapsed().as_secs_f64()
            );
            return Ok(settings);
        }
        if said.elapsed() >= SAY_EVERY {
            said = Instant::now();
            tracing::info!(
                key = key.as_str(),
                "still waiting for the orchestrator's run settings ({:.0} s of {:.0} s)",
                begun.elapsed().as_secs_f64(),
                wait.as_secs_f64()
            );
        }
        // A query that ended at once (no route yet) is not asked again at once.
        std::thread::sleep(ASK_EVERY.saturating_sub(asked.elapsed()).min(Duration::from_millis(100)));
    }
}

/// The settings of the orchestrator's `answer` to the agent of `robot`, or
/// why it may not run them.
fn launch_settings(answer: SettingsAnswer, robot: RobotId) -> Result<RunSettings, FetchError> {
    let refused = |why: String| FetchError::Refused { robot: robot.0, why };
    let settings = match answer {
        SettingsAnswer::Settings(bytes) => RunSettings::decode(&bytes)?,
        SettingsAnswer::Refused(why) => return Err(refused(why)),
    };
    if !(1..=settings.swarm_size).contains(&robot.0) {
        let n = settings.swarm_size;
        return Err(refused(format!(
            "robot {} is not one of the launch's robots (it has robots 1 to {n})",
            robot.0
        )));
    }
    Ok(settings)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paper() -> RunSettings {
        RunSettings {
            terrain: "..G\n.#.\nS..\n".into(),
            eps: 3.0,
            noise: false,
            seed: 0,
            clock: Clock::Lockstep,
            speed: 1.0,
            swarm_size: 3,
            heartbeat_ms: 100,
            cell: 1.0,
            robot_speed: 1.0,
        }
    }

    #[test]
    fn an_agent_outside_the_launch_does_not_run_its_settings() {
        let served = || SettingsAnswer::Settings(paper().encode());
        assert_eq!(launch_settings(served(), RobotId(3)).expect("robot 3 of 3").swarm_size, 3);
        // An orchestrator that answers anyone (an older one): the agent's own check.
        let own = launch_settings(served(), RobotId(9)).expect_err("robot 9 of 3");
        let text = "refused by the orchestrator for robot 9: robot 9 is not one of the launch's robots (it has robots 1 to 3)";
        assert_eq!(own.to_string(), text);
        let why = "robot 9 is not one of the launch's robots (it has robots 1 to 3)";
        let refused = launch_settings(SettingsAnswer::Refused(why.into()), RobotId(9)).expect_err("refused");
        assert_eq!(refused.to_string(), text);
    }

    #[test]
    fn the_fingerprint_is_pinned() {
        // The wire's value: an agent of another build must compute the same.
        let s = paper();
        // Golden bytes (PROTOCOL.md): format 2, the terrain's length and
        // text, ε = 3.0 (LE f64), noise off, seed 0, lockstep, speed 1.0,
        // 3 robots, 100 ms heartbeats, cell 1.0, robot speed 1.0.
        // Recomputed apart with Python's hashlib: sha256(bytes)[:8] read
        // little-endian.
        let hex: String = s.encode().iter().map(|b| format!("{b:02x}")).collect();
        let want = "020c2e2e470a2e232e0a532e2e0a0000000000000840000000000000000000f03f0364\
                    000000000000f03f000000000000f03f";
        assert_eq!(hex, want);
        assert_eq!(format!("{:016x}", s.fingerprint()), "f30c0f6d8f04586c");
        assert_eq!(s.fingerprint(), paper().fingerprint(), "deterministic");
        assert_ne!(s.fingerprint(), 0);
    }

    #[test]
    fn every_field_changes_the_fingerprint() {
        let base = paper().fingerprint();
        let changed = [
            RunSettings { terrain: "..G\n...\nS..\n".into(), ..paper() },
            RunSettings { eps: 0.1 + 0.2, ..paper() },
            RunSettings { noise: true, ..paper() },
            RunSettings { seed: 1, ..paper() },
            RunSettings { clock: Clock::Realtime, ..paper() },
            RunSettings { speed: 2.0, ..paper() },
            RunSettings { swarm_size: 4, ..paper() },
            RunSettings { heartbeat_ms: 50, ..paper() },
            RunSettings { cell: 0.02, ..paper() },
            RunSettings { robot_speed: 0.22, ..paper() },
        ];
        for s in changed {
            assert_ne!(s.fingerprint(), base, "{s:?}");
            assert!(s.first_difference(&paper()).is_some(), "{s:?}");
        }
        assert_eq!(fingerprint_of(&[]), fingerprint_of(&[]));
    }

    #[test]
    fn the_speed_counts_under_the_realtime_clock_only() {
        use bycoms_runtime::BusArgs;
        let args = |clock, speed| AgentArgs {
            swarm: "s".into(),
            robot: 2,
            terrain: Some("-".into()),
            eps: Some(3.0),
            noise: false,
            seed: 0,
            clock,
            speed,
            cell_size: 1.0,
            robot_speed: 1.0,
            swarm_size: Some(3),
            parent_pid: None,
            heartbeat_ms: 100,
            parked_heartbeat_ms: None,
            settings_timeout: 1.0,
            bus: BusArgs::default(),
            failsafe: Default::default(),
        };
        let of = |clock, speed| RunSettings::of(&args(clock, speed), paper().terrain).expect("settings");
        assert_eq!(of(Clock::Lockstep, 10.0), paper());
        assert_eq!(of(Clock::Lockstep, 1.0).fingerprint(), of(Clock::Lockstep, 10.0).fingerprint());
        assert_ne!(of(Clock::Realtime, 1.0).fingerprint(), of(Clock::Realtime, 10.0).fingerprint());
        let no_eps = AgentArgs { eps: None, ..args(Clock::Lockstep, 1.0) };
        assert_eq!(RunSettings::of(&no_eps, String::new()), None);
    }

    /// The argv a launch gives its agents ([`RunSettings::onto`] +
    /// [`AgentArgs::to_flags`]) is read back by the agent's parser into the
    /// very settings, bit for bit, on both clocks.
    #[test]
    fn settings_given_as_flags_are_read_back_exactly() {
        use super::super::options::{parse_from, SimAgentRun};
        let realtime = RunSettings {
            eps: 0.1 + 0.2,
            seed: u64::MAX,
            speed: 2.5,
            noise: true,
            clock: Clock::Realtime,
            swarm_size: 9,
            heartbeat_ms: 37,
            cell: 0.02,
            robot_speed: 0.1 + 0.12,
            ..paper()
        };
        for s in [paper(), realtime] {
            let args = s.onto(AgentArgs::new("s", 2));
            let argv = std::iter::once("sim-agent".to_string()).chain(args.to_flags());
            let SimAgentRun::Robot(parsed) = parse_from(argv).expect("the flags parse").1 else {
                panic!("not a robot")
            };
            assert_eq!(parsed, args);
            let back = RunSettings::of(&parsed, s.terrain.clone()).expect("settings");
            assert_eq!((back.eps.to_bits(), back.fingerprint()), (s.eps.to_bits(), s.fingerprint()));
            assert_eq!(back, s);
        }
    }

    #[test]
    fn the_encoding_round_trips_exactly() {
        let s = RunSettings { eps: 0.1 + 0.2, seed: u64::MAX, speed: 2.5, noise: true, ..paper() };
        let bytes = s.encode();
        let back = RunSettings::decode(&bytes).expect("decodes");
        assert_eq!(back, s);
        assert_eq!(back.eps.to_bits(), s.eps.to_bits());
        assert_eq!(back.encode(), bytes, "canonical: the same bytes again");
        assert!(matches!(RunSettings::decode(&[]), Err(DecodeError::Empty)));
        let mut other = bytes.clone();
        other[0] = FORMAT + 1;
        assert!(
            matches!(RunSettings::decode(&other), Err(DecodeError::Format { found }) if found == FORMAT + 1)
        );
        assert!(matches!(RunSettings::decode(&bytes[..bytes.len() - 1]), Err(DecodeError::Malformed(_))));
    }

    #[test]
    fn the_first_difference_is_named() {
        let launch = RunSettings { eps: 0.1, ..paper() };
        assert_eq!(launch.first_difference(&launch), None);
        let here = RunSettings { eps: 0.05, seed: 9, ..paper() };
        assert_eq!(
            here.first_difference(&launch).as_deref(),
            Some("epsilon (--eps): 0.05 here, 0.1 in the launch")
        );
        let here = RunSettings { seed: 9, ..launch.clone() };
        assert_eq!(here.first_difference(&launch).as_deref(), Some("seed (--seed): 9 here, 0 in the launch"));
        let here = RunSettings { noise: true, ..launch.clone() };
        assert_eq!(
            here.first_difference(&launch).as_deref(),
            Some("noise (--noise): on here, off in the launch")
        );
        let here = RunSettings { swarm_size: 5, ..launch.clone() };
        assert_eq!(
            here.first_difference(&launch).as_deref(),
            Some("swarm size (--swarm-size): 5 here, 3 in the launch")
        );
        let here = RunSettings { terrain: "..G\n.#.\nS.#\n".into(), ..launch.clone() };
        assert_eq!(
            here.first_difference(&launch).as_deref(),
            Some(r#"terrain (--terrain): line 3 is "S.#" here, "S.." in the launch"#)
        );
        let here = RunSettings { terrain: "..G\n.#.\n".into(), ..launch.clone() };
        assert_eq!(
            here.first_difference(&launch).as_deref(),
            Some(r#"terrain (--terrain): line 3 is "" here, "S.." in the launch"#)
        );
        let here = RunSettings { terrain: "..G\n.#.\nS..".into(), ..launch.clone() };
        assert_eq!(
            here.first_difference(&launch).as_deref(),
            Some(r#"terrain (--terrain): line 4 is no line here, "" in the launch"#)
        );
    }
}
