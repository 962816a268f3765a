//! `orchestrator launch`: every robot its own agent, deployed one at a time
//! through the gate.
//!
//! Why this shape: the orchestrator knows no terrain. It hands
//! the world to the simulated agents (a lab has the real one), then sees
//! only what a lab sees — poses — and from them derives goal bearings and
//! the gate's decisions. Modules:
//!
//! * [`config`] — the TOML config (`deploy/launch.toml`) and its defaults;
//! * [`core`] — the launch itself as a deterministic state machine, no IO:
//!   inputs with their time in, outputs and the next deadline out; the
//!   gate ([`bycoms_study::gate`]), the budget, registration, settling, placement,
//!   partitions and re-sends, the dead-robot policy live there once;
//! * [`driver`] — the IO shell that feeds the core from the bus, the pose
//!   source and the agent source on the wall clock and carries out its
//!   outputs, then ends the launch in order and builds the summary;
//!   [`setup`] turns the config and the seams' properties into the core's
//!   settings;
//! * three seams, so that the core and the gate know no concrete kind:
//!   [`transport`] (the bus: iceoryx2, zenoh or in-memory), [`agents`]
//!   (where agents come from: spawned here, remote, real robots behind
//!   gateways) and [`poses`] (where the gate's poses come from: the agents'
//!   simulated mocap on the bus, NatNet, a replay);
//! * [`ports`] — the bus, with recording and bad-traffic counting;
//! * [`lab`] — a lab's world in metres from its scenario file;
//! * [`summary`] / [`progress`] / [`recording`] — the report, the terminal,
//!   the MCAP file;
//! * [`events`] — the typed JSON channels of a recording (run, events,
//!   summary), each with its JSON schema;
//! * [`observe`] — observers that see every pose and gate event, and the
//!   seam of the live view (`bycoms_orchestrator::live`, above the launch: [`run_serving`]);
//! * [`swarm_lock`] — one live launch per swarm name;
//! * [`limits`] — the open files the launch needs, checked (and the soft
//!   limit raised) before anything starts;
//!
//! The benchmarks that run whole launches (`bench scale`, `bench crowd`,
//! `bench stop`) are a crate above this one (`bycoms-bench`).

pub mod agents;
pub mod config;
pub mod control;
/// The launch core, a crate of its own (`orchestrator/launch-core/`): every
/// `crate::core::…` and `bycoms_launch::core::…` path is the crate's.
pub use bycoms_launch_core as core;
pub mod driver;
pub mod events;
pub mod faults;
#[cfg(any(test, feature = "testing"))]
pub mod harness;
pub mod lab;
pub mod limits;
pub mod observe;
pub mod ports;
pub mod poses;
pub mod progress;
pub mod recording;
pub mod ros2;
pub mod ros2_graph;
pub mod ros2_stop;
pub mod setup;
pub mod status;
pub mod summary;
pub mod swarm_lock;
pub mod transport;
mod world;

#[doc(inline)]
pub use self::core::LaunchCore;
pub use agents::executable::{agent_command, AGENT_BIN_ENV};
pub use agents::spawned::AgentCommand;
pub use config::{Clock, LaunchConfig, Missing, OnDeath};
pub use summary::{Outcome, RobotEnd, Summary};
pub use world::{SimArena, World};

use anyhow::{Context, Result};
use bycoms_protocol::bus::zenoh::clock::ClockServer;
use bycoms_protocol::bus::zenoh::settings::SettingsServer;
use bycoms_protocol::bus::zenoh::ZenohBus;
use bycoms_protocol::Swarm;
use ports::Ports;
use recording::Recording;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use transport::SharedBus;

/// The process-wide Ctrl-C flag (`bycoms_runtime::interrupt`: one handler per
/// process, shared by every command and the agents' lifeline).
pub fn interrupt_flag() -> Arc<AtomicBool> {
    bycoms_runtime::interrupt::flag_or_default()
}

/// Runs one launch to its end. Errors before the first agent starts are
/// returned; anything after ends in the summary (outcome `error`). A
/// config that asks for a live view (`serve`) needs [`run_serving`].
pub fn run(cfg: LaunchConfig, world: World, agent: AgentCommand) -> Result<Summary> {
    run_serving(cfg, world, agent, None)
}

/// [`run`], with the live view `serve` starts when the config asks for one
/// (`serve = ADDR`; `orchestrator launch` passes `bycoms_orchestrator::live::serve`,
/// which sits above the launch). A config that asks for a view is refused
/// without `serve`, before anything starts.
pub fn run_serving(
    cfg: LaunchConfig,
    world: World,
    agent: AgentCommand,
    serve: Option<observe::Serve>,
) -> Result<Summary> {
    let begun = std::time::Instant::now();
    cfg.validate()?;
    lab::check_sim_speed(cfg.sim_speed, &world, cfg.robots)?;
    if cfg.serve.is_some() && serve.is_none() {
        anyhow::bail!(
            "this launch has no live view to serve (`serve`): `orchestrator launch --serve` has one"
        );
    }
    bycoms_runtime::cli::quiet_iceoryx2();
    let swarm_name = cfg.swarm.clone().unwrap_or_else(|| format!("launch-{}", std::process::id()));
    let swarm = Swarm::new(&swarm_name).with_context(|| format!("bad swarm name {swarm_name:?}"))?;
    // Enough open files for every port of the busiest process, or a clear no.
    let files = limits::files_needed(cfg.robots, cfg.transport.kind);
    limits::ensure_open_files(files, cfg.robots).map_err(bycoms_runtime::exit::usage)?;
    // Held until the launch has ended (dropped last): one live launch per swarm.
    let _swarm_lock = swarm_lock::SwarmLock::for_launch(&swarm_name)?;
    // The file (run metadata, scene world) and the picture's trace, if asked for.
    // The run's one scene (for the file and the live view), fed as messages are recorded.
    let scene = Recording::scene_for(&swarm_name, &world, &cfg);
    let recording = Recording::start(&swarm_name, &world, &cfg, scene.clone())?;
    // `_presence`: the orchestrator's zenoh liveliness token, held to the end.
    let transport::Opened { bus, endpoints, links, presence: _presence, zenoh } =
        transport::open(&cfg.transport, &cfg.faults, cfg.robots, &swarm_name)?;
    if let Some(z) = &zenoh {
        transport::check_connected(z, &cfg.transport.connect, connect_needed_by(&cfg))?;
    }
    let bus: SharedBus = bus;
    let (ros2_settings, ros2_session) = ros2_graph::for_launch(&cfg, zenoh.as_ref())?;
    let graph = ros2_session.as_ref().map(|s| (&ros2_settings, s));
    let simulated = world.simulated.as_ref().map(|a| a.members.as_slice()).unwrap_or_default();
    let pose_source = poses::open(&cfg.mocap, cfg.robots, &bus, swarm, graph, simulated)?;
    let mut ports =
        Ports::open(bus, swarm, cfg.robots, recording).context("cannot open the orchestrator's ports")?;
    let live =
        observe_run(&mut ports, &cfg, &world, &swarm_name, scene.as_ref(), serve, ros2_session.as_ref())?;
    let joining = setup::joining(&cfg, swarm_name, endpoints.clone());
    let run = setup::run_settings(&cfg, &world);
    let (settings_served, _clock_served) = serve_over_zenoh(zenoh.as_ref(), &swarm, &run, cfg.robots)?;
    let agents = cfg.agents.open(agent, links, ros2_graph::for_agents(&ros2_settings, &endpoints))?;
    let control =
        control::Control::serve(swarm.as_str(), zenoh.as_ref()).context("cannot serve status and stop")?;
    // `--ros2`: the stop service, held to the end; its calls are stop questions.
    // On the ROS 2 session (the lab's router, or the launch's own), as the topics.
    let _ros2_stop = match (&cfg.ros2, &ros2_session) {
        (Some(ros2), Some(session)) => Some(ros2_stop::Ros2Stop::open(ros2, session, control.sender())?),
        _ => None,
    };
    let stop = interrupt_flag();
    stop.store(false, Ordering::SeqCst);
    let driver = driver::Driver::new(driver::Parts {
        cfg,
        world,
        ports,
        agents,
        pose_source,
        joining,
        run,
        stop,
        begun,
        endpoints,
        settings: settings_served,
        control: Some(control),
    });
    let summary = driver.run();
    bycoms_runtime::cli::result_decided();
    if let Some(live) = live {
        live.end(&summary);
    }
    Ok(summary)
}

/// What of the launch needs its `--connect` endpoints reached, in words:
/// `--ros2` over the launch's own session (the ROS 2 graph is there), or
/// agents started elsewhere (they may reach the launch only through them).
fn connect_needed_by(cfg: &LaunchConfig) -> Option<&'static str> {
    if cfg.ros2.as_ref().is_some_and(|r| r.router.is_none()) {
        Some("--ros2 (the ROS 2 graph is reached through it)")
    } else if !cfg.agents.started_here() {
        Some("agents started elsewhere (they may reach this launch only through it)")
    } else {
        None
    }
}

/// The launch's observers, each told the run's world before any agent
/// starts: the live view when the config asks for one (returned, to be
/// told the summary at the end) and the ROS 2 output (`--ros2`).
fn observe_run(
    ports: &mut Ports,
    cfg: &LaunchConfig,
    world: &World,
    swarm_name: &str,
    scene: Option<&bycoms_record::scene::SharedScene>,
    serve: Option<observe::Serve>,
    ros2_session: Option<&zenoh::Session>,
) -> Result<Option<Box<dyn observe::View>>> {
    let live = match (&cfg.serve, serve) {
        (Some(addr), Some(start)) => Some(start(addr)?),
        _ => None,
    };
    if let Some(live) = &live {
        bycoms_runtime::logging::status_line(&live.banner());
        ports.observers.push(live.observer());
    }
    if let (Some(ros2), Some(session)) = (&cfg.ros2, ros2_session) {
        ports.observers.push(Box::new(ros2::Ros2Bridge::open(ros2, session, cfg.robots)?));
    }
    ports.observers.iter_mut().for_each(|o| o.world(swarm_name, world, cfg, scene));
    ports.show_scene();
    Ok(live)
}

/// Over zenoh, what the launch serves to the end: the run's settings, for
/// agents started elsewhere with only where to connect, their swarm and
/// robot id; and the orchestrator's clock, which agents and `doctor
/// --connect` measure their offset against (`orchestrator/launch-core/src/clocks.rs`).
fn serve_over_zenoh(
    zenoh: Option<&ZenohBus>,
    swarm: &Swarm,
    settings: &bycoms_sim_agent::RunSettings,
    robots: u32,
) -> Result<(Option<SettingsServer>, Option<ClockServer>)> {
    let Some(z) = zenoh else { return Ok((None, None)) };
    let served =
        z.serve_settings(swarm, settings.encode(), robots).context("cannot serve the run's settings")?;
    tracing::info!(
        key = swarm.settings().as_str(),
        fingerprint = format_args!("{:016x}", settings.fingerprint()),
        "zenoh: the run's settings are served to agents"
    );
    let clock = z.serve_clock(swarm).context("cannot serve the orchestrator's clock")?;
    Ok((Some(served), Some(clock)))
}
