//! The `sim-agent` command line.
//!
//! Why in the library: the orchestrator spawns agents with exactly these
//! flags, and falls back to running the same code as its hidden
//! `orchestrator sim-agent` subcommand when no `sim-agent` binary sits next
//! to it (e.g. after `cargo run --bin orchestrator`, which builds only the
//! orchestrator). One definition keeps the two spellings identical.
//!
//! One typed builder per binary: whoever starts a `sim-agent` fills an
//! [`AgentArgs`] (or a [`LabArgs`] for `sim-agent lab`) and passes its
//! `to_flags`; nobody writes the flags by hand. The parser the binary runs
//! is [`command`] (with [`parse_from`]), so the round-trip tests below read
//! the flags with exactly what the binary reads them with.

use bycoms_lab::process::LabArgs;
use bycoms_runtime::cli::{check_speed, command_with_subcommands, parse_with_subcommands};
use bycoms_runtime::doctor::{HostArgs, HostNeeds};
use bycoms_runtime::failsafe::FailsafeArgs;
use bycoms_runtime::logging::LogArgs;
use bycoms_runtime::seconds::{check_seconds, Zero};
use bycoms_runtime::{BusArgs, Transport};
use bycoms_sim::sensing::NoiseModel;
use bycoms_sim::RunConfig;
use clap::Command;
use std::path::PathBuf;

/// How long an agent without settings flags asks the orchestrator for the
/// run's settings by default, seconds (`--settings-timeout`).
pub const DEFAULT_SETTINGS_TIMEOUT_S: f64 = 60.0;

/// How simulated time advances: the one clock setting of a launch, shared
/// by the orchestrator (`launch --clock`, `clock = ...` in its config) and
/// every agent (`sim-agent --clock`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Clock {
    /// The orchestrator ticks every live agent and waits for all answers:
    /// as fast as the agents answer, and bit-identical to `simulate`. An
    /// agent steps only on `Tick` and answers each with `TickDone`.
    Lockstep,
    /// Every agent steps on its own wall clock at 10 Hz × `speed`.
    Realtime,
}

impl Clock {
    /// The clock's name as on the command line and in summaries.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Lockstep => "lockstep",
            Self::Realtime => "realtime",
        }
    }
}

/// One simulated BYCOMS robot as its own process, the agent a launch
/// starts for each robot (or that runs on another host): on iceoryx2 (this
/// host) or zenoh (any host). `sim-agent lab` is the emulated lab instead.
///
/// Over zenoh it needs only where to connect, its swarm and its robot id:
/// it asks the orchestrator for the run's settings (terrain, ε, noise,
/// seed, clock, speed, swarm size). Started with settings flags it checks
/// them against the launch's and exits naming the first difference. A
/// launch without its robot refuses it (status 3). It registers, waits for its deployment, then senses the field of the
/// beacons the orchestrator sends it (each earlier robot's last pose,
/// summed in robot-id order), runs the BYCOMS
/// controller on its goal bearing, moves its simulated body and publishes its
/// pose as simulated motion capture. It freezes where it enters an
/// impassable cell. It exits on `Shutdown`, on SIGTERM/SIGINT, and within
/// 2 s of its parent (the orchestrator) dying. Over zenoh (an orchestrator
/// on another host) it watches the orchestrator's liveliness: gone for
/// longer than `--orchestrator-grace`, the robot stops, then the agent
/// exits (status 4) or waits, by `--on-orchestrator-lost`.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct AgentArgs {
    /// Swarm name: the namespace of the run's topics.
    #[arg(long)]
    pub swarm: String,
    /// This agent's robot id (1-based deployment order).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub robot: u32,
    /// Terrain file in the text format; `-` reads it from stdin. With it
    /// (and `--eps`) the agent runs these settings and registers with their
    /// fingerprint: a launch with other settings refuses it, naming the
    /// first difference. Without any settings flag (over zenoh only) the
    /// agent takes the run's settings from the orchestrator.
    #[arg(
        long,
        value_name = "FILE",
        requires = "eps",
        help_heading = "Run settings (default: the orchestrator's)"
    )]
    pub terrain: Option<PathBuf>,
    /// Circumferential radius ε (threshold g_th = 1/ε²).
    #[arg(long, requires = "terrain", help_heading = "Run settings (default: the orchestrator's)")]
    pub eps: Option<f64>,
    /// Add the paper's sensing noise.
    #[arg(long, requires = "terrain", help_heading = "Run settings (default: the orchestrator's)")]
    pub noise: bool,
    /// Run seed; this robot's noise stream is `robot_seed(seed, robot)`.
    #[arg(
        long,
        default_value_t = 0,
        requires = "terrain",
        help_heading = "Run settings (default: the orchestrator's)"
    )]
    pub seed: u64,
    /// Clock of the control periods.
    #[arg(
        long,
        value_enum,
        default_value_t = Clock::Lockstep,
        requires = "terrain",
        help_heading = "Run settings (default: the orchestrator's)"
    )]
    pub clock: Clock,
    /// Real-time speed-up: periods of 0.1 s / speed (realtime clock only).
    #[arg(
        long,
        default_value_t = 1.0,
        requires = "terrain",
        help_heading = "Run settings (default: the orchestrator's)"
    )]
    pub speed: f64,
    /// The world's units per terrain cell: 1 in the paper's world; a lab's
    /// arena in metres is a terrain of small cells (its frames blocked),
    /// and then poses, beacons, speeds and ε are in metres.
    #[arg(
        long,
        default_value_t = 1.0,
        requires = "terrain",
        help_heading = "Run settings (default: the orchestrator's)"
    )]
    pub cell_size: f64,
    /// Straight-line speed, units per simulated second (the paper's 1; a
    /// simulated member of a lab's swarm drives as fast as its real ones).
    #[arg(
        long,
        default_value_t = 1.0,
        requires = "terrain",
        help_heading = "Run settings (default: the orchestrator's)"
    )]
    pub robot_speed: f64,
    /// Robots in the swarm: sizes the shared-memory services, and must be the
    /// same for every process of the swarm (default: this robot's id).
    #[arg(long, requires = "terrain", help_heading = "Run settings (default: the orchestrator's)")]
    pub swarm_size: Option<u32>,
    /// The orchestrator's pid; the agent exits when its parent is no longer
    /// this process (default: its parent at start).
    #[arg(long, value_parser = bycoms_runtime::lifeline::parent_pid)]
    pub parent_pid: Option<i32>,
    /// Heartbeat period, milliseconds of wall time.
    #[arg(
        long,
        default_value_t = bycoms_protocol::msg::HEARTBEAT_MS,
        value_parser = bycoms_runtime::seconds::millis,
        requires = "terrain",
        help_heading = "Run settings (default: the orchestrator's)"
    )]
    pub heartbeat_ms: u64,
    /// Heartbeat period once the robot is parked (frozen or stopped: it
    /// gets no more ticks), milliseconds of wall time [default: the
    /// heartbeat period]. A launch gives its agents a quarter of its
    /// heartbeat timeout, at most 1 s: a thousand parked agents beating
    /// ten times a second took a quarter of a two-core machine.
    #[arg(
        long,
        value_parser = bycoms_runtime::seconds::millis,
        requires = "terrain",
        help_heading = "Run settings (default: the orchestrator's)"
    )]
    pub parked_heartbeat_ms: Option<u64>,
    /// zenoh, without settings flags: how long to wait for the orchestrator,
    /// seconds: to be reachable (it may start after the agent), then to
    /// hand over the run's settings; the agent says while it waits.
    #[arg(long, value_name = "SECONDS", default_value_t = DEFAULT_SETTINGS_TIMEOUT_S)]
    pub settings_timeout: f64,
    /// The bus.
    #[command(flatten)]
    pub bus: BusArgs,
    /// zenoh: the failsafe when the orchestrator is lost.
    #[command(flatten)]
    pub failsafe: FailsafeArgs,
}

impl AgentArgs {
    /// Robot `robot` of `swarm` with every other flag at its default (what
    /// `sim-agent --swarm SWARM --robot ROBOT` parses into): a starting
    /// point for a starter's struct update.
    pub fn new(swarm: impl Into<String>, robot: u32) -> Self {
        Self {
            swarm: swarm.into(),
            robot,
            terrain: None,
            eps: None,
            noise: false,
            seed: 0,
            clock: Clock::Lockstep,
            speed: 1.0,
            cell_size: 1.0,
            robot_speed: 1.0,
            swarm_size: None,
            parent_pid: None,
            heartbeat_ms: bycoms_protocol::msg::HEARTBEAT_MS,
            parked_heartbeat_ms: None,
            settings_timeout: DEFAULT_SETTINGS_TIMEOUT_S,
            bus: BusArgs::default(),
            failsafe: FailsafeArgs::default(),
        }
    }

    /// The run parameters the in-process runner would use for the same
    /// flags (ε is NaN without `--eps`: the settings are then the
    /// orchestrator's, see [`RunSettings::run_config`]).
    ///
    /// [`RunSettings::run_config`]: super::settings::RunSettings::run_config
    pub fn run_config(&self) -> RunConfig {
        let mut cfg = RunConfig::paper(self.eps.unwrap_or(f64::NAN));
        cfg.noise = self.noise.then(NoiseModel::paper);
        cfg.seed = self.seed;
        cfg.cell = self.cell_size;
        cfg.kinematics.speed = self.robot_speed;
        cfg
    }

    /// Robots in the swarm as the bus is sized for (a `--swarm-size` that
    /// does not hold the robot is refused by [`AgentArgs::validate`]).
    pub fn swarm_size(&self) -> u32 {
        self.swarm_size.unwrap_or(self.robot).max(self.robot)
    }

    /// Checks the values clap cannot: the run parameters with the one check
    /// every command makes ([`RunConfig::validate`]), the speed with
    /// [`check_speed`].
    /// Without settings flags the settings come from the orchestrator, over
    /// zenoh only.
    pub fn validate(&self) -> Result<(), String> {
        if self.has_settings() {
            self.run_config().validate().map_err(|e| format!("bad run parameters: {e}"))?;
            check_speed(self.speed)?;
        } else if self.bus.transport != Transport::Zenoh {
            return Err("the run's settings come from the orchestrator over zenoh only: \
                        give --transport zenoh --connect ENDPOINT, or the settings \
                        (--terrain FILE --eps E ...)"
                .into());
        }
        check_seconds("--settings-timeout", self.settings_timeout, Zero::Refused)?;
        bycoms_runtime::cli::check_swarm_size(self.robot, self.swarm_size)?;
        self.failsafe.grace()?;
        self.bus.validate()
    }

    /// Whether the agent was started with the run's settings (`--terrain`
    /// and `--eps`; clap makes every other settings flag need them).
    pub fn has_settings(&self) -> bool {
        self.terrain.is_some() && self.eps.is_some()
    }

    /// The command-line flags that reproduce these arguments (what the
    /// orchestrator passes when it spawns an agent).
    pub fn to_flags(&self) -> Vec<String> {
        let mut v = vec!["--swarm".into(), self.swarm.clone(), "--robot".into(), self.robot.to_string()];
        if let (Some(terrain), Some(eps)) = (&self.terrain, self.eps) {
            v.extend([
                "--terrain".into(),
                terrain.display().to_string(),
                "--eps".into(),
                format!("{eps:?}"),
                "--seed".into(),
                self.seed.to_string(),
                "--clock".into(),
                self.clock.as_str().into(),
                "--speed".into(),
                format!("{:?}", self.speed),
                "--heartbeat-ms".into(),
                self.heartbeat_ms.to_string(),
            ]);
            if self.cell_size != 1.0 || self.robot_speed != 1.0 {
                v.extend(["--cell-size".into(), format!("{:?}", self.cell_size)]);
                v.extend(["--robot-speed".into(), format!("{:?}", self.robot_speed)]);
            }
            if self.noise {
                v.push("--noise".into());
            }
            if let Some(n) = self.swarm_size {
                v.push("--swarm-size".into());
                v.push(n.to_string());
            }
            if let Some(ms) = self.parked_heartbeat_ms {
                v.push("--parked-heartbeat-ms".into());
                v.push(ms.to_string());
            }
        }
        if self.settings_timeout != DEFAULT_SETTINGS_TIMEOUT_S {
            v.push("--settings-timeout".into());
            v.push(format!("{:?}", self.settings_timeout));
        }
        if let Some(p) = self.parent_pid {
            v.push("--parent-pid".into());
            v.push(p.to_string());
        }
        v.extend(self.bus.to_flags());
        v.extend(self.failsafe.to_flags());
        v
    }
}

/// Check this robot's host before a lab day, as its `sim-agent` will run
/// over zenoh: the open-files limit, this robot's certificate in its zenoh
/// config, the orchestrator's endpoint reached, its liveliness seen and this
/// host's clock offset to it.
///
/// Each finding names its cause and its fix; exit 0 without an error, 1
/// with one, 2 for a usage error. `orchestrator doctor --connect` runs the
/// same zenoh checks where the orchestrator binary is installed.
#[derive(Clone, Debug, PartialEq, Eq, clap::Args)]
pub struct DoctorArgs {
    #[command(flatten)]
    pub host: HostArgs,
}

impl DoctorArgs {
    /// Runs the doctor; returns the exit code (see [`DoctorArgs`]).
    pub fn main(&self) -> i32 {
        let needs = HostNeeds { files: bycoms_runtime::doctor::host::AGENT_FILES, bind: None };
        bycoms_runtime::doctor::main_with(&self.host, needs)
    }
}

/// `sim-agent`'s subcommands (their help is their flags' doc comment).
#[derive(Clone, Debug, PartialEq, clap::Subcommand)]
pub enum SimAgentCommand {
    // Boxed: the lab's flags are most of the enum's size.
    Lab(Box<LabArgs>),
    Doctor(DoctorArgs),
}

/// The whole `sim-agent` command line: the robot's flags ([`AgentArgs`])
/// and the logging flags at the top level, the emulated lab and the host's
/// doctor as the `lab` and `doctor` subcommands ([`SimAgentCommand`]).
///
/// Assembled by [`command_with_subcommands`] (the runtime's, shared with
/// `gateway` and its `bench` and `doctor`), which says how and why.
pub fn command() -> Command {
    command_with_subcommands::<AgentArgs, SimAgentCommand>(
        "sim-agent",
        env!("CARGO_PKG_VERSION"),
        "One simulated robot as its own process on the bus (what `launch` starts); `lab` the emulated lab, `doctor` this host's checks",
    )
}

/// What a `sim-agent` command line asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum SimAgentRun {
    /// One simulated robot (no subcommand).
    Robot(AgentArgs),
    /// `sim-agent lab`: the emulated lab.
    Lab(LabArgs),
    /// `sim-agent doctor`: this host's checks.
    Doctor(DoctorArgs),
}

/// Parses a `sim-agent` command line (`argv[0]` first) with [`command`]:
/// the logging flags and what to run. Errors carry the usage line of the
/// command they are about (the lab's for `lab`).
pub fn parse_from<I, T>(argv: I) -> Result<(LogArgs, SimAgentRun), clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let (log, chosen) = parse_with_subcommands(command, argv)?;
    let run = match chosen {
        Err(robot) => SimAgentRun::Robot(robot),
        Ok(SimAgentCommand::Lab(lab)) => SimAgentRun::Lab(*lab),
        Ok(SimAgentCommand::Doctor(doctor)) => SimAgentRun::Doctor(doctor),
    };
    Ok((log, run))
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_runtime::failsafe::OnOrchestratorLost;

    /// `sim-agent` + `args` as the binary parses them.
    fn run_of(args: Vec<String>) -> SimAgentRun {
        parse_from(std::iter::once("sim-agent".to_string()).chain(args)).expect("the flags parse").1
    }

    /// A robot's flags as the binary parses them.
    fn robot_of(flags: Vec<String>) -> AgentArgs {
        match run_of(flags) {
            SimAgentRun::Robot(a) => a,
            other => panic!("not a robot: {other:?}"),
        }
    }

    #[test]
    fn the_command_is_consistent() {
        command().debug_assert();
    }

    #[test]
    fn flags_round_trip_exactly() {
        let eps = 0.1 + 0.2; // not a short decimal: must survive the round trip
        let args = AgentArgs {
            swarm: "s".into(),
            robot: 4,
            terrain: Some("-".into()),
            eps: Some(eps),
            noise: true,
            seed: u64::MAX,
            clock: Clock::Realtime,
            speed: 2.5,
            cell_size: 0.02,
            robot_speed: 0.1 + 0.12,
            swarm_size: Some(9),
            parent_pid: Some(77),
            heartbeat_ms: 50,
            parked_heartbeat_ms: Some(450),
            settings_timeout: 2.5,
            bus: BusArgs {
                transport: Transport::Zenoh,
                connect: vec!["tcp/127.0.0.1:7447".into(), "tls/lab:7448".into()],
                zenoh_config: None,
            },
            failsafe: FailsafeArgs { grace_s: 0.1 + 0.4, on_lost: OnOrchestratorLost::Wait },
        };
        let parsed = robot_of(args.to_flags());
        assert_eq!(parsed, args, "{:?}", args.to_flags());
        assert_eq!(parsed.eps.map(f64::to_bits), Some(eps.to_bits()));
        assert_eq!(parsed.swarm_size(), 9);
        assert!(parsed.validate().is_ok());
        assert_eq!(parsed.bus, args.bus);
        // The bus flags' own checks are bus_args.rs's; the agent makes them.
        let ipc_with_endpoint =
            AgentArgs { bus: BusArgs { transport: Transport::Ipc, ..args.bus.clone() }, ..parsed.clone() };
        assert!(ipc_with_endpoint.validate().unwrap_err().contains("--transport zenoh"));
        assert_eq!(parsed.failsafe, args.failsafe);
        let bad_grace =
            AgentArgs { failsafe: FailsafeArgs { grace_s: -1.0, ..args.failsafe }, ..parsed.clone() };
        assert!(bad_grace.validate().unwrap_err().contains("--orchestrator-grace"));
        let bad = AgentArgs { eps: Some(f64::NAN), ..parsed };
        assert!(bad.validate().is_err());
    }

    /// A swarm that does not hold the robot is a usage error, as `gateway`'s
    /// (it was quietly raised to the robot's id).
    #[test]
    fn a_swarm_size_below_the_robot_is_refused() {
        for (size, robot) in [(0, 1), (2, 5)] {
            let flags = format!("--swarm s --robot {robot} --swarm-size {size} --terrain - --eps 0.1");
            let e = parse(&flags).expect("parses").validate().expect_err("refused");
            assert!(e.starts_with(&format!("--swarm-size {size}: robot {robot} is not one of")), "{e}");
        }
        let fits = parse("--swarm s --robot 5 --swarm-size 5 --terrain - --eps 0.1").expect("parses");
        assert_eq!((fits.validate(), fits.swarm_size()), (Ok(()), 5));
    }

    fn parse(flags: &str) -> Result<AgentArgs, clap::Error> {
        match parse_from(std::iter::once("sim-agent").chain(flags.split_whitespace()))?.1 {
            SimAgentRun::Robot(a) => Ok(a),
            other => panic!("not a robot: {other:?}"),
        }
    }

    #[test]
    fn the_defaults_round_trip() {
        // The least a robot's command line can say: the rest at clap's defaults.
        let least = parse("--swarm s --robot 1").unwrap();
        assert_eq!(least, AgentArgs::new("s", 1));
        assert_eq!(robot_of(least.to_flags()), least);
        assert!(
            !least.to_flags().iter().any(|f| f == "--eps" || f == "--transport"),
            "{:?}",
            least.to_flags()
        );
        assert_eq!((least.bus, least.failsafe), (BusArgs::default(), FailsafeArgs::default()));
        // With the settings at their defaults.
        let settings = parse("--swarm s --robot 1 --terrain t.txt --eps 3").unwrap();
        assert_eq!(robot_of(settings.to_flags()), settings);
    }

    fn lab_of(args: Vec<String>) -> LabArgs {
        match run_of(args) {
            SimAgentRun::Lab(a) => a,
            other => panic!("not the lab: {other:?}"),
        }
    }

    #[test]
    fn doctor_is_a_subcommand_with_the_host_s_flags() {
        let args = "doctor --connect tcp/10.0.0.5:7447 --swarm lab --robot 2 --json --timeout-ms 900";
        let SimAgentRun::Doctor(d) = run_of(args.split(' ').map(String::from).collect()) else {
            panic!("not the doctor")
        };
        assert_eq!(
            (d.host.connect.as_str(), d.host.swarm.as_str(), d.host.robot),
            ("tcp/10.0.0.5:7447", "lab", 2)
        );
        assert_eq!((d.host.timeout_ms, d.host.json), (900, true));
        let e = parse_from([
            "sim-agent",
            "doctor",
            "--connect",
            "tcp/h:1",
            "--swarm",
            "s",
            "--robot",
            "1",
            "--bind",
            "x",
        ]);
        assert!(e.is_err(), "--bind is the gateway's");
        let help = command().find_subcommand_mut("doctor").expect("doctor").render_help().to_string();
        assert!(help.starts_with("Check this robot's host"), "{help}");
        let top = command().render_help().to_string();
        assert!(top.lines().any(|l| l.trim_start().starts_with("doctor ")), "{top}");
    }

    #[test]
    fn the_lab_s_flags_round_trip_exactly() {
        let least = lab_of(
            ["lab", "--scenario", "exp-short", "--robots", "r.toml", "--swarm", "j"].map(String::from).into(),
        );
        assert_eq!(least, LabArgs::new("exp-short", "r.toml", "j"));
        assert_eq!(lab_of(least.to_args()), least, "{:?}", least.to_args());
        assert_eq!((least.speed, least.seed, least.mocap_ms, least.natnet), (1.0, 0, 50, None));
        let lab = LabArgs {
            scenario: "deploy/lab/exp-long.toml".into(),
            robots: "deploy/lab/robots.toml".into(),
            swarm: "lab".into(),
            speed: 0.1 + 0.2,
            seed: u64::MAX,
            duration: Some(30.5),
            mocap_ms: 20,
            parent_pid: Some(77),
            natnet: Some("127.0.0.1:1510".parse().unwrap()),
            natnet_rate: 240.0,
            natnet_faults: Some("faults.toml".into()),
            ros2_router: Some("tcp/127.0.0.1:7447".into()),
            ros2_domain_id: 42,
            ros2_namespace: "/lab".into(),
            bus: BusArgs {
                transport: Transport::Zenoh,
                connect: vec!["quic/lab-host:7447".into()],
                zenoh_config: Some("lab.json5".into()),
            },
        };
        let parsed = lab_of(lab.to_args());
        assert_eq!(parsed, lab, "{:?}", lab.to_args());
        assert_eq!(parsed.speed.to_bits(), (0.1f64 + 0.2).to_bits());
        // The lab's flags are the lab's: after `lab` only.
        assert!(parse_from(std::iter::once("sim-agent".to_string()).chain(lab.to_flags())).is_err());
    }

    #[test]
    fn without_settings_flags_the_settings_are_the_orchestrator_s() {
        let bare = parse("--transport zenoh --connect tcp/10.0.0.5:7447 --swarm lab --robot 2").unwrap();
        assert!(!bare.has_settings());
        assert!(bare.validate().is_ok());
        // What the orchestrator would spawn from it: no settings flags.
        assert!(!bare.to_flags().iter().any(|f| f == "--seed" || f == "--eps"), "{:?}", bare.to_flags());
        assert_eq!(parse(&bare.to_flags().join(" ")).unwrap().to_flags(), bare.to_flags());
        // Over iceoryx2 nobody hands them over.
        let ipc = parse("--swarm lab --robot 2").unwrap();
        assert!(ipc.validate().unwrap_err().contains("over zenoh only"));
        // A settings flag alone would be ignored: refused instead.
        for partial in
            ["--seed 3", "--noise", "--eps 3", "--terrain t.txt", "--clock realtime", "--swarm-size 4"]
        {
            let flags =
                format!("--transport zenoh --connect tcp/10.0.0.5:7447 --swarm lab --robot 2 {partial}");
            assert!(parse(&flags).is_err(), "{partial}");
        }
        let full = parse("--swarm lab --robot 2 --terrain t.txt --eps 3 --seed 3").unwrap();
        assert!(full.has_settings() && full.validate().is_ok());
        for wait in [0.0, 1e300, 1e20, f64::NAN, -1.0] {
            let bad_wait = AgentArgs { settings_timeout: wait, ..bare.clone() };
            let e = bad_wait.validate().unwrap_err();
            assert!(e.starts_with("--settings-timeout must be a number of seconds in (0, "), "{e}");
        }
    }
}
