//! `launch`'s configuration: the TOML file, its defaults, its validation.
//!
//! Why strict: a misspelt key in a lab's config file must be an error, not
//! a silently ignored setting (`deny_unknown_fields` everywhere). Every key
//! is documented in one file, `deploy/launch.toml`, whose values are exactly
//! [`LaunchConfig::default`] (a test parses it and compares). Precedence:
//! built-in defaults < `--config FILE` < command-line flags. Relative
//! paths in a config file are relative to the file's directory (a lab keeps
//! its config beside its terrain), those on the command line to the working
//! directory.

mod finite;
mod moved;
mod ros2;
mod supervision;

pub use super::agents::choice::{AgentSourceKind, AgentsConfig};
pub use super::agents::gateways::GatewaysAt;
use anyhow::{Context, Result};
use bycoms_protocol::bus::fault::FaultConfig;
use bycoms_runtime::check_speed;
use bycoms_runtime::exit::usage;
use bycoms_runtime::seconds::{check_seconds, Zero};
use bycoms_sim::runner::DEFAULT_SUCCESS_RADIUS;
use bycoms_sim::sensing::NoiseModel;
use bycoms_sim::RunConfig;
use bycoms_study::runs::{check_run, RunNames};
pub use ros2::Ros2Config;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;
pub use supervision::{SupervisionConfig, SHUTDOWN_GRACE_PER_AGENT};

/// The bus kind, shared with the agents (`--transport`).
pub use bycoms_runtime::Transport;
/// How simulated time advances: the one clock enum, shared with the agents.
pub use bycoms_sim_agent::Clock;

/// The dead-robot and missing-robot policies (the launch core's, owned there).
pub use bycoms_launch_core::{Missing, OnDeath};

/// Everything `orchestrator launch` can be configured with.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LaunchConfig {
    /// Robots available; deployed one at a time.
    pub robots: u32,
    /// Built-in scenario used when no terrain file is given.
    pub scenario: String,
    /// Terrain file (overrides `scenario`).
    pub terrain: Option<PathBuf>,
    /// Circumferential radius ε, cells.
    pub eps: f64,
    /// The paper's sensing noise.
    pub noise: bool,
    /// Run seed of the noise streams.
    pub seed: u64,
    /// Lockstep or real time.
    pub clock: Clock,
    /// Real-time speed-up (real-time clock only).
    pub speed: f64,
    /// A mixed swarm's simulated members run this many times faster than
    /// `speed` (`--sim-speed`): only one robot moves at a time, so while a
    /// simulated one moves every real robot stands (waiting, or stopped as a
    /// beacon), and the run between real robots takes less of the lab's day.
    pub sim_speed: f64,
    /// Simulated time budget, s (periods during which a robot moved).
    pub time_limit: f64,
    /// A robot within this distance of the goal has arrived (world units;
    /// the runner's `success_radius`, decided by
    /// [`bycoms_sim::runner::arrived`] for the gate and the runner alike).
    pub goal_radius: f64,
    /// Swarm name (topic namespace); default `launch-<pid>`.
    pub swarm: Option<String>,
    /// MCAP recording of every message and gate event.
    pub record: Option<PathBuf>,
    /// SVG snapshot of the run (trajectories, beacons, ε circles) written at the end.
    pub svg: Option<PathBuf>,
    /// Serve the live view (Foxglove WebSocket + the page) on `host:port`.
    pub serve: Option<String>,
    /// The agent executable; default `sim-agent` next to the orchestrator.
    pub agent_bin: Option<PathBuf>,
    /// The deployment gate.
    pub gate: GateConfig,
    /// Agent supervision.
    pub supervision: SupervisionConfig,
    /// Fault injection into the orchestrator's bus (off by default).
    pub faults: FaultsConfig,
    /// `launch --ros2`: publish the run into a ROS 2 graph over rmw_zenoh (zenoh transport only).
    pub ros2: Option<Ros2Config>,
    /// The bus: iceoryx2 on this host, or zenoh across hosts.
    pub transport: TransportConfig,
    /// Where the gate's poses come from (`bycoms_mocap::MocapConfig`).
    pub mocap: bycoms_mocap::MocapConfig,
    /// Where the agents come from (`super::agents::choice`).
    pub agents: AgentsConfig,
    /// How the operator's placement of each real robot at the start is
    /// confirmed by motion capture, whatever the pose source.
    pub placement: bycoms_mocap::PlacementConfig,
}

/// The bus of a launch (`[transport]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default, expecting = "a [transport] table")]
pub struct TransportConfig {
    /// `ipc` (iceoryx2, this host) or `zenoh` (tcp/quic/tls, any host).
    pub kind: Transport,
    /// zenoh: endpoints the orchestrator's router session listens on
    /// (`tcp/HOST:PORT`, `quic/HOST:PORT`, `tls/HOST:PORT`; port 0 takes a
    /// free port).
    pub listen: Vec<String>,
    /// zenoh: endpoints it connects to as well (e.g. a standalone zenohd).
    pub connect: Vec<String>,
    /// zenoh: a zenoh JSON5 config file read first (TLS, access control).
    pub zenoh_config: Option<PathBuf>,
    /// zenoh: the config file each agent this launch starts reads first,
    /// `{robot}` replaced by its robot id: e.g. `certs/robot-{robot}.json5`
    /// as `orchestrator certs` writes them, so spawned agents can join a
    /// secured (`quic/`, `tls/`) endpoint with their own certificate.
    pub agent_zenoh_config: Option<PathBuf>,
}

impl TransportConfig {
    /// The zenoh config file robot `id`'s agent reads first, if any
    /// (`agent_zenoh_config` with `{robot}` replaced).
    pub fn agent_config_of(&self, id: u32) -> Option<PathBuf> {
        let template = self.agent_zenoh_config.as_ref()?;
        Some(PathBuf::from(template.to_string_lossy().replace("{robot}", &id.to_string())))
    }
}

impl Default for TransportConfig {
    fn default() -> Self {
        Self {
            kind: Transport::Ipc,
            listen: vec!["tcp/127.0.0.1:0".into()],
            connect: Vec::new(),
            zenoh_config: None,
            agent_zenoh_config: None,
        }
    }
}

/// The deployment gate's motion test.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default, expecting = "a [gate] table")]
pub struct GateConfig {
    /// A robot slower than this (units/s) is still...
    pub stop_speed: f64,
    /// ...if it also turns slower than this (rad/s; 0: turning is ignored).
    pub stop_turn_rate: f64,
    /// A robot still for this long (simulated s) has stopped.
    pub dwell: f64,
    /// Start the next agent process while the current robot moves.
    pub prespawn: bool,
    /// What a dead agent means.
    pub on_agent_death: OnDeath,
    /// A pose that moved faster than this (world units — cells, or metres
    /// in a lab — per second of simulated time) from the robot's last one
    /// is refused as implausible (a forged or swapped pose; see
    /// `orchestrator/launch-core/src/plausible.rs`, which says why motion
    /// capture's `tracker.max_speed` is another rule).
    pub max_speed: f64,
}

impl Default for LaunchConfig {
    fn default() -> Self {
        Self {
            robots: 3,
            scenario: "long-obstacle".into(),
            terrain: None,
            eps: 3.0,
            noise: false,
            seed: 0,
            clock: Clock::Lockstep,
            speed: 10.0,
            sim_speed: 1.0,
            time_limit: 10_000.0,
            goal_radius: DEFAULT_SUCCESS_RADIUS,
            swarm: None,
            record: None,
            svg: None,
            serve: None,
            agent_bin: None,
            gate: GateConfig::default(),
            supervision: SupervisionConfig::default(),
            faults: FaultsConfig::default(),
            ros2: None,
            transport: TransportConfig::default(),
            mocap: bycoms_mocap::MocapConfig::default(),
            agents: AgentsConfig::default(),
            placement: bycoms_mocap::PlacementConfig::default(),
        }
    }
}

impl Default for GateConfig {
    fn default() -> Self {
        Self {
            stop_speed: 0.05,
            stop_turn_rate: 0.05,
            dwell: 20.0,
            prespawn: true,
            on_agent_death: OnDeath::Beacon,
            max_speed: 5.0,
        }
    }
}

impl LaunchConfig {
    /// Reads a config file; missing keys keep their defaults, relative
    /// paths in it are resolved against the file's directory.
    pub fn load(path: &Path) -> Result<Self> {
        let text = bycoms_runtime::capped::read_capped_file(path, MAX_CONFIG_BYTES)
            .with_context(|| format!("cannot read config {}", path.display()))?;
        let mut cfg =
            Self::parse(&text).map_err(|e| usage(format!("bad config {}: {e:#}", path.display())))?;
        let base = path.parent().unwrap_or(Path::new(""));
        for field in [
            &mut cfg.terrain,
            &mut cfg.record,
            &mut cfg.svg,
            &mut cfg.agent_bin,
            &mut cfg.transport.zenoh_config,
            &mut cfg.transport.agent_zenoh_config,
            &mut cfg.agents.robots_file,
            &mut cfg.agents.gateway_bin,
        ] {
            if let Some(p) = field.as_mut().filter(|p| p.is_relative()) {
                *p = base.join(&*p);
            }
        }
        // A lab scenario is a built-in name or a file beside the config.
        if let Some(s) = cfg.agents.scenario.as_mut() {
            let beside = base.join(&*s);
            if Path::new(s.as_str()).is_relative() && beside.is_file() {
                *s = beside.display().to_string();
            }
        }
        Ok(cfg)
    }

    /// Parses config text; a table that moved is named with its new place.
    pub fn parse(text: &str) -> Result<Self> {
        toml::from_str(text).map_err(|e| match moved::old_placement_tables(text).first() {
            Some(old) => anyhow::anyhow!(
                "{old} is now the top-level [placement] table (one for every pose source): {e}"
            ),
            None => e.into(),
        })
    }

    /// Reads the configuration a recording holds (its `run` channel's
    /// `config`), keys that moved since it was written carried over.
    pub fn from_recorded(mut config: serde_json::Value) -> serde_json::Result<Self> {
        moved::upgrade_recorded(&mut config);
        serde_json::from_value(config)
    }

    /// The property the `launch_config` fuzz target checks on any bytes
    /// (`fuzz/`), kept here so that the target is a one-line shim and the
    /// unit tests run the same check over the target's seeds: text either
    /// is rejected or gives a config that validates or not without
    /// panicking, serialises back to TOML, and reads back to the same
    /// config (compared as TOML text, so NaN, which `validate` rejects, does
    /// not break equality); a valid config compares equal and stays valid.
    pub fn check_round_trip(data: &[u8]) -> std::result::Result<(), String> {
        let Ok(text) = std::str::from_utf8(data) else { return Ok(()) };
        let Ok(config) = Self::parse(text) else { return Ok(()) };
        let valid = config.validate().is_ok();
        let written =
            toml::to_string(&config).map_err(|e| format!("a parsed config does not serialise: {e}"))?;
        let back = Self::parse(&written).map_err(|e| format!("a serialised config does not parse: {e:#}"))?;
        let again =
            toml::to_string(&back).map_err(|e| format!("a read-back config does not serialise: {e}"))?;
        if again != written {
            return Err(format!("the TOML round trip is not stable:\n{written}\n---\n{again}"));
        }
        if valid && (back != config || back.validate().is_err()) {
            return Err(format!("a valid config does not survive the round trip:\n{written}"));
        }
        Ok(())
    }

    /// The run parameters of the robots: the runner's, with this config's
    /// ε, noise, seed, time limit and goal radius.
    pub fn run_config(&self) -> RunConfig {
        let mut run = RunConfig::paper(self.eps);
        run.noise = self.noise.then(NoiseModel::paper);
        run.seed = self.seed;
        run.time_limit = self.time_limit;
        run.success_radius = self.goal_radius;
        run
    }

    /// The control period dt, s: the robots' kinematics' (one constant for
    /// the simulator, the agents and the launch).
    pub fn dt(&self) -> f64 {
        self.run_config().kinematics.dt
    }

    /// One control period in wall time on the real-time clock (dt / speed).
    pub fn wall_period(&self) -> Duration {
        Duration::from_secs_f64(self.dt() / self.speed)
    }

    /// One control period in simulated µs (the poses' `time_us` step).
    pub fn dt_us(&self) -> u64 {
        (self.dt() * 1e6).round() as u64
    }

    /// Checks every value; the message names the key. Every error is a
    /// usage error (exit code 2). The run parameters go through the one
    /// check every command and every agent makes ([`check_run`]).
    pub fn validate(&self) -> Result<()> {
        check_run(&self.run_config(), &CONFIG_KEYS)?;
        self.faults.validate()?;
        check_speed(self.speed).map_err(|e| usage(format!("bad speed (--speed): {e}")))?;
        self.check_sim_speed()?;
        self.check_gate()?;
        self.check_seconds()?;
        if self.transport.kind == Transport::Zenoh
            && self.transport.listen.is_empty()
            && self.transport.zenoh_config.is_none()
        {
            return Err(usage("transport.listen needs an endpoint (e.g. tcp/0.0.0.0:7447) with zenoh"));
        }
        let secured = self.transport.listen.iter().find(|e| bycoms_protocol::bus::zenoh::is_secured(e));
        if self.transport.kind == Transport::Zenoh
            && secured.is_some()
            && self.agents.started_here()
            && self.transport.agent_zenoh_config.is_none()
        {
            let endpoint = secured.map_or("", String::as_str);
            return Err(usage(format!(
                "the agents this launch starts cannot join the secured endpoint {endpoint} without their \
                 certificates: set transport.agent_zenoh_config (--agent-zenoh-config), e.g. \
                 certs/robot-{{robot}}.json5"
            )));
        }
        if let Some(addr) = &self.serve {
            check_serve(addr)?;
        }
        self.check_ros2()?;
        if let Some(name) = &self.swarm {
            check_swarm(name)?;
        }
        check_endpoints("transport.listen", &self.transport.listen)?;
        check_endpoints("transport.connect", &self.transport.connect)?;
        if self.robots == 0 {
            return Err(usage("robots must be at least 1"));
        }
        if self.robots > MAX_ROBOTS {
            return Err(usage(format!("robots must be at most {MAX_ROBOTS}, got {}", self.robots)));
        }
        self.mocap.validate(self.robots, &self.simulated_robots()).map_err(usage)?;
        self.placement.validate().map_err(usage)?;
        let graph =
            self.ros2.as_ref().is_some_and(|r| r.router.is_some()) || self.transport.kind == Transport::Zenoh;
        self.agents
            .validate(self.robots, self.transport.kind, self.clock == Clock::Lockstep, graph)
            .map_err(usage)?;
        if self.supervision.heartbeat_timeout <= self.supervision.heartbeat_interval {
            return Err(usage(
                "supervision.heartbeat_timeout must be longer than supervision.heartbeat_interval",
            ));
        }
        self.check_finite()
    }

    /// The simulated members of a mixed swarm (`kind = "sim"` in the robots
    /// file of real robots), which motion capture does not see; none for
    /// any other launch, or when the file cannot be read (the agents' check
    /// says why).
    fn simulated_robots(&self) -> Vec<u32> {
        let file = self.agents.robots_file.as_deref().filter(|_| self.agents.source == AgentSourceKind::Real);
        file.and_then(|p| bycoms_lab::robots::RobotsFile::read(p).ok()).map(|f| f.sim).unwrap_or_default()
    }

    /// Every float of the config, whatever its key, is a finite number
    /// ([`finite`]); the keys checked above say more about their own.
    fn check_finite(&self) -> Result<()> {
        // TOML's integers are i64: a seed past i64::MAX (any u64 is a valid
        // seed) would not serialise. Seeds are integers, never floats, so
        // the walk goes over a copy with them set aside.
        let mut floats = self.clone();
        floats.seed = 0;
        floats.faults.seed = 0;
        let value = toml::Value::try_from(&floats).context("the config does not serialise")?;
        match finite::first_non_finite(&value) {
            Some((key, v)) => Err(usage(format!("{key} must be a finite number, got {v}"))),
            None => Ok(()),
        }
    }

    /// The gate's speeds, by key and flag.
    /// `sim_speed`: a positive speed-up whose product with `speed` is one
    /// an agent can keep ([`check_speed`]), on the real-time clock (a
    /// stepped swarm runs as fast as it can anyway). Whether the swarm has
    /// simulated members beside real ones is the world's to say
    /// ([`crate::lab::check_sim_speed`]).
    fn check_sim_speed(&self) -> Result<()> {
        if self.sim_speed == 1.0 {
            return Ok(());
        }
        let bad = |why: String| usage(format!("bad sim_speed (--sim-speed): {why}"));
        if !(self.sim_speed.is_finite() && self.sim_speed > 0.0) {
            return Err(bad(format!("must be a positive number, got {}", self.sim_speed)));
        }
        if self.clock != Clock::Realtime {
            return Err(bad(
                "speeds up a real-time launch (clock = \"realtime\"); a lockstep one is not timed".into(),
            ));
        }
        check_speed(self.speed * self.sim_speed).map_err(|e| {
            bad(format!("the simulated members would run at {} × {}: {e}", self.speed, self.sim_speed))
        })
    }

    fn check_gate(&self) -> Result<()> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !positive(self.gate.max_speed) {
            return Err(usage(format!(
                "gate.max_speed must be a positive number, got {}",
                self.gate.max_speed
            )));
        }
        // Nothing is slower than 0: with `stop_speed` 0 no robot would ever
        // be still, and only the time limit would end it.
        if !positive(self.gate.stop_speed) {
            return Err(usage(format!(
                "gate.stop_speed (--stop-speed) must be a positive number (a robot slower than it is still), got {}",
                self.gate.stop_speed
            )));
        }
        let turn = self.gate.stop_turn_rate;
        if !(turn.is_finite() && turn >= 0.0) {
            return Err(usage(format!(
                "gate.stop_turn_rate (--stop-turn-rate) must be a non-negative number (0 ignores turning), got {turn}"
            )));
        }
        Ok(())
    }

    /// Every span of seconds, by its key and flag, through the one check
    /// ([`bycoms_runtime::seconds`]): `--unreachable-grace 1e300` is a usage error,
    /// not a panic where it becomes a `Duration`.
    fn check_seconds(&self) -> Result<()> {
        let (gate, sup) = (&self.gate, &self.supervision);
        let spans = [
            ("gate.dwell (--dwell)", gate.dwell, Zero::Refused),
            ("supervision.register_timeout (--register-timeout)", sup.register_timeout, Zero::Refused),
            ("supervision.heartbeat_interval", sup.heartbeat_interval, Zero::Refused),
            ("supervision.heartbeat_timeout (--heartbeat-timeout)", sup.heartbeat_timeout, Zero::Refused),
            ("supervision.tick_timeout", sup.tick_timeout, Zero::Refused),
            ("supervision.shutdown_grace", sup.shutdown_grace, Zero::Refused),
            ("supervision.unreachable_grace (--unreachable-grace)", sup.unreachable_grace, Zero::Allowed),
            ("supervision.clock_warn", sup.clock_warn, Zero::Allowed),
            ("supervision.clock_limit", sup.clock_limit, Zero::Allowed),
        ];
        for (key, value, zero) in spans {
            check_seconds(key, value, zero).map_err(usage)?;
        }
        Ok(())
    }

    /// A duration from seconds (validated by [`Self::validate`]).
    pub fn secs(v: f64) -> Duration {
        Duration::from_secs_f64(v)
    }
}

/// The run parameters by their config keys (and flags): a launch's value
/// comes from the config file or a flag.
const CONFIG_KEYS: RunNames = RunNames {
    eps: "eps (--eps)",
    time_limit: "time_limit (--time-limit)",
    success_radius: "goal_radius (--goal-radius)",
    max_robots: "robots (--robots)",
};

/// A swarm name from the user (flag or config): the swarm, or a usage
/// error naming it.
pub fn check_swarm(name: &str) -> Result<bycoms_protocol::Swarm> {
    bycoms_protocol::Swarm::new(name).map_err(|e| usage(format!("bad swarm name {name:?}: {e}")))
}

/// zenoh endpoints from the user, named `what` (`--listen`,
/// `transport.listen`): a usage error for the first one that is not
/// `LINK/HOST:PORT` ([`bycoms_protocol::bus::zenoh::check_endpoint`]).
impl LaunchConfig {
    /// `[ros2]` and a ROS 2 mocap source: a graph to reach (a router, or
    /// the launch's zenoh session), a router endpoint that parses, and no
    /// mocap topic that is one of the launch's own pose topics (it would
    /// hear its own poses as motion capture).
    fn check_ros2(&self) -> Result<()> {
        let ros2 = self.ros2.clone().unwrap_or_default();
        let wanted = self.ros2.is_some() || self.mocap.source == bycoms_mocap::MocapSource::Ros2;
        if !wanted {
            return Ok(());
        }
        ros2.validate().map_err(usage)?;
        if let Some(router) = &ros2.router {
            check_endpoints("ros2.router", std::slice::from_ref(router))?;
            if bycoms_protocol::bus::zenoh::is_secured(router) {
                return Err(usage(format!(
                    "ros2.router {router} (--ros2-router): a secured endpoint needs the lab's \
                     certificates, and the launch's ROS 2 session is given none: give the tcp/HOST:PORT \
                     the lab's rmw_zenohd listens on"
                )));
            }
        } else if self.transport.kind != Transport::Zenoh {
            return Err(usage(
                "ros2 (--ros2, mocap.source = \"ros2\") needs a zenoh session: set ros2.router \
                 (--ros2-router, the lab's rmw_zenohd) or transport.kind = \"zenoh\"",
            ));
        }
        let (Some(mocap), Some(_)) = (&self.mocap.ros2, &self.ros2) else { return Ok(()) };
        match (1..=self.robots).map(|k| ros2.pose_topic(k)).find(|t| mocap.topics.contains_key(t)) {
            Some(topic) => Err(usage(format!(
                "mocap.ros2.topics: {topic} is a topic this launch publishes its own poses on (ros2.namespace): \
                 map the driver's topics"
            ))),
            None => Ok(()),
        }
    }
}

pub fn check_endpoints(what: &str, endpoints: &[String]) -> Result<()> {
    for endpoint in endpoints {
        bycoms_protocol::bus::zenoh::check_endpoint(endpoint)
            .map_err(|e| usage(format!("bad {what} {e}")))?;
    }
    Ok(())
}

/// Largest config file read, bytes (`deploy/launch.toml`, every key with
/// its documentation, is about 14 kB): `--config /dev/zero` must not read
/// without end.
pub const MAX_CONFIG_BYTES: u64 = 1024 * 1024;

/// Most robots one launch deploys (sizes the shared-memory services).
pub const MAX_ROBOTS: u32 = 1000;

/// A robot count given with `flag` to a command that sizes a swarm's bus as
/// a launch does (`bridge`, `doctor`, `bench crowd` / `stop`): 1 to
/// [`MAX_ROBOTS`], else a usage error up front. (`bridge --robots 100000`
/// worked for 6 s before iceoryx2 refused its services, and left files.)
pub fn check_robot_count(flag: &str, robots: u32) -> Result<()> {
    if robots == 0 || robots > MAX_ROBOTS {
        return Err(usage(format!("{flag} {robots}: a launch deploys 1 to {MAX_ROBOTS} robots")));
    }
    Ok(())
}

/// `serve` must be `host:port` (port 0 picks a free port).
fn check_serve(addr: &str) -> Result<()> {
    let bad = || usage(format!("serve must be host:port (e.g. 127.0.0.1:8765, 0.0.0.0:0), got {addr:?}"));
    let (host, port) = addr.rsplit_once(':').ok_or_else(bad)?;
    if host.is_empty() || port.parse::<u16>().is_err() {
        return Err(bad());
    }
    Ok(())
}

/// The `[faults]` section: probabilities per received message.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default, expecting = "a [faults] table")]
pub struct FaultsConfig {
    /// Probability that a message is lost.
    pub drop: f64,
    /// Probability that a message is delivered twice.
    pub duplicate: f64,
    /// Probability that a message is held back for `delay_ms`.
    pub delay: f64,
    /// How long a delayed message is held, ms.
    pub delay_ms: u64,
    /// Probability that a message is swapped with its successor.
    pub reorder: f64,
    /// Seed of the fault decisions.
    pub seed: u64,
}

impl Default for FaultsConfig {
    fn default() -> Self {
        Self { drop: 0.0, duplicate: 0.0, delay: 0.0, delay_ms: 10, reorder: 0.0, seed: 0 }
    }
}

impl FaultsConfig {
    /// Whether any fault is enabled.
    pub fn is_on(&self) -> bool {
        [self.drop, self.duplicate, self.delay, self.reorder].iter().any(|&p| p != 0.0)
    }

    /// The protocol crate's form.
    pub fn fault_config(&self) -> FaultConfig {
        FaultConfig {
            drop: self.drop,
            duplicate: self.duplicate,
            delay: self.delay,
            delay_by: Duration::from_millis(self.delay_ms),
            reorder: self.reorder,
            seed: self.seed,
        }
    }

    /// Checks every rate lies in 0..=1 (a usage error naming the key and
    /// its value otherwise: "faults.drop = 1.5: …").
    pub fn validate(&self) -> Result<()> {
        self.fault_config().validate().map_err(|why| usage(format!("faults.{why}")))
    }

    /// The faults in words, for the log: "drop 0.5, duplicate 0, delay 0.1
    /// by 10 ms, reorder 0, seed 3".
    pub fn words(&self) -> String {
        format!(
            "drop {}, duplicate {}, delay {} by {} ms, reorder {}, seed {}",
            self.drop, self.duplicate, self.delay, self.delay_ms, self.reorder, self.seed
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fuzz target's property over its seeds, every prefix of them and
    /// every single-byte change to a few bytes (what CI runs instead of
    /// building the orchestrator for libFuzzer; `fuzz/README.md`).
    #[test]
    fn the_fuzz_targets_round_trip_holds_on_its_seeds_and_their_variants() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/seeds/launch_config");
        let mut checked = 0;
        for entry in std::fs::read_dir(&dir).expect("the launch_config seeds") {
            let seed = std::fs::read(entry.expect("entry").path()).expect("seed");
            for end in 0..=seed.len() {
                LaunchConfig::check_round_trip(&seed[..end]).unwrap_or_else(|e| panic!("prefix {end}: {e}"));
                checked += 1;
            }
            for at in (0..seed.len()).step_by(7) {
                for byte in [b'0', b'9', b'-', b'.', b'"', b'[', b'\n', b'e', b'x'] {
                    let mut v = seed.clone();
                    v[at] = byte;
                    LaunchConfig::check_round_trip(&v).unwrap_or_else(|e| panic!("byte {at} = {byte}: {e}"));
                    checked += 1;
                }
            }
        }
        assert!(checked > 1000, "{checked} inputs checked");
    }

    const DEFAULT_FILE: &str = include_str!("../../../deploy/launch.toml");

    #[test]
    fn the_documented_default_file_is_the_default() {
        let parsed = LaunchConfig::parse(DEFAULT_FILE).expect("deploy/launch.toml parses");
        assert_eq!(parsed, LaunchConfig::default());
        parsed.validate().expect("the defaults are valid");
    }

    #[test]
    fn the_shutdown_grace_grows_with_the_agents_still_running_from_the_configured_one() {
        let sup = SupervisionConfig { shutdown_grace: 0.5, ..Default::default() };
        assert_eq!(sup.shutdown_grace_for(0), Duration::from_millis(500));
        assert_eq!(sup.shutdown_grace_for(300), Duration::from_millis(500) + SHUTDOWN_GRACE_PER_AGENT * 300);
        assert!(sup.shutdown_grace_for(1000) > sup.shutdown_grace_for(300));
    }

    #[test]
    fn every_key_of_the_default_file_is_documented() {
        // A key line `k = v` must follow a comment line.
        let mut previous = "";
        for line in DEFAULT_FILE.lines().map(str::trim) {
            let is_key = !line.starts_with('#') && !line.starts_with('[') && line.contains('=');
            assert!(!is_key || previous.starts_with('#'), "undocumented key: {line}");
            previous = line;
        }
    }

    #[test]
    fn unknown_keys_and_bad_values_are_errors() {
        let err = LaunchConfig::parse("robtos = 3").unwrap_err();
        assert!(format!("{err:#}").contains("robtos"), "{err:#}");
        let err = LaunchConfig::parse("[gate]\ndwel = 3.0").unwrap_err();
        assert!(format!("{err:#}").contains("dwel"), "{err:#}");
        let err = LaunchConfig::parse("[mocap.natnet.placement]\nradius = 0.2").unwrap_err();
        let said = "[mocap.natnet.placement] is now the top-level [placement] table";
        assert!(format!("{err:#}").starts_with(said), "{err:#}");
        let recorded = serde_json::json!({"agents": {"placement": {"radius": 0.3}}});
        assert_eq!(LaunchConfig::from_recorded(recorded).expect("an older recording").placement.radius, 0.3);
        let partial = LaunchConfig::parse("eps = 2.0\n[gate]\ndwell = 30.0").unwrap();
        assert_eq!((partial.eps, partial.gate.dwell, partial.robots), (2.0, 30.0, 3));
        let bad = LaunchConfig { eps: -1.0, ..LaunchConfig::default() };
        assert!(format!("{:#}", bad.validate().unwrap_err()).contains("eps"));
    }

    #[test]
    fn a_table_given_as_a_value_is_named_as_the_table_not_as_a_rust_type() {
        for key in ["transport", "gate", "supervision", "faults", "mocap", "agents", "placement", "ros2"] {
            let err = format!("{:#}", LaunchConfig::parse(&format!("{key} = 5")).unwrap_err());
            let article = if key == "agents" { "an" } else { "a" };
            assert!(err.contains(&format!("expected {article} [{key}] table")), "{key}: {err}");
            assert!(!err.contains("struct"), "{key}: {err}");
        }
    }

    #[test]
    fn seconds_past_any_run_in_a_config_are_usage_errors_naming_the_key_and_its_range() {
        for (text, says) in [
            (
                "[supervision]\nregister_timeout = 1e300",
                "supervision.register_timeout (--register-timeout) must",
            ),
            (
                "[supervision]\nheartbeat_timeout = 1e20",
                "supervision.heartbeat_timeout (--heartbeat-timeout) must",
            ),
            ("[supervision]\nlink_grace = 1e300", "supervision.unreachable_grace (--unreachable-grace) must"),
            ("[supervision]\nlink_grace = nan", "supervision.unreachable_grace (--unreachable-grace) must"),
            ("[supervision]\ntick_timeout = inf", "supervision.tick_timeout must"),
            ("[supervision]\nshutdown_grace = -1.0", "supervision.shutdown_grace must"),
            ("[gate]\ndwell = 1e300", "gate.dwell (--dwell) must"),
            ("time_limit = 1e300", "bad time_limit (--time-limit)"),
            ("[placement]\ntimeout = 1e300", "placement.timeout must"),
        ] {
            let cfg = LaunchConfig::parse(text).expect("parses");
            let e = cfg.validate().expect_err(text);
            assert_eq!(bycoms_runtime::exit::code_of(&e), bycoms_runtime::exit::USAGE, "{text}: {e:#}");
            assert!(format!("{e:#}").contains(says), "{text}: {e:#}");
            assert!(format!("{e:#}").contains("100000000"), "the range is said: {e:#}");
        }
    }

    /// Issue 49: a NaN or infinite arena origin passed, and the operator
    /// was asked for 600 s to place a robot that could never be placed.
    /// Every float of the config goes through one check naming its key.
    #[test]
    fn a_non_finite_float_anywhere_in_a_config_is_a_usage_error_naming_its_key() {
        let lab = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../deploy/lab");
        let ros2 = LaunchConfig::load(&lab.join("launch-ros2.toml")).expect("the ROS 2 lab config");
        let natnet = LaunchConfig::load(&lab.join("launch-natnet.toml")).expect("the NatNet lab config");
        ros2.validate().expect("valid as shipped");
        natnet.validate().expect("valid as shipped");
        let mut cases = Vec::new();
        let mut cfg = ros2.clone();
        cfg.mocap.ros2.as_mut().expect("[mocap.ros2]").arena.origin = [f64::NAN, 1e308, f64::NEG_INFINITY];
        cases.push((cfg, "mocap.ros2.arena.origin[0] must be a finite number, got NaN"));
        let mut cfg = natnet.clone();
        cfg.mocap.natnet.as_mut().expect("[mocap.natnet]").arena.origin = [0.0, 1e308, f64::NEG_INFINITY];
        cases.push((cfg, "mocap.natnet.arena.origin[2] must be a finite number, got -inf"));
        for (cfg, says) in cases {
            let e = cfg.validate().expect_err(says);
            assert_eq!(bycoms_runtime::exit::code_of(&e), bycoms_runtime::exit::USAGE, "{e:#}");
            assert_eq!(format!("{e:#}"), says);
        }
        // Seeds past TOML's i64 (the soak's) are not floats and pass the walk.
        let mut big = ros2;
        big.seed = u64::MAX;
        big.faults.seed = u64::MAX - 1;
        big.validate().expect("any u64 is a seed");
    }

    /// `--sim-speed`: a positive speed-up, on the real-time clock, whose
    /// product with `--speed` an agent can keep; 1 is always valid.
    #[test]
    fn a_sim_speed_is_a_positive_speed_up_of_a_real_time_launch() {
        let realtime = |sim_speed| LaunchConfig {
            clock: Clock::Realtime,
            speed: 3.0,
            sim_speed,
            ..LaunchConfig::default()
        };
        realtime(4.0).validate().expect("4 × 3 is a speed an agent keeps");
        LaunchConfig::default().validate().expect("1 under lockstep");
        for (cfg, why) in [
            (realtime(0.0), "must be a positive number, got 0"),
            (realtime(f64::NAN), "must be a positive number, got NaN"),
            (realtime(400.0), "the simulated members would run at 3 × 400"),
            (LaunchConfig { sim_speed: 2.0, ..LaunchConfig::default() }, "a lockstep one is not timed"),
        ] {
            let e = format!("{:#}", cfg.validate().expect_err("refused"));
            assert!(e.starts_with("bad sim_speed (--sim-speed): "), "{e}");
            assert!(e.contains(why), "{e}");
        }
    }

    /// Issue 49: `--stop-speed 0` made no robot ever still, and a lockstep
    /// launch ran without end.
    #[test]
    fn a_stop_speed_of_zero_is_refused_naming_the_key_and_flag() {
        for v in [0.0, -0.1, f64::NAN] {
            let cfg = LaunchConfig {
                gate: GateConfig { stop_speed: v, ..GateConfig::default() },
                ..LaunchConfig::default()
            };
            let e = format!("{:#}", cfg.validate().expect_err("refused"));
            assert!(e.starts_with("gate.stop_speed (--stop-speed) must be a positive number"), "{e}");
            assert!(e.ends_with(&format!("got {v}")), "{e}");
        }
        let cfg = LaunchConfig {
            gate: GateConfig { stop_turn_rate: 0.0, ..GateConfig::default() },
            ..LaunchConfig::default()
        };
        cfg.validate().expect("a stop_turn_rate of 0 ignores turning");
    }

    #[test]
    fn an_endless_or_huge_config_is_refused_without_reading_it_whole() {
        let e = LaunchConfig::load(Path::new("/dev/zero")).expect_err("endless");
        assert_eq!(format!("{e:#}"), "cannot read config /dev/zero: more than the limit of 1048576 bytes");
        let dir = tempfile::tempdir().expect("temp dir");
        let big = dir.path().join("big.toml");
        std::fs::File::create(&big).and_then(|f| f.set_len(300_000_000)).expect("sparse file");
        let e = format!("{:#}", LaunchConfig::load(&big).expect_err("too large"));
        assert!(e.ends_with("300000000 bytes, more than the limit of 1048576 bytes"), "{e}");
    }

    #[test]
    fn relative_paths_in_a_config_file_are_relative_to_the_file() {
        let dir = tempfile::tempdir().expect("temp dir");
        let file = dir.path().join("lab.toml");
        let text = "terrain = \"maps/t.txt\"\nrecord = \"run.mcap\"\nagent_bin = \"/opt/sim-agent\"\n";
        std::fs::write(&file, text).expect("write config");
        let cfg = LaunchConfig::load(&file).expect("loads");
        assert_eq!(cfg.terrain, Some(dir.path().join("maps/t.txt")));
        assert_eq!(cfg.record, Some(dir.path().join("run.mcap")));
        assert_eq!(cfg.agent_bin, Some(PathBuf::from("/opt/sim-agent")), "absolute paths stay");
    }
}
