//! `orchestrator launch`: one robot per agent process, deployed one at a
//! time through the gate (see `bycoms_launch`).
//!
//! This file only merges the settings (defaults < `--config` < flags),
//! loads the world, runs the launch and turns its summary into output and
//! an exit code.

use anyhow::Result;
use bycoms_lab::robots::RobotsFile;
use bycoms_launch::config::{AgentSourceKind, GatewaysAt, Transport};
use bycoms_launch::{self as launch, Clock, LaunchConfig, Missing, OnDeath, Outcome, World};
use bycoms_runtime::exit;
use bycoms_runtime::out::{Kind, Outputs};
use bycoms_sim::terrain::to_text;
use bycoms_study::scenario::{self, TerrainSource};
use std::path::PathBuf;

/// Declares `launch`'s flags once: each field is a clap flag (its doc
/// comment is its `--help`) and, after `=>`, how it lands on its config key:
/// `set key` (a given value replaces the key's), `some key` (the key is an
/// option), `list key` (given values replace the key's list), `by_hand key`
/// (merged by hand in [`Args::config`], as `--scenario`, which also clears
/// the terrain). The macro writes the struct, [`Args::overlay`], which
/// merges every such flag over the file's values, and [`Args::keyed`]: from
/// it `--help` prints each flag's default, read from
/// [`LaunchConfig::default`], so a default is written once. Flags without
/// `=>` (switches that are not keys, `--config`, `--agent-bin`, ...) are
/// handled by hand in [`Args::config`].
macro_rules! launch_flags {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $($(#[$field_meta:meta])* pub $field:ident: $ty:ty $(=> $how:ident $($key:ident).+)?,)*
        }
    ) => {
        $(#[$meta])*
        pub struct $name {
            $($(#[$field_meta])* pub $field: $ty,)*
        }

        impl $name {
            /// The flags given, over `cfg` (the defaults and the file's values).
            fn overlay(&self, cfg: &mut LaunchConfig) {
                $($(merge!($how, cfg.$($key).+, self.$field);)?)*
            }

            /// Each flag that sets a config key (its clap id, `stop_speed`),
            /// with the key (`gate.stop_speed`).
            fn keyed() -> Vec<(&'static str, String)> {
                vec![$($((stringify!($field), stringify!($($key).+).replace(' ', "")),)?)*]
            }
        }
    };
}

/// One flag over one config key (see [`launch_flags`]).
macro_rules! merge {
    (set, $slot:expr, $flag:expr) => {
        if let Some(v) = &$flag {
            $slot = v.clone();
        }
    };
    (some, $slot:expr, $flag:expr) => {
        if $flag.is_some() {
            $slot.clone_from(&$flag);
        }
    };
    (list, $slot:expr, $flag:expr) => {
        if !$flag.is_empty() {
            $slot.clone_from(&$flag);
        }
    };
    (by_hand, $slot:expr, $flag:expr) => {};
}

/// What `--help` adds to each flag that sets a config key: ` [default: v]`,
/// `v` the key's value in [`LaunchConfig::default`] (a key whose default
/// is no value, an unset option, says its default in its own words).
fn defaults_in_help() -> impl FnMut(clap::Arg) -> clap::Arg {
    let defaults = serde_json::to_value(LaunchConfig::default()).unwrap_or_default();
    let keyed = Args::keyed();
    move |arg| {
        let key = keyed.iter().find(|(id, _)| *id == arg.get_id().as_str()).map(|(_, key)| key);
        let pointer = key.map(|key| format!("/{}", key.replace('.', "/")));
        match pointer.and_then(|p| shown(defaults.pointer(&p)?)) {
            Some(value) => with_default(arg, &value),
            None => arg,
        }
    }
}

/// A default as `--help` prints it (`3`, `0.05`, `lockstep`, `tcp/127.0.0.1:0`).
fn shown(value: &serde_json::Value) -> Option<String> {
    use serde_json::Value;
    match value {
        Value::Number(n) => Some(n.as_f64().map_or_else(|| n.to_string(), |f| f.to_string())),
        Value::String(s) => Some(s.clone()),
        Value::Bool(b) => Some(b.to_string()),
        Value::Array(items) if !items.is_empty() => {
            Some(items.iter().filter_map(shown).collect::<Vec<_>>().join(", "))
        }
        Value::Array(_) | Value::Null | Value::Object(_) => None,
    }
}

/// `arg` with ` [default: value]` after its help (and its long help).
fn with_default(arg: clap::Arg, value: &str) -> clap::Arg {
    let append =
        |help: &clap::builder::StyledStr| format!("{} [default: {value}]", help.to_string().trim_end());
    let help = arg.get_help().map(append);
    let long = arg.get_long_help().map(append);
    let arg = match help {
        Some(help) => arg.help(help),
        None => arg,
    };
    match long {
        Some(long) => arg.long_help(long),
        None => arg,
    }
}

launch_flags! {
/// Deploy robots one at a time as separate agent processes (over iceoryx2 or zenoh).
///
/// With no options, runs the built-in `long-obstacle` scenario (the paper's
/// three-robot experiment) with 3 robots, ε = 3, on the lockstep clock:
/// robots 1 and 2 get stuck, robot 3 goes around their fields to the goal.
/// Every option can also be set in a config file (see deploy/launch.toml);
/// flags override the file. Exit codes: 0 a robot arrived, 3 none arrived,
/// 1 error, 130 interrupted.
#[derive(Debug, clap::Args)]
#[command(mut_args = defaults_in_help())]
pub struct Args {
    /// Robots available (deployed one at a time).
    #[arg(long)]
    pub robots: Option<u32> => set robots,
    /// Terrain file in the text format (overrides --scenario).
    #[arg(long, value_name = "FILE", conflicts_with = "scenario")]
    pub terrain: Option<PathBuf> => some terrain,
    /// Built-in scenario.
    #[arg(long, value_parser = scenario::names())]
    pub scenario: Option<String> => by_hand scenario,
    /// Circumferential radius ε in cells.
    #[arg(long, allow_negative_numbers = true)]
    pub eps: Option<f64> => set eps,
    /// Sensing noise on (`--noise`) or off (`--noise false`).
    #[arg(long, num_args = 0..=1, default_missing_value = "true", value_name = "BOOL")]
    pub noise: Option<bool> => set noise,
    /// Run seed of the robots' noise streams.
    #[arg(long)]
    pub seed: Option<u64> => set seed,
    /// Clock: lockstep (fast, bit-identical to `simulate`) or realtime.
    #[arg(long, value_enum)]
    pub clock: Option<Clock> => set clock,
    /// Real-time speed-up: 10 Hz × speed, at most 1000 (a period of 100 µs).
    #[arg(long, allow_negative_numbers = true)]
    pub speed: Option<f64> => set speed,
    /// A mixed swarm's simulated robots run this many times faster than
    /// --speed (real-time clock); only one robot moves at a time, so every
    /// real robot stands while a simulated one moves.
    #[arg(long, value_name = "FACTOR", allow_negative_numbers = true)]
    pub sim_speed: Option<f64> => set sim_speed,
    /// Simulated time budget, seconds of robot motion.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub time_limit: Option<f64> => set time_limit,
    /// Arrival radius around the goal.
    #[arg(long)]
    pub goal_radius: Option<f64> => set goal_radius,
    /// Swarm name (topic namespace) [default: `launch-<pid>`].
    #[arg(long)]
    pub swarm: Option<String> => some swarm,
    /// Record every bus message (raw bytes) and decoded channels Foxglove shows (scene, frames,
    /// log, per-robot JSON) to this MCAP file [default: none]. Lockstep runs are logged at
    /// simulated time. An existing recording is replaced only with --force; a file that is
    /// not an MCAP recording is never overwritten.
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<PathBuf> => some record,
    /// Let --record replace an existing MCAP recording and --svg an existing
    /// SVG picture (never another kind of file, never an input).
    #[arg(long)]
    pub force: bool,
    /// Draw the run as an SVG snapshot (trajectories, beacons, ε circles) when it ends [default: none].
    /// An existing picture is replaced only with --force; checked before anything starts.
    #[arg(long, value_name = "FILE.svg")]
    pub svg: Option<PathBuf> => some svg,
    /// Serve the live view on host:port: Foxglove connects to ws://host:port,
    /// a browser opens http://host:port/ (port 0 picks a free port; printed).
    #[arg(long, value_name = "HOST:PORT")]
    pub serve: Option<String> => some serve,
    /// Print the summary as JSON on stdout; its one-line form moves to stderr, with the progress.
    #[arg(long)]
    pub json: bool,
    /// Config file (TOML; every key documented in deploy/launch.toml).
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<PathBuf>,
    /// Agent executable [default: $BYCOMS_SIM_AGENT, else sim-agent next to orchestrator].
    #[arg(long, value_name = "FILE")]
    pub agent_bin: Option<PathBuf>,
    /// Gate: a robot still this long (simulated s) has stopped.
    #[arg(long, value_name = "SECONDS")]
    pub dwell: Option<f64> => set gate.dwell,
    /// Gate: slower than this (cells/s) is still...
    #[arg(long)]
    pub stop_speed: Option<f64> => set gate.stop_speed,
    /// ...if it also turns slower than this (rad/s; 0 ignores turning).
    #[arg(long)]
    pub stop_turn_rate: Option<f64> => set gate.stop_turn_rate,
    /// Do not start the next agents (one; four in lockstep) while the
    /// current robot moves.
    #[arg(long)]
    pub no_prespawn: bool,
    /// Publish the run into a ROS 2 graph over rmw_zenoh: each robot's pose,
    /// path and state, /tf, /clock, the map, /tf_static, beacons (these three
    /// latched for late joiners), gate events and real
    /// robots' diagnostics, with node and publisher tokens (`[ros2]` in the config:
    /// domain id, namespace; default domain 0, namespace /). Needs --transport zenoh.
    #[arg(long)]
    pub ros2: bool,
    /// Join the ROS 2 graph as a zenoh client of the lab's router
    /// (`rmw_zenohd`, e.g. tcp/192.168.1.2:7447) instead of over the
    /// launch's own zenoh session (`ros2.router`); implies --ros2 and
    /// needs no --transport zenoh. No router there ends the launch before
    /// it starts; a router without ROS 2 nodes of the domain is warned about.
    #[arg(long, value_name = "ENDPOINT")]
    pub ros2_router: Option<String>,
    /// What a dead agent means.
    #[arg(long, value_enum)]
    pub on_agent_death: Option<OnDeath> => set gate.on_agent_death,
    /// A robot whose agent never registers (or, started here, dies before
    /// it registers, twice): skip it at its turn, or fail the launch.
    #[arg(long, value_enum)]
    pub missing: Option<Missing> => set supervision.missing,
    /// Seconds an agent has to register.
    #[arg(long, value_name = "SECONDS")]
    pub register_timeout: Option<f64> => set supervision.register_timeout,
    /// Seconds of silence after which a live agent counts as hung.
    #[arg(long, value_name = "SECONDS")]
    pub heartbeat_timeout: Option<f64> => set supervision.heartbeat_timeout,
    /// Remote agents: seconds one may be unreachable (its zenoh connection
    /// cut, or silent) before it counts as dead; the run waits for it
    /// meanwhile and resumes when it is back; 0: dead at once. (Was
    /// --link-grace, still accepted: "link" is the robot link.)
    #[arg(long, value_name = "SECONDS", alias = "link-grace")]
    pub unreachable_grace: Option<f64> => set supervision.unreachable_grace,
    /// The bus: ipc (iceoryx2, this host) or zenoh (tcp/quic/tls, any host).
    #[arg(long, value_enum)]
    pub transport: Option<Transport> => set transport.kind,
    /// zenoh: endpoint to listen on, tcp/HOST:PORT, or quic/HOST:PORT (tls/)
    /// with certificates; port 0 takes a free one (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String> => list transport.listen,
    /// zenoh: endpoint to connect to as well, e.g. a zenohd router (repeatable).
    /// Nothing answering at any of them within 2 s of the start is an error
    /// with --ros2 or agents started elsewhere, a warning otherwise.
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String> => list transport.connect,
    /// zenoh: a zenoh JSON5 config file read first (TLS, access control).
    #[arg(long, value_name = "FILE")]
    pub zenoh_config: Option<PathBuf> => some transport.zenoh_config,
    /// zenoh: the config file each started agent reads first, `{robot}`
    /// replaced by its id (e.g. certs/robot-{robot}.json5 from `orchestrator
    /// certs`, for quic/ and tls/ endpoints).
    #[arg(long, value_name = "FILE")]
    pub agent_zenoh_config: Option<PathBuf> => some transport.agent_zenoh_config,
    /// Where agents come from: spawned (a sim-agent per robot, here),
    /// remote (started by hand on other hosts with `sim-agent --transport
    /// zenoh --connect ...`; the launch waits for all) or real (a `gateway`
    /// gateway per robot of --robots-file).
    #[arg(long, value_enum)]
    pub agents: Option<AgentSourceKind> => set agents.source,
    /// Real robots: the lab's robots file (addresses and key files), for
    /// gateways started here.
    #[arg(long, value_name = "FILE")]
    pub robots_file: Option<PathBuf> => some agents.robots_file,
    /// Real robots: where their `gateway` processes run: here (started by the
    /// launch from --robots-file) or elsewhere (started by hand on a bridge
    /// host with `gateway --transport zenoh --connect ...`; needs --transport
    /// zenoh).
    #[arg(long, value_enum)]
    pub gateways: Option<GatewaysAt> => set agents.gateways,
    /// Real robots: the lab scenario (exp-short, exp-long or a scenario
    /// file, see deploy/lab/): start, goal and arena in metres.
    #[arg(long, value_name = "NAME|FILE")]
    pub lab_scenario: Option<String> => some agents.scenario,
}
}

impl Args {
    /// Defaults, then the config file, then the flags.
    pub fn config(&self) -> Result<LaunchConfig> {
        let mut cfg = match &self.config {
            Some(path) => LaunchConfig::load(path)?,
            None => LaunchConfig::default(),
        };
        if let Some(v) = &self.scenario {
            cfg.scenario = v.clone();
            cfg.terrain = None;
        }
        // Every flag that names its config key (`=> ...` above).
        self.overlay(&mut cfg);
        if self.no_prespawn {
            cfg.gate.prespawn = false;
        }
        if (self.ros2 || self.ros2_router.is_some()) && cfg.ros2.is_none() {
            cfg.ros2 = Some(launch::ros2::Ros2Config::default());
        }
        if let (Some(router), Some(ros2)) = (&self.ros2_router, cfg.ros2.as_mut()) {
            ros2.router = Some(router.clone());
        }
        cfg.validate()?;
        Ok(cfg)
    }
}

/// The world of a launch config.
pub fn world(cfg: &LaunchConfig) -> Result<World> {
    if let Some(lab) = &cfg.agents.scenario {
        let file = cfg.agents.robots_file.as_deref().map(RobotsFile::read).transpose()?;
        return launch::lab::lab_world(lab, cfg.robots, file.as_ref());
    }
    let source = match &cfg.terrain {
        Some(path) => TerrainSource::File(path.clone()),
        None => TerrainSource::Scenario(cfg.scenario.clone()),
    };
    let w = scenario::load(&source)?;
    World::new(
        w.name,
        to_text(&w.terrain),
        w.terrain.start(),
        w.terrain.goal(),
        bycoms_study::draw::snapshot::Unit::Cell,
    )
}

/// The launch's inputs (config, terrain, zenoh configs, robots file, lab
/// scenario file, agent binary) and outputs (`--record`, `--svg`), for the
/// overwrite rule.
fn outputs(args: &Args, cfg: &LaunchConfig) -> Outputs {
    let lab_file = cfg.agents.scenario.as_ref().map(PathBuf::from).filter(|p| p.is_file());
    let inputs = [
        &args.config,
        &cfg.terrain,
        &cfg.agent_bin,
        &args.agent_bin,
        &cfg.transport.zenoh_config,
        &cfg.transport.agent_zenoh_config,
        &cfg.agents.robots_file,
        &lab_file,
    ];
    let mut rule = inputs.into_iter().flatten().fold(Outputs::new(args.force), Outputs::input);
    if let Some(path) = &cfg.record {
        rule = rule.output("--record", path, Kind::Recording);
    }
    if let Some(path) = &cfg.svg {
        rule = rule.output("--svg", path, Kind::Svg);
    }
    rule
}

pub fn run(args: Args) -> Result<i32> {
    let cfg = args.config()?;
    // Refused before anything starts (the rule: `bycoms_runtime::out::files`).
    outputs(&args, &cfg).check().map_err(bycoms_runtime::out::usage_unless_io)?;
    let world = world(&cfg)?;
    let agent = launch::agent_command(args.agent_bin.as_deref(), cfg.agent_bin.as_deref())?;
    let cfg_svg = cfg.svg.clone();
    let summary = launch::run_serving(cfg, world, agent, Some(crate::live::serve))?;
    if args.json {
        bycoms_runtime::logging::status_line(&summary.line());
        bycoms_runtime::outln!("{}", serde_json::to_string_pretty(&summary)?)?;
    } else {
        bycoms_runtime::outln!("{}", summary.text())?;
        if let Some(e) = &summary.error {
            tracing::error!("{e}");
        }
    }
    // The result is printed first: a picture that cannot be written loses nothing else.
    let mut code = None;
    if let Some(path) = &cfg_svg {
        let write = |svg: &str| bycoms_runtime::out::write(path, Kind::Svg, args.force, svg.as_bytes());
        match summary.picture.as_deref().map(write) {
            Some(Ok(())) => bycoms_runtime::logging::status_line(&format!("picture: {}", path.display())),
            Some(Err(e)) => {
                tracing::error!("no picture written: {e}");
                code = Some(exit::ERROR);
            }
            None => {
                tracing::error!("no picture of the run was made");
                code = Some(exit::ERROR);
            }
        }
    }
    Ok(code.unwrap_or(match summary.outcome {
        Outcome::Arrived => exit::SUCCESS,
        Outcome::Interrupted => exit::INTERRUPTED,
        Outcome::Error => exit::ERROR,
        Outcome::RobotsExhausted | Outcome::TimeLimit => exit::NOT_ARRIVED,
    }))
}

#[cfg(test)]
mod tests {
    use bycoms_launch::{Clock, LaunchConfig};
    use clap::Parser;

    /// `orchestrator launch`'s flags alone (the command line around them is
    /// `commands`'s, which uses this file).
    #[derive(Parser)]
    #[command(name = "launch")]
    struct Cli {
        #[command(flatten)]
        args: super::Args,
    }

    fn config(args: &[&str]) -> anyhow::Result<LaunchConfig> {
        Cli::try_parse_from([&["launch"], args].concat())?.args.config()
    }

    #[test]
    fn flags_override_the_config_file_which_overrides_the_defaults() {
        assert_eq!(config(&[]).unwrap(), LaunchConfig::default());
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("launch.toml");
        std::fs::write(&file, "eps = 2.0\nrobots = 7\nnoise = true\n[gate]\ndwell = 5.0\n").unwrap();
        let path = file.to_str().unwrap();
        let from_file = config(&["--config", path]).unwrap();
        assert_eq!(
            (from_file.eps, from_file.robots, from_file.noise, from_file.gate.dwell),
            (2.0, 7, true, 5.0)
        );
        let both =
            config(&["--config", path, "--eps", "4", "--noise", "false", "--clock", "realtime"]).unwrap();
        assert_eq!((both.eps, both.robots, both.noise, both.clock), (4.0, 7, false, Clock::Realtime));
        let zenoh = config(&["--transport", "zenoh", "--listen", "tcp/0.0.0.0:7447"]).unwrap();
        assert_eq!(zenoh.transport.kind, bycoms_launch::config::Transport::Zenoh);
        assert_eq!(zenoh.transport.listen, ["tcp/0.0.0.0:7447"]);
    }

    /// Every default `launch --help` prints is the real one: giving the
    /// printed value explicitly changes nothing. (`deploy/launch.toml` is
    /// checked against the same defaults in `launch::config`, so the three
    /// agree.) Defaults that are prose, not a value, are named here.
    #[test]
    fn the_defaults_help_prints_are_the_defaults() {
        use clap::CommandFactory;
        const PROSE: [&str; 4] = ["swarm", "record", "svg", "agent-bin"];
        let launch = Cli::command();
        let defaults = LaunchConfig::default();
        let (mut checked, mut prose) = (Vec::new(), Vec::new());
        for arg in launch.get_arguments() {
            let Some(long) = arg.get_long() else { continue };
            let help = arg.get_long_help().or(arg.get_help()).map(ToString::to_string).unwrap_or_default();
            let help = help.split_whitespace().collect::<Vec<_>>().join(" ");
            let Some(value) = help.split("[default: ").nth(1).and_then(|r| r.split(']').next()) else {
                continue;
            };
            if PROSE.contains(&long) {
                prose.push(long.to_string());
                continue;
            }
            let flag = format!("--{long}");
            let given = config(&[flag.as_str(), value]).unwrap_or_else(|e| {
                panic!("--help says {flag} defaults to {value:?}, which does not parse: {e:#}")
            });
            assert_eq!(given, defaults, "--help says {flag} defaults to {value:?}, which is not the default");
            checked.push(long.to_string());
        }
        assert_eq!(prose, PROSE, "the prose defaults are the ones named");
        assert!(checked.len() >= 15, "the defaults of --help are checked: {checked:?}");
    }

    #[test]
    fn ros2_is_a_zenoh_launchs_and_its_namespace_is_checked() {
        let err = format!("{:#}", config(&["--ros2"]).unwrap_err());
        assert!(err.contains("--ros2") && err.contains("zenoh"), "{err}");
        let zenoh = ["--ros2", "--transport", "zenoh", "--listen", "tcp/127.0.0.1:0"];
        assert_eq!(config(&zenoh).unwrap().ros2, Some(bycoms_launch::ros2::Ros2Config::default()));
        let dir = tempfile::tempdir().expect("temp dir");
        let file = dir.path().join("launch.toml");
        std::fs::write(&file, "[transport]\nkind = \"zenoh\"\n[ros2]\nnamespace = \"lab\"\n").expect("write");
        let err = format!("{:#}", config(&["--config", file.to_str().expect("utf-8")]).unwrap_err());
        assert!(err.contains("ros2.namespace"), "{err}");
    }

    /// `--ros2-router` joins the lab's graph as a client: no zenoh
    /// transport needed, the endpoint checked; a ROS 2 mocap source needs a
    /// session too, and may not read the launch's own pose topics.
    #[test]
    fn a_ros2_router_needs_no_zenoh_transport_and_ros2_mocap_needs_a_graph() {
        let cfg = config(&["--ros2-router", "tcp/127.0.0.1:7447"]).unwrap();
        assert_eq!(cfg.ros2.and_then(|r| r.router).as_deref(), Some("tcp/127.0.0.1:7447"));
        let err = format!("{:#}", config(&["--ros2-router", "127.0.0.1:7447"]).unwrap_err());
        assert!(err.contains("ros2.router"), "{err}");
        // QUIC needs certificates the ROS 2 session cannot be given: said
        // at once, not after zenoh's 10 s handshake timeout.
        let err = config(&["--ros2-router", "quic/127.0.0.1:7447"]).unwrap_err();
        assert_eq!(bycoms_runtime::exit::code_of(&err), bycoms_runtime::exit::USAGE);
        let err = format!("{err:#}");
        assert!(err.contains("ros2.router quic/127.0.0.1:7447 (--ros2-router): a secured endpoint"), "{err}");
        let dir = tempfile::tempdir().expect("temp dir");
        let file = dir.path().join("launch.toml");
        let mocap = "robots = 1\n[mocap]\nsource = \"ros2\"\n[mocap.ros2.topics]\n\"/robot_1/pose\" = 1\n\
                     [mocap.ros2.tracker]\nmax_speed = 1.0\njump_slack = 0.1\nlost_after_us = 500000\n";
        std::fs::write(&file, mocap).expect("write");
        let path = file.to_str().expect("utf-8");
        let err = format!("{:#}", config(&["--config", path]).unwrap_err());
        assert!(err.contains("needs a zenoh session") && err.contains("ros2.router"), "{err}");
        let err =
            format!("{:#}", config(&["--config", path, "--ros2-router", "tcp/127.0.0.1:7447"]).unwrap_err());
        assert!(err.contains("/robot_1/pose is a topic this launch publishes its own poses on"), "{err}");
        std::fs::write(&file, mocap.replace("/robot_1/pose", "/vrpn_mocap/robot1/pose")).expect("write");
        config(&["--config", path, "--ros2-router", "tcp/127.0.0.1:7447"]).expect("a driver's topic");
    }

    /// Each flag declared with its config key names a real key (its path in
    /// the config as serialised: the TOML key), and setting the flag changes
    /// that key and no other.
    #[test]
    fn every_flag_names_its_config_key() {
        let defaults = serde_json::to_value(LaunchConfig::default()).expect("serialises");
        let keys = super::Args::keyed();
        assert!(keys.len() >= 30, "{keys:?}");
        for (field, key) in keys {
            let pointer = format!("/{}", key.replace('.', "/"));
            assert!(defaults.pointer(&pointer).is_some(), "--{field}: no config key {key}");
        }
        let set = config(&["--dwell", "7", "--listen", "tcp/127.0.0.1:1", "--missing", "fail"]).unwrap();
        let mut want = LaunchConfig::default();
        (want.gate.dwell, want.transport.listen) = (7.0, vec!["tcp/127.0.0.1:1".into()]);
        want.supervision.missing = bycoms_launch::Missing::Fail;
        assert_eq!(set, want);
    }

    #[test]
    fn bad_values_and_unknown_keys_are_errors() {
        assert!(format!("{:#}", config(&["--eps", "-1"]).unwrap_err()).contains("eps"));
        for bad in ["8765", ":8765", "localhost:http", "127.0.0.1:70000"] {
            assert!(format!("{:#}", config(&["--serve", bad]).unwrap_err()).contains("serve"), "{bad}");
        }
        assert_eq!(config(&["--serve", "127.0.0.1:0"]).unwrap().serve.as_deref(), Some("127.0.0.1:0"));
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("bad.toml");
        std::fs::write(&file, "[gate]\nprespwan = false\n").unwrap();
        let err = config(&["--config", file.to_str().unwrap()]).unwrap_err();
        assert!(format!("{err:#}").contains("prespwan"), "{err:#}");
    }
}
