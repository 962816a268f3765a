//! `sim-agent lab`: the emulated lab as a process — the physical room that a
//! real `gateway` talks to over UDP, with simulated motion capture on
//! the bus.
//!
//! Why a process: the gateway and the orchestrator must not be able to tell
//! the emulator from hardware, so the emulated ESP32s sit behind their own
//! UDP sockets (addresses from the robots file, `deploy/lab/robots.toml`),
//! and the lab's only other output is what a motion-capture system would
//! give: each placed body's true pose on `robot/<id>/pose`. That is the one
//! seam a real mocap source replaces ([`MocapOut`]); with `--natnet ADDR`
//! the bodies are served by NatNet instead (`super::natnet_out`) and nothing
//! is published on the bus.
//!
//! With a robots file of ROS 2 robots (`kind = "ros2"`) the room holds
//! their bodies instead (`super::ros2_body`, no ESP32, no sound), driven by
//! their `cmd_vel` topics on the lab's zenoh router (`--ros2-router`,
//! `super::cmd_vel`); their poses go out as the crawlers' do.
//!
//! The emulated operator ([`Operator`]) reads the orchestrator's placement
//! requests (`bycoms/<swarm>/operator`, the prompt a person reads on the
//! terminal) and puts the robot on the start mark; a robot enabled without
//! a request is placed when enabled (a launch without the prompt).
//!
//! The lab runs on its own clock ([`Lab::step`], 5 ms of lab time) paced at
//! `--speed` × real time; if the machine cannot keep up it runs late rather
//! than skipping physics (the summary says how late). At exit it prints a
//! JSON summary on stdout: final bodies, firmware states and drop counts,
//! and the control-period jitter (wall time between the firmware's control
//! periods against the nominal 125 ms / speed).

use super::cmd_vel::{CmdVelIn, Ros2Link};
use super::natnet_out::NatNetOut;
use super::robots::{Kind, RobotsError, RobotsFile, Ros2Entry};
use super::ros2_body::DiffDriveConfig;
use super::scenario::{Scenario, ScenarioError};
use super::world::{Lab, Wiring, CONTROL_PERIOD, PHYSICS_DT};
use bycoms_natnet_server::Faults;
use bycoms_protocol::bus::zenoh::AliveWatch;
use bycoms_protocol::bus::{Bus, BusError, BusExt, TypedPublisher, TypedSubscriber};
use bycoms_protocol::link::RobotState;
use bycoms_protocol::msg::{Deploy, Pose};
use bycoms_protocol::{NameError, RobotId, Swarm};
use bycoms_runtime::cli::quiet_iceoryx2;
use bycoms_runtime::failsafe::Failsafe;
use bycoms_runtime::seconds::{check_seconds, Zero};
use bycoms_runtime::{check_speed, BusArgs, BusOpenError, ExitCause, Lifeline, OnBus};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The emulated lab: one emulated ESP32 per robot behind its own UDP socket,
/// crawler bodies, sound, and simulated motion capture on the bus (ROS 2
/// robots: bodies driven by their cmd_vel).
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct LabArgs {
    /// Scenario: a built-in name (`exp-short`, `exp-long`) or a scenario file.
    #[arg(long)]
    pub scenario: String,
    /// The robots file: each robot's UDP address, its gateway's, its key file.
    #[arg(long, value_name = "FILE")]
    pub robots: PathBuf,
    /// Swarm name: the namespace of the run's topics (poses go there).
    #[arg(long)]
    pub swarm: String,
    /// Lab time per wall time (2 = twice as fast as real time).
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Seed of the lab's noise and of the robots' boot entropy.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Stop after this much lab time, seconds (default: run until signalled).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Motion capture period, lab milliseconds.
    #[arg(long, default_value_t = 50, value_parser = bycoms_runtime::seconds::millis)]
    pub mocap_ms: u64,
    /// Exit when this process is no longer the parent (default: the parent
    /// at start).
    #[arg(long, value_parser = bycoms_runtime::lifeline::parent_pid)]
    pub parent_pid: Option<i32>,
    /// Serve the bodies by NatNet (OptiTrack) with the command channel on
    /// this address (Motive's port is 1510) instead of publishing true
    /// poses on the bus: robot k is rigid body `robot<k>`, Y up.
    #[arg(long, value_name = "ADDR")]
    pub natnet: Option<std::net::SocketAddr>,
    /// NatNet frames per second of lab time (with --natnet).
    #[arg(long, default_value_t = 120.0, value_name = "HZ")]
    pub natnet_rate: f64,
    /// With --natnet: the cameras' faults, a TOML file of the NatNet
    /// server's `[faults]` keys (`seed`, `frame_loss`, `marker_noise_m`,
    /// `[[occlusions]]`, `[[swaps]]`; times in seconds of lab time, body ids
    /// are robot ids; see deploy/natnet-serve.toml).
    #[arg(long, value_name = "FILE", requires = "natnet")]
    pub natnet_faults: Option<PathBuf>,
    /// With a robots file of ROS 2 robots (`kind = "ros2"`): the lab's
    /// zenoh router (rmw_zenohd, e.g. tcp/127.0.0.1:7447), joined as a
    /// client to read each robot's `cmd_vel` as its driver would.
    #[arg(long, value_name = "ENDPOINT")]
    pub ros2_router: Option<String>,
    /// With --ros2-router: `ROS_DOMAIN_ID` of the robots' topics (0 to 232).
    #[arg(long, default_value_t = 0, value_name = "ID", requires = "ros2_router",
          value_parser = clap::value_parser!(u32).range(0..=232))]
    pub ros2_domain_id: u32,
    /// With --ros2-router: the namespace of the default topics
    /// `<namespace>/robot_<id>/cmd_vel`.
    #[arg(long, default_value = "/", value_name = "NAMESPACE", requires = "ros2_router")]
    pub ros2_namespace: String,
    /// The bus of the operator's requests and the bus mocap: iceoryx2 on
    /// the orchestrator's host, or zenoh to the orchestrator (a lab on
    /// another host, as the gateways on a bridge host).
    #[command(flatten)]
    pub bus: BusArgs,
}

impl LabArgs {
    /// The subcommand of `sim-agent` that runs the lab.
    pub const SUBCOMMAND: &'static str = "lab";

    /// Checks what clap cannot: the speed-up, `--duration` (the one check
    /// of seconds, `bycoms_runtime::seconds`), the NatNet rate (the mocap
    /// period is clap's, through the same check in milliseconds).
    pub fn validate(&self) -> Result<(), LabError> {
        check_speed(self.speed).map_err(LabError::Args)?;
        if let Some(d) = self.duration {
            check_seconds("--duration", d, Zero::Allowed).map_err(LabError::Args)?;
        }
        // At least one frame a second: a frame period is a span of seconds
        // too (`--natnet-rate 1e-300` made one of 1e300 s).
        if !bycoms_ros2::rmw_zenoh::is_fully_qualified(&self.ros2_namespace, true) {
            return Err(LabError::Args(format!(
                "--ros2-namespace {:?} is not a ROS 2 namespace (`/`, or `/a/b`: letters, digits, `_`)",
                self.ros2_namespace
            )));
        }
        let rates = bycoms_natnet_server::config::RATE_HZ;
        if !rates.contains(&self.natnet_rate) {
            return Err(LabError::Args(format!(
                "--natnet-rate must be a number of Hz in [{}, {}], got {:?}",
                rates.start(),
                rates.end(),
                self.natnet_rate
            )));
        }
        Ok(())
    }

    /// Scenario `scenario` with the robots of `robots` in `swarm`, every
    /// other flag at its default (what `sim-agent lab --scenario S --robots
    /// FILE --swarm SWARM` parses into).
    pub fn new(scenario: impl Into<String>, robots: impl Into<PathBuf>, swarm: impl Into<String>) -> Self {
        Self {
            scenario: scenario.into(),
            robots: robots.into(),
            swarm: swarm.into(),
            speed: 1.0,
            seed: 0,
            duration: None,
            mocap_ms: 50,
            parent_pid: None,
            natnet: None,
            natnet_rate: 120.0,
            natnet_faults: None,
            ros2_router: None,
            ros2_domain_id: 0,
            ros2_namespace: "/".into(),
            bus: BusArgs::default(),
        }
    }

    /// The flags that reproduce these arguments after `sim-agent lab`
    /// (read back by `bycoms_sim_agent::options::command`'s `lab`).
    pub fn to_flags(&self) -> Vec<String> {
        let mut v = vec![
            "--scenario".into(),
            self.scenario.clone(),
            "--robots".into(),
            self.robots.display().to_string(),
            "--swarm".into(),
            self.swarm.clone(),
            "--speed".into(),
            format!("{:?}", self.speed),
            "--seed".into(),
            self.seed.to_string(),
            "--mocap-ms".into(),
            self.mocap_ms.to_string(),
            "--natnet-rate".into(),
            format!("{:?}", self.natnet_rate),
        ];
        if let Some(d) = self.duration {
            v.extend(["--duration".into(), format!("{d:?}")]);
        }
        if let Some(p) = self.parent_pid {
            v.extend(["--parent-pid".into(), p.to_string()]);
        }
        if let Some(addr) = self.natnet {
            v.extend(["--natnet".into(), addr.to_string()]);
        }
        if let Some(file) = &self.natnet_faults {
            v.extend(["--natnet-faults".into(), file.display().to_string()]);
        }
        if let Some(router) = &self.ros2_router {
            v.extend(["--ros2-router".into(), router.clone(), "--ros2-domain-id".into()]);
            v.extend([
                self.ros2_domain_id.to_string(),
                "--ros2-namespace".into(),
                self.ros2_namespace.clone(),
            ]);
        }
        v.extend(self.bus.to_flags());
        v
    }

    /// The whole argument list after the program: `lab` and [`to_flags`].
    ///
    /// [`to_flags`]: Self::to_flags
    pub fn to_args(&self) -> Vec<String> {
        std::iter::once(Self::SUBCOMMAND.to_string()).chain(self.to_flags()).collect()
    }
}

/// Why the lab could not run.
#[derive(Debug, thiserror::Error)]
pub enum LabError {
    /// A flag has an unusable value.
    #[error("{0}")]
    Args(String),
    /// The scenario could not be read.
    #[error("cannot read scenario {path}: {source}")]
    ReadScenario {
        /// The file.
        path: String,
        /// What the OS said, or that it is too large or not text.
        source: bycoms_runtime::capped::CappedError,
    },
    /// The scenario is unknown or malformed.
    #[error("scenario {name}: {source}")]
    Scenario {
        /// Name or file.
        name: String,
        /// What is wrong.
        source: ScenarioError,
    },
    /// The robots file or a key file.
    #[error(transparent)]
    Robots(#[from] RobotsError),
    /// The swarm name is not a valid topic chunk.
    #[error("bad swarm name: {0}")]
    Swarm(#[from] NameError),
    /// A robot's socket could not be bound or used.
    #[error("robot sockets: {0}")]
    Io(#[from] std::io::Error),
    /// The bus failed.
    #[error("bus: {0}")]
    Bus(#[from] BusError),
    /// The parent-death link could not be set up.
    #[error(transparent)]
    Lifeline(#[from] bycoms_runtime::lifeline::LifelineError),
    /// The NatNet server could not start.
    #[error(transparent)]
    NatNet(#[from] bycoms_natnet_server::ServerError),
    /// The ROS 2 robots' router could not be joined or subscribed on.
    #[error("{0}")]
    Ros2(String),
}

/// Loads a scenario: an existing file, else a built-in name.
pub fn load_scenario(name: &str) -> Result<Scenario, LabError> {
    let path = std::path::Path::new(name);
    if path.is_file() {
        let text = bycoms_runtime::capped::read_capped_file(path, super::scenario::MAX_FILE_BYTES)
            .map_err(|source| LabError::ReadScenario { path: name.to_owned(), source })?;
        Scenario::parse(&text)
    } else {
        Scenario::builtin(name)
    }
    .map_err(|source| LabError::Scenario { name: name.to_owned(), source })
}

/// The simulated motion capture: true poses on the bus. A real mocap
/// source (NatNet) publishes the same topics instead.
pub struct MocapOut<B: Bus> {
    /// Each of the lab's robots' pose publisher, by id.
    poses: std::collections::BTreeMap<RobotId, TypedPublisher<B::Publisher, Pose>>,
    frame: u64,
}

impl<B: Bus> MocapOut<B> {
    /// One pose publisher per robot of `ids` (the lab's own: a simulated
    /// member of a mixed swarm publishes its pose itself).
    pub fn open(bus: &B, swarm: &Swarm, ids: &[RobotId]) -> Result<Self, BusError> {
        let poses = ids
            .iter()
            .map(|&id| Ok((id, bus.typed_publisher(&swarm.pose(id))?)))
            .collect::<Result<_, BusError>>()?;
        Ok(Self { poses, frame: 0 })
    }

    /// Publishes every placed body's pose at lab time `now`.
    pub fn publish(&mut self, lab: &Lab, now: Duration) -> Result<(), BusError> {
        self.frame += 1;
        for (robot, b) in lab.poses() {
            let (Some(b), Some(out)) = (b, self.poses.get(&robot)) else {
                continue;
            };
            let time_us = bycoms_runtime::epoch::micros_of(now);
            out.publish(&Pose { robot, x: b.x, y: b.y, heading: b.heading, step: self.frame, time_us })?;
        }
        Ok(())
    }
}

/// The emulated operator: answers the orchestrator's placement requests
/// by putting the named robot on the start mark.
pub struct Operator<B: Bus> {
    requests: TypedSubscriber<B::Subscriber, Deploy>,
}

impl<B: Bus> Operator<B> {
    /// Listens on the swarm's `operator` topic.
    pub fn open(bus: &B, swarm: &Swarm) -> Result<Self, BusError> {
        Ok(Self { requests: bus.typed_subscriber(&swarm.operator())? })
    }

    /// Places every robot asked for since the last call. A request that
    /// does not decode or names no robot of the lab is logged and ignored.
    pub fn answer(&mut self, lab: &mut Lab) {
        loop {
            let request = match self.requests.try_recv() {
                Ok(Some(r)) => r,
                Ok(None) => return,
                Err(e) => {
                    tracing::warn!("operator: unreadable placement request: {e}");
                    continue;
                }
            };
            let start = lab.scenario().start;
            let index = (request.robot.0 as usize).wrapping_sub(1);
            if (request.x - start.x).hypot(request.y - start.y) > 0.05 {
                tracing::warn!(
                    robot = request.robot.0,
                    asked_x = request.x,
                    asked_y = request.y,
                    "operator: asked to place a robot away from the start mark; placing it on the mark"
                );
            }
            if lab.place(index) {
                let at = lab.scenario().placement(index);
                tracing::info!(
                    robot = request.robot.0,
                    x = at.x,
                    y = at.y,
                    lab_s = lab.now().as_secs_f64(),
                    "operator placed the robot at the start"
                );
            } else {
                tracing::warn!(
                    robot = request.robot.0,
                    "operator: no such robot off the arena, request ignored"
                );
            }
        }
    }
}

/// Wall time between control periods against nominal, µs.
#[derive(Default)]
struct Jitter {
    last: Option<Instant>,
    errors_us: Vec<f64>,
}

impl Jitter {
    fn control(&mut self, nominal: Duration) {
        let now = Instant::now();
        if let Some(last) = self.last.replace(now) {
            let err = now.duration_since(last).as_secs_f64() - nominal.as_secs_f64();
            self.errors_us.push(err.abs() * 1e6);
        }
    }

    fn percentile(&self, p: f64) -> Option<f64> {
        bycoms_runtime::stats::quantile(&self.errors_us, p)
    }
}

/// Runs the lab with `args`; returns the process exit code (0 orderly,
/// 2 usage error, 1 any other error).
pub fn main_with(args: &LabArgs) -> i32 {
    quiet_iceoryx2();
    let _span = tracing::info_span!("lab").entered();
    match run(args) {
        Ok(cause) => {
            tracing::debug!(?cause, "lab exits");
            // Interrupted: 130, as every agent process (`ExitCause::exit_code`).
            cause.map_or(0, ExitCause::exit_code)
        }
        Err(e) => {
            tracing::error!("{e}");
            if matches!(e, LabError::Args(_)) {
                2
            } else {
                1
            }
        }
    }
}

/// Reads and checks a NatNet faults file.
fn read_faults(path: &std::path::Path) -> Result<Faults, LabError> {
    let bad = |why: String| LabError::Args(format!("--natnet-faults {}: {why}", path.display()));
    let text = bycoms_runtime::capped::read_capped_file(path, super::scenario::MAX_FILE_BYTES)
        .map_err(|e| bad(e.to_string()))?;
    let faults: Faults = toml::from_str(&text).map_err(|e| bad(e.to_string()))?;
    if !(0.0..=1.0).contains(&faults.frame_loss) {
        return Err(bad(format!("frame_loss must be in [0, 1], got {}", faults.frame_loss)));
    }
    if !(faults.marker_noise_m.is_finite() && faults.marker_noise_m >= 0.0) {
        return Err(bad("marker_noise_m must be finite and ≥ 0".into()));
    }
    Ok(faults)
}

fn run(args: &LabArgs) -> Result<Option<ExitCause>, LabError> {
    let lifeline = Lifeline::install(args.parent_pid)?;
    run_with(args, lifeline)
}

/// Runs the lab with `args` until `lifeline` fires (in a process: its
/// signals and its parent; in-process, a test's `Lifeline::with_flag`) or
/// `--duration` passes; prints the summary.
pub fn run_with(args: &LabArgs, mut lifeline: Lifeline) -> Result<Option<ExitCause>, LabError> {
    args.validate()?;
    if let Some(router) = &args.ros2_router {
        bycoms_protocol::bus::zenoh::check_endpoint(router)
            .map_err(|e| LabError::Args(format!("bad --ros2-router {e}")))?;
    }
    let scenario = load_scenario(&args.scenario)?;
    let fleet = Fleet::read(args, &scenario)?;
    let swarm = Swarm::new(&args.swarm)?;
    let n = fleet.swarm;
    args.bus.validate().map_err(LabError::Args)?;
    let node = format!("bycoms-{}-lab", swarm.as_str());
    let then = RunLab { args, swarm: &swarm, scenario, fleet: &fleet, lifeline: &mut lifeline };
    args.bus.open(&swarm, None, None, n, node, then).map_err(|e| match e {
        BusOpenError::Args(a) => LabError::Args(a),
        BusOpenError::Bus(b) => LabError::Bus(b),
    })?
}

/// The lab's robots, of the one kind the robots file declares, and the
/// swarm they are members of.
struct Fleet {
    robots: Robots,
    /// Robots in the swarm: every process of a swarm sizes the bus for it.
    /// The lab's own robots, or with simulated members (`kind = "sim"`,
    /// which the lab does not emulate: they are `sim-agent`s of the
    /// launch) every robot of the file.
    swarm: u32,
}

/// The robots the lab emulates.
enum Robots {
    /// Emulated ESP32s, each wired to its gateway.
    Acoustic(Vec<Wiring>),
    /// ROS 2 robots, driven by their `cmd_vel` on the lab's router.
    Ros2(Vec<Ros2Entry>, Ros2Link),
}

impl Fleet {
    /// The scenario's robots: the robots file's first ones (one file
    /// serves every scenario of a lab); with simulated members, the whole
    /// file (a mixed swarm is as large as its robots file).
    fn read(args: &LabArgs, scenario: &Scenario) -> Result<Self, LabError> {
        let mut robots = RobotsFile::read(&args.robots)?;
        let file = args.robots.display();
        let kind = robots.kind().ok_or_else(|| {
            LabError::Args(format!("robots file {file} mixes acoustic and ros2 robots: one kind at a time"))
        })?;
        let mixed = !robots.sim.is_empty();
        match kind {
            Kind::Sim => {
                let why =
                    format!("robots file {file} has only simulated robots: the lab has none to emulate");
                return Err(LabError::Args(why));
            }
            Kind::Acoustic if mixed => {
                let why = format!(
                    "robots file {file} mixes acoustic and simulated robots: an acoustic robot hears tones, \
                     and a simulated one makes none (mixed swarms take ROS 2 robots)"
                );
                return Err(LabError::Args(why));
            }
            _ => {}
        }
        let (want, have) = (scenario.tones.len(), robots.len());
        if have < want && !mixed {
            return Err(LabError::Args(format!(
                "scenario {} has {want} robots, the robots file only {have}",
                scenario.name
            )));
        }
        let swarm = if mixed { have } else { want } as u32;
        if kind == Kind::Acoustic {
            if args.ros2_router.is_some() {
                let why = format!("--ros2-router is for ROS 2 robots; robots file {file} has acoustic ones");
                return Err(LabError::Args(why));
            }
            robots.robots.truncate(want);
            let keys = robots.keys()?;
            let wiring = robots.robots.iter().zip(keys);
            let wiring = wiring.map(|(r, key)| Wiring { key, bind: r.address, gateway: r.gateway }).collect();
            return Ok(Self { robots: Robots::Acoustic(wiring), swarm });
        }
        let router = args.ros2_router.clone().ok_or_else(|| {
            LabError::Args(format!(
                "robots file {file} has ROS 2 robots (kind = \"ros2\"): give the lab's zenoh router, \
                 --ros2-router tcp/HOST:7447"
            ))
        })?;
        robots.ros2.retain(|r| r.id <= swarm);
        let link =
            Ros2Link { router, domain_id: args.ros2_domain_id, namespace: args.ros2_namespace.clone() };
        Ok(Self { robots: Robots::Ros2(robots.ros2, link), swarm })
    }

    /// The ids of the robots the lab emulates.
    fn ids(&self) -> Vec<RobotId> {
        match &self.robots {
            Robots::Acoustic(wiring) => (1..=wiring.len() as u32).map(RobotId).collect(),
            Robots::Ros2(entries, _) => entries.iter().map(|e| RobotId(e.id)).collect(),
        }
    }

    /// The lab of these robots in `scenario` and, for ROS 2 robots, their
    /// commands' subscriptions.
    fn lab(&self, scenario: Scenario, seed: u64) -> Result<(Lab, Option<CmdVelIn>), LabError> {
        match &self.robots {
            Robots::Acoustic(wiring) => Ok((Lab::wired(scenario, wiring, seed)?, None)),
            Robots::Ros2(entries, link) => {
                let radius = scenario.body.radius;
                let bodies: Vec<_> = entries
                    .iter()
                    .map(|e| (RobotId(e.id), DiffDriveConfig::new(e.limits, radius, e.cmd_vel_timeout)))
                    .collect();
                let commands = CmdVelIn::open(link, entries).map_err(LabError::Ros2)?;
                Ok((Lab::ros2(scenario, &bodies, seed), Some(commands)))
            }
        }
    }
}

/// The lab's loop once the bus is open.
struct RunLab<'a> {
    args: &'a LabArgs,
    swarm: &'a Swarm,
    scenario: Scenario,
    fleet: &'a Fleet,
    lifeline: &'a mut Lifeline,
}

impl OnBus for RunLab<'_> {
    type Output = Result<Option<ExitCause>, LabError>;
    fn run<B: Bus>(self, bus: &B, _failsafe: Option<(Failsafe, AliveWatch)>) -> Self::Output {
        let RunLab { args, swarm, scenario, fleet, lifeline } = self;
        run_on(bus, args, swarm, scenario, fleet, lifeline)
    }
}

/// One motion capture: NatNet (as a real lab's Motive) or the bus.
fn mocap_out<B: Bus>(
    bus: &B,
    args: &LabArgs,
    swarm: &Swarm,
    fleet: &Fleet,
) -> Result<(Option<MocapOut<B>>, Option<NatNetOut>), LabError> {
    match args.natnet {
        Some(addr) => {
            let faults = match &args.natnet_faults {
                Some(path) => read_faults(path)?,
                None => Faults::default(),
            };
            let out = NatNetOut::start(addr, fleet.swarm, args.natnet_rate, args.speed, faults)?;
            tracing::info!(command = %out.command_addr(), rate_hz = args.natnet_rate, "lab: motion capture by NatNet");
            Ok((None, Some(out)))
        }
        None => Ok((Some(MocapOut::open(bus, swarm, &fleet.ids())?), None)),
    }
}

/// Logs every firmware state change since `states`.
fn log_states(lab: &Lab, states: &mut [RobotState], now: Duration) {
    for (i, (r, last)) in lab.robots().iter().zip(states.iter_mut()).enumerate() {
        let state = r.esp.firmware().state();
        if state != *last {
            let lab_s = now.as_secs_f64();
            tracing::info!(robot = i + 1, from = ?*last, to = ?state, lab_s, "firmware state");
            *last = state;
        }
    }
}

fn run_on<B: Bus>(
    bus: &B,
    args: &LabArgs,
    swarm: &Swarm,
    scenario: Scenario,
    fleet: &Fleet,
    lifeline: &mut Lifeline,
) -> Result<Option<ExitCause>, LabError> {
    let (bus, swarm, n) = (bus, *swarm, fleet.swarm);
    let (mut mocap, natnet) = mocap_out(bus, args, &swarm, fleet)?;
    let mut operator = Operator::open(bus, &swarm)?;
    let (mut lab, mut commands) = fleet.lab(scenario, args.seed)?;
    tracing::info!(scenario = lab.scenario().name, robots = n, speed = args.speed, "lab running");
    // Checked by `LabArgs::validate`: a valid span.
    let end = args.duration.map(Duration::from_secs_f64);
    let mocap_every = Duration::from_millis(args.mocap_ms);
    let mut next_mocap = Duration::ZERO;
    let mut states: Vec<RobotState> = lab.robots().iter().map(|r| r.esp.firmware().state()).collect();
    let mut jitter = Jitter::default();
    let nominal = CONTROL_PERIOD.div_f64(args.speed);
    let (t0, mut late) = (Instant::now(), Duration::ZERO);
    let cause = loop {
        if let Some(cause) = lifeline.check() {
            break Some(cause);
        }
        let now = lab.now();
        if end.is_some_and(|e| now >= e) {
            break None;
        }
        let control = !now.is_zero() && now.as_micros() % CONTROL_PERIOD.as_micros() == 0;
        operator.answer(&mut lab);
        if let Some(commands) = commands.as_mut() {
            commands.drain(&mut lab, t0, args.speed);
        }
        lab.step()?;
        if control {
            jitter.control(nominal);
        }
        log_states(&lab, &mut states, now);
        if let Some(natnet) = &natnet {
            natnet.update(&lab);
        }
        if let Some(mocap) = mocap.as_mut().filter(|_| now >= next_mocap) {
            mocap.publish(&lab, now)?;
            next_mocap += mocap_every;
        }
        let due = t0 + (now + PHYSICS_DT).div_f64(args.speed);
        let wall = Instant::now();
        if due > wall {
            std::thread::sleep(due - wall);
        } else {
            late = late.max(wall - due);
        }
    };
    print_summary(&lab, commands.as_ref(), &jitter, t0.elapsed(), late);
    Ok(cause)
}

fn print_summary(lab: &Lab, commands: Option<&CmdVelIn>, jitter: &Jitter, wall: Duration, late: Duration) {
    let mut robots: Vec<serde_json::Value> = lab
        .robots()
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let fw = r.esp.firmware();
            let drops: serde_json::Map<String, serde_json::Value> =
                fw.drops().nonzero().map(|(why, n)| (why.name().to_owned(), n.into())).collect();
            serde_json::json!({
                "robot": i + 1,
                "placed": r.body.is_some(),
                "x": r.body.map(|b| b.x),
                "y": r.body.map(|b| b.y),
                "stuck": r.body.is_some_and(|b| b.stuck),
                "state": format!("{:?}", fw.state()),
                "connected": fw.connected(),
                "datagrams_received": r.esp.received(),
                "drops": drops,
            })
        })
        .collect();
    robots.extend(lab.ros2_robots().iter().map(|r| {
        let counts = commands.map(|c| c.counts(r.id)).unwrap_or_default();
        let body = r.body.as_ref();
        serde_json::json!({
            "robot": r.id.0,
            "kind": "ros2",
            "placed": body.is_some(),
            "x": body.map(|b| b.x),
            "y": body.map(|b| b.y),
            "heading": body.map(|b| b.heading),
            "stuck": body.is_some_and(|b| b.stuck),
            "cmd_vel": {
                "commands": counts.commands,
                "undecodable": counts.undecodable,
                "unplaced": counts.unplaced,
                "last": counts.last.map(|v| [v.linear, v.angular]),
            },
        })
    }));
    let summary = serde_json::json!({
        "lab_s": lab.now().as_secs_f64(),
        "wall_s": wall.as_secs_f64(),
        "max_late_ms": late.as_secs_f64() * 1e3,
        "control_jitter_us": { "p50": jitter.percentile(0.5), "p99": jitter.percentile(0.99), "periods": jitter.errors_us.len() },
        "robots": robots,
    });
    println!("{summary}");
}
