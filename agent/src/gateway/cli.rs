//! The `gateway` command line and `main`.
//!
//! Exit codes: 0 after `Shutdown` or the parent's death; 130 after Ctrl-C
//! (SIGINT, or SIGTERM / SIGHUP / SIGQUIT: one handler), as the
//! orchestrator and `sim-agent` (one mapping, `ExitCause::exit_code`); 3 when
//! another gateway holds the robot; 4 over zenoh when the orchestrator was
//! gone past `--orchestrator-grace` (the robot was stopped first; with
//! `--on-orchestrator-lost wait` the gateway stays instead); 2 for a usage
//! error (bad flags, values, key file, swarm name); 1 for any other error
//! (socket, bus), printed first.
//!
//! The bus flags are the runtime's (`BusArgs`, as `sim-agent`'s): `--transport ipc` on the
//! orchestrator's host (the default), or `--transport zenoh --connect
//! quic/ORCHESTRATOR:7447 --zenoh-config robot-K.json5` from a bridge host
//! next to the robots' access point.
//!
//! One typed builder: whoever starts a gateway (the orchestrator's
//! `orchestrator/launch/src/agents/gateways.rs`) fills a [`GatewayArgs`] and passes its
//! [`GatewayArgs::to_flags`]; the binary parses them with [`command`] (via
//! [`parse_from`]), and the round-trip tests below hold the two together.

use super::bench::BenchArgs;
use super::core::{GatewayCore, Timers};
use super::run::{Gateway, GatewayPorts, RunError};
use bycoms_protocol::bus::zenoh::clock::ClockProbe;
use bycoms_protocol::bus::zenoh::AliveWatch;
use bycoms_protocol::bus::{Bus, BusError};
use bycoms_protocol::link::{KeyFileError, LinkKey};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{NameError, RobotId, Swarm};
use bycoms_runtime::cli::{command_with_subcommands, parse_with_subcommands};
use bycoms_runtime::doctor::{HostArgs, HostNeeds};
use bycoms_runtime::failsafe::{Failsafe, FailsafeArgs};
use bycoms_runtime::lifeline::LifelineError;
use bycoms_runtime::logging::LogArgs;
use bycoms_runtime::stats::quantile;
use bycoms_runtime::{check_speed, BusArgs, BusOpenError, Epoch, ExitCause, Lifeline, OnBus};
use clap::Command;
use std::net::{SocketAddr, UdpSocket};
use std::path::PathBuf;
use std::time::Duration;

/// Longest link timeout: the gateway must report a lost link within 500 ms.
pub const MAX_LINK_TIMEOUT_MS: u64 = 500;

/// The link timeout a gateway runs with unless told otherwise, ms of robot
/// time: the one number the launch's gateways are started with and its
/// core's link grace is reckoned from (`launch::agents::gateways`).
pub const LINK_TIMEOUT_MS: u64 = 300;

/// The gateway of one real robot: owns the robot's UDP link and appears on
/// the bus as an agent of kind `Real`.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct GatewayArgs {
    /// Swarm name: the namespace of the run's topics.
    #[arg(long)]
    pub swarm: String,
    /// The robot's id (1-based deployment order).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub robot: u32,
    /// The UDP address to listen on: where the robot sends (its flashed
    /// gateway address).
    #[arg(long, value_name = "ADDR", value_parser = bycoms_runtime::cli::fixed_port)]
    pub bind: SocketAddr,
    /// The robot's key file: 64 hexadecimal digits.
    #[arg(long, value_name = "FILE")]
    pub key_file: PathBuf,
    /// Robots in the swarm: sizes the shared-memory services, the same for
    /// every process of the swarm (default: this robot's id).
    #[arg(long)]
    pub swarm_size: Option<u32>,
    /// Speed-up of the robot's clock (an emulated lab running faster than
    /// real time): every link timer is divided by it.
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Report the link lost after this long without an authentic robot
    /// frame, ms at speed 1 (at most 500).
    #[arg(long, default_value_t = LINK_TIMEOUT_MS)]
    pub link_timeout_ms: u64,
    /// Bus heartbeat period, ms of wall time.
    #[arg(long, default_value_t = bycoms_protocol::msg::HEARTBEAT_MS, value_parser = bycoms_runtime::seconds::millis)]
    pub heartbeat_ms: u64,
    /// The orchestrator's pid; the gateway exits when its parent is no
    /// longer this process (default: its parent at start).
    #[arg(long, value_parser = bycoms_runtime::lifeline::parent_pid)]
    pub parent_pid: Option<i32>,
    /// The bus: iceoryx2 on the orchestrator's host, or zenoh to the
    /// orchestrator from a bridge host (with the robot's certificate in
    /// `--zenoh-config`).
    #[command(flatten)]
    pub bus: BusArgs,
    /// zenoh: the failsafe when the orchestrator is lost.
    #[command(flatten)]
    pub failsafe: FailsafeArgs,
}

impl GatewayArgs {
    /// The gateway of robot `robot` of `swarm`, listening on `bind` with
    /// the key in `key_file`, every other flag at its default (what `agent
    /// --swarm S --robot K --bind ADDR --key-file FILE` parses into).
    pub fn new(swarm: impl Into<String>, robot: u32, bind: SocketAddr, key_file: impl Into<PathBuf>) -> Self {
        Self {
            swarm: swarm.into(),
            robot,
            bind,
            key_file: key_file.into(),
            swarm_size: None,
            speed: 1.0,
            link_timeout_ms: LINK_TIMEOUT_MS,
            heartbeat_ms: bycoms_protocol::msg::HEARTBEAT_MS,
            parent_pid: None,
            bus: BusArgs::default(),
            failsafe: FailsafeArgs::default(),
        }
    }

    /// Checks what clap cannot.
    pub fn validate(&self) -> Result<(), String> {
        check_speed(self.speed)?;
        if !(1..=MAX_LINK_TIMEOUT_MS).contains(&self.link_timeout_ms) {
            return Err(format!(
                "--link-timeout-ms must be in 1..={MAX_LINK_TIMEOUT_MS}, got {}",
                self.link_timeout_ms
            ));
        }
        bycoms_runtime::cli::check_swarm_size(self.robot, self.swarm_size)?;
        self.failsafe.grace()?;
        self.bus.validate()
    }

    /// The link timers for these flags.
    pub fn timers(&self) -> Timers {
        let link_timeout = Duration::from_secs_f64(self.link_timeout_ms as f64 / 1000.0 / self.speed);
        Timers { link_timeout, ..Timers::paper(self.speed) }
    }

    /// The flags that reproduce these arguments (what a launcher passes).
    pub fn to_flags(&self) -> Vec<String> {
        let mut v = vec![
            "--swarm".into(),
            self.swarm.clone(),
            "--robot".into(),
            self.robot.to_string(),
            "--bind".into(),
            self.bind.to_string(),
            "--key-file".into(),
            self.key_file.display().to_string(),
            "--speed".into(),
            format!("{:?}", self.speed),
            "--link-timeout-ms".into(),
            self.link_timeout_ms.to_string(),
            "--heartbeat-ms".into(),
            self.heartbeat_ms.to_string(),
        ];
        for (flag, value) in [
            ("--swarm-size", self.swarm_size.map(i64::from)),
            ("--parent-pid", self.parent_pid.map(i64::from)),
        ] {
            if let Some(n) = value {
                v.push(flag.into());
                v.push(n.to_string());
            }
        }
        v.extend(self.bus.to_flags());
        v.extend(self.failsafe.to_flags());
        v
    }
}

/// Check this robot's gateway host before a lab day, as its gateway will
/// run: the open-files limit, the robot link's UDP port free (--bind), this
/// robot's certificate in its zenoh config, the orchestrator's endpoint
/// reached, its liveliness seen and this host's clock offset to it.
///
/// Each finding names its cause and its fix; exit 0 without an error, 1
/// with one, 2 for a usage error. `orchestrator doctor --connect` runs the
/// same zenoh checks where the orchestrator binary is installed.
#[derive(Clone, Debug, PartialEq, Eq, clap::Args)]
pub struct DoctorArgs {
    /// The UDP address the gateway will listen on (its robot's flashed
    /// gateway address, the robots file's `gateway`): checked bindable.
    #[arg(long, value_name = "ADDR", value_parser = bycoms_runtime::cli::fixed_port)]
    pub bind: Option<SocketAddr>,
    #[command(flatten)]
    pub host: HostArgs,
}

impl DoctorArgs {
    /// Runs the doctor; returns the exit code (see [`DoctorArgs`]).
    pub fn main(&self) -> i32 {
        let needs = HostNeeds { files: bycoms_runtime::doctor::host::AGENT_FILES, bind: self.bind };
        bycoms_runtime::doctor::main_with(&self.host, needs)
    }
}

/// `gateway`'s subcommands (their help is their flags' doc comment).
#[derive(Clone, Debug, PartialEq, clap::Subcommand)]
pub enum AgentCommand {
    Bench(BenchArgs),
    Doctor(DoctorArgs),
}

/// The whole `gateway` command line: the gateway's flags ([`GatewayArgs`])
/// and the logging flags at the top level, the added-latency bench and
/// the host's doctor as the `bench` and `doctor` subcommands
/// ([`AgentCommand`]).
///
/// As `sim-agent` and its `lab`: the gateway's flags stay at the top level
/// (launchers start `gateway --swarm … --robot …`), a subcommand lifts their
/// requirement and the two exclude each other, so `gateway --help` lists
/// `bench` and `doctor`, and `gateway bench --help` has the bench's own usage
/// line; the logging flags go before or after the subcommand
/// ([`command_with_subcommands`] says how and why).
pub fn command() -> Command {
    command_with_subcommands::<GatewayArgs, AgentCommand>(
        "gateway",
        env!("CARGO_PKG_VERSION"),
        "One real robot's gateway between its authenticated UDP link and the BYCOMS bus; `bench` its added latency, `doctor` this host's checks",
    )
}

/// What a `gateway` command line asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum AgentRun {
    /// One robot's gateway (no subcommand).
    Gateway(GatewayArgs),
    /// `gateway bench`: the gateway's added latency.
    Bench(BenchArgs),
    /// `gateway doctor`: this host's checks.
    Doctor(DoctorArgs),
}

/// Parses a `gateway` command line (`argv[0]` first) with [`command`]: the
/// logging flags and what to run. Errors carry the usage line of the
/// command they are about (the bench's for `bench`).
pub fn parse_from<I, T>(argv: I) -> Result<(LogArgs, AgentRun), clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let (log, chosen) = parse_with_subcommands(command, argv)?;
    let run = match chosen {
        Err(gateway) => AgentRun::Gateway(gateway),
        Ok(AgentCommand::Bench(bench)) => AgentRun::Bench(bench),
        Ok(AgentCommand::Doctor(doctor)) => AgentRun::Doctor(doctor),
    };
    Ok((log, run))
}

/// Why a gateway could not run.
#[derive(Debug, thiserror::Error)]
pub enum GatewayError {
    /// A flag has an unusable value.
    #[error("{0}")]
    Args(String),
    /// The key file is unreadable or malformed.
    #[error(transparent)]
    Key(#[from] KeyFileError),
    /// The swarm name is not a valid topic chunk.
    #[error("bad swarm name: {0}")]
    Swarm(#[from] NameError),
    /// The robot's socket could not be bound.
    #[error("cannot listen for robot {robot} on {addr}: {source}")]
    Bind {
        /// The robot.
        robot: u32,
        /// The address.
        addr: SocketAddr,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The OS random source failed.
    #[error("no randomness for session ids: {0}")]
    Random(getrandom::Error),
    /// The bus failed.
    #[error("bus: {0}")]
    Bus(#[from] BusError),
    /// The loop failed.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The parent-death link could not be set up.
    #[error(transparent)]
    Lifeline(#[from] LifelineError),
}

/// Runs one gateway; returns the process exit code.
pub fn main_with(args: &GatewayArgs) -> i32 {
    let _span = tracing::info_span!("gateway", robot = args.robot).entered();
    bycoms_runtime::cli::agent_main(
        || run(args),
        |e| match e {
            GatewayError::Args(_) | GatewayError::Key(_) | GatewayError::Swarm(_) => 2,
            _ => 1,
        },
    )
}

/// The exit code of a gateway that ended for `cause` (see the module doc;
/// the runtime's one mapping, shared with `sim-agent`).
pub fn exit_code(cause: ExitCause) -> i32 {
    cause.exit_code()
}

fn run(args: &GatewayArgs) -> Result<ExitCause, GatewayError> {
    let mut lifeline = Lifeline::install(args.parent_pid)?;
    args.validate().map_err(GatewayError::Args)?;
    let swarm = Swarm::new(&args.swarm)?;
    let key = LinkKey::read_file(&args.key_file)?;
    let id = RobotId(args.robot);
    let socket = UdpSocket::bind(args.bind).map_err(|source| GatewayError::Bind {
        robot: id.0,
        addr: args.bind,
        source,
    })?;
    let mut seed = [0u8; 8];
    getrandom::fill(&mut seed).map_err(GatewayError::Random)?;
    let size = args.swarm_size.unwrap_or(args.robot).max(args.robot);
    let node = format!("bycoms-{}-gateway-{}", swarm.as_str(), id.0);
    // The session's time: µs since the gateway started.
    let epoch = Epoch::now();
    let core = GatewayCore::new(id, key, args.timers(), u64::from_le_bytes(seed), epoch.elapsed());
    let then = RunGateway { args, swarm: &swarm, core, epoch, socket, lifeline: &mut lifeline, clock: None };
    args.bus.open(&swarm, Some(Member::Agent(id)), Some(&args.failsafe), size, node, then).map_err(|e| {
        match e {
            BusOpenError::Args(a) => GatewayError::Args(a),
            BusOpenError::Bus(b) => GatewayError::Bus(b),
        }
    })?
}

/// The gateway's loop once the bus is open.
struct RunGateway<'a> {
    args: &'a GatewayArgs,
    swarm: &'a Swarm,
    core: GatewayCore,
    /// What the core's time counts from.
    epoch: Epoch,
    socket: UdpSocket,
    lifeline: &'a mut Lifeline,
    /// zenoh: this host's clock offset to the orchestrator's, measured.
    clock: Option<ClockProbe>,
}

impl OnBus for RunGateway<'_> {
    type Output = Result<ExitCause, GatewayError>;
    fn clock(&mut self, probe: ClockProbe) {
        self.clock = Some(probe);
    }
    fn run<B: Bus>(self, bus: &B, failsafe: Option<(Failsafe, AliveWatch)>) -> Self::Output {
        let args = self.args;
        let ports = GatewayPorts::open(bus, self.swarm, self.core.robot())?;
        let heartbeat = Duration::from_millis(args.heartbeat_ms);
        let mut gateway = Gateway::new(self.core, ports, self.socket, heartbeat, failsafe, self.epoch)
            .map_err(RunError::from)?;
        if let Some(probe) = self.clock {
            gateway.report_clock(probe);
        }
        tracing::info!(bind = %args.bind, speed = args.speed, transport = args.bus.transport.as_str(), "gateway listening for its robot");
        let cause = gateway.run(self.lifeline)?;
        let drops: Vec<String> =
            gateway.core().drops().nonzero().map(|(why, n)| format!("{}={n}", why.name())).collect();
        let s = gateway.stats();
        tracing::info!(
            ?cause,
            relayed = s.relayed,
            relay_p50_us = quantile(&s.relay_ns, 0.5).map(|n| n / 1000),
            relay_p99_us = quantile(&s.relay_ns, 0.99).map(|n| n / 1000),
            bad_messages = gateway.traffic().total(),
            refused_frames = %drops.join(" "),
            "gateway exits"
        );
        Ok(cause)
    }
}

#[cfg(test)]
mod exit_code_tests {
    use super::*;

    #[test]
    fn a_signal_is_an_interruption_and_the_rest_as_sim_agent() {
        assert_eq!(exit_code(ExitCause::Signal), 130);
        assert_eq!(exit_code(ExitCause::Refused), 3);
        assert_eq!(exit_code(ExitCause::OrchestratorLost), 4);
        assert_eq!(exit_code(ExitCause::Shutdown), 0);
        assert_eq!(exit_code(ExitCause::ParentGone), 0);
    }
}

#[cfg(test)]
mod command_tests {
    use super::*;
    use bycoms_runtime::failsafe::OnOrchestratorLost;
    use bycoms_runtime::Transport;

    fn run_of<S: AsRef<str>>(args: &[S]) -> Result<AgentRun, clap::Error> {
        let argv = std::iter::once("gateway").chain(args.iter().map(|a| a.as_ref()));
        parse_from(argv).map(|(_, run)| run)
    }

    fn gateway_of(flags: &[String]) -> GatewayArgs {
        match run_of(flags).expect("the flags parse") {
            AgentRun::Gateway(g) => g,
            other => panic!("not a gateway: {other:?}"),
        }
    }

    #[test]
    fn the_command_is_consistent() {
        command().debug_assert();
    }

    #[test]
    fn a_swarm_the_robot_is_not_in_is_refused() {
        let flags = |size: &str, robot: &str| {
            [
                "--swarm",
                "lab",
                "--robot",
                robot,
                "--bind",
                "127.0.0.1:47001",
                "--key-file",
                "k",
                "--swarm-size",
                size,
            ]
            .map(String::from)
        };
        for (size, robot) in [("0", "1"), ("2", "5")] {
            let e = gateway_of(&flags(size, robot)).validate().expect_err("refused");
            assert!(e.starts_with(&format!("--swarm-size {size}: robot {robot} is not one of")), "{e}");
        }
        assert!(gateway_of(&flags("5", "5")).validate().is_ok());
    }

    #[test]
    fn the_flags_round_trip_exactly() {
        let args = GatewayArgs {
            swarm: "lab".into(),
            robot: 3,
            bind: "10.0.0.7:9000".parse().unwrap(),
            key_file: "keys/robot-3.key".into(),
            swarm_size: Some(5),
            speed: 0.1 + 0.2,
            link_timeout_ms: 250,
            heartbeat_ms: 40,
            parent_pid: Some(77),
            bus: BusArgs {
                transport: Transport::Zenoh,
                connect: vec!["quic/orchestrator:7447".into(), "tcp/10.0.0.1:7447".into()],
                zenoh_config: Some("robot-3.json5".into()),
            },
            failsafe: FailsafeArgs { grace_s: 0.1 + 0.4, on_lost: OnOrchestratorLost::Wait },
        };
        let parsed = gateway_of(&args.to_flags());
        assert_eq!(parsed, args, "{:?}", args.to_flags());
        assert_eq!(parsed.speed.to_bits(), (0.1f64 + 0.2).to_bits());
        assert!(parsed.validate().is_ok());
    }

    #[test]
    fn the_defaults_round_trip() {
        let least = ["--swarm", "s", "--robot", "1", "--bind", "127.0.0.1:47001", "--key-file", "k"];
        let args = gateway_of(&least.map(String::from));
        assert_eq!(args, GatewayArgs::new("s", 1, "127.0.0.1:47001".parse().unwrap(), "k"));
        assert_eq!((args.speed, args.link_timeout_ms, args.heartbeat_ms), (1.0, 300, 100));
        assert_eq!((args.swarm_size, args.parent_pid), (None, None));
        assert_eq!((&args.bus, args.failsafe), (&BusArgs::default(), FailsafeArgs::default()));
        assert_eq!(gateway_of(&args.to_flags()), args, "{:?}", args.to_flags());
    }

    #[test]
    fn bench_is_a_subcommand_beside_the_gateway_s_flags() {
        let bench = run_of(&["bench", "--frames", "5", "--interval-ms", "1"]).expect("parses");
        assert_eq!(bench, AgentRun::Bench(BenchArgs { frames: 5, interval_ms: 1 }));
        // The logging flags in any position (README, "Logs and shell completions").
        for argv in
            [["gateway", "bench", "--log-format", "json"], ["gateway", "--log-format", "json", "bench"]]
        {
            let (log, run) = parse_from(argv).expect("the logging flags");
            assert_eq!(log.log_format, bycoms_runtime::logging::LogFormat::Json, "{argv:?}");
            assert_eq!(run, AgentRun::Bench(BenchArgs { frames: 2000, interval_ms: 2 }));
        }
        // The bench needs none of the gateway's flags and takes none.
        let err = run_of(&["--swarm", "s", "bench"]).unwrap_err();
        assert_eq!(err.kind(), clap::error::ErrorKind::ArgumentConflict, "{err}");
        let err = run_of(&["bench", "--robot", "1"]).unwrap_err().to_string();
        assert!(err.contains("Usage: gateway bench"), "{err}");
        // Without it, the gateway's flags are required as before.
        let err = run_of(&["--swarm", "s"]).unwrap_err().to_string();
        assert!(err.contains("--robot"), "{err}");
        let help = command().render_help().to_string();
        assert!(help.lines().any(|l| l.trim_start().starts_with("bench ")), "{help}");
        assert!(help.lines().any(|l| l.trim_start().starts_with("doctor ")), "{help}");
    }

    #[test]
    fn doctor_is_a_subcommand_with_the_host_s_flags_and_the_gateway_s_port() {
        let args = [
            "doctor",
            "--connect",
            "quic/o:7447",
            "--swarm",
            "lab",
            "--robot",
            "3",
            "--bind",
            "10.0.0.2:9000",
        ];
        let AgentRun::Doctor(d) = run_of(&args).expect("parses") else { panic!("not the doctor") };
        assert_eq!(d.bind, Some("10.0.0.2:9000".parse().unwrap()));
        assert_eq!((d.host.connect.as_str(), d.host.swarm.as_str(), d.host.robot), ("quic/o:7447", "lab", 3));
        assert_eq!((d.host.timeout_ms, d.host.json, &d.host.zenoh_config), (500, false, &None));
        let err = run_of(&["doctor", "--swarm", "lab", "--robot", "3"]).unwrap_err().to_string();
        assert!(err.contains("--connect") && err.contains("Usage: gateway doctor"), "{err}");
        let help = command().find_subcommand_mut("doctor").expect("doctor").render_help().to_string();
        assert!(help.starts_with("Check this robot's gateway host"), "{help}");
    }
}
