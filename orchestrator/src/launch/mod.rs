//! `orchestrator launch`: every robot its own agent process, deployed one at
//! a time through the gate, over iceoryx2 shared memory.
//!
//! Why this shape (design §5): the orchestrator knows no terrain. It hands
//! the world to the simulated agents (a lab has the real one), then sees
//! only what a lab sees — poses — and from them derives goal bearings and
//! the gate's decisions. Modules:
//!
//! * [`config`] — the TOML config (`deploy/launch.toml`) and its defaults;
//! * [`gate`] — the motion test: stopped, arrived or stuck, from poses;
//! * [`supervise`] — agent processes: spawn, poll, heartbeats, kill;
//! * [`ports`] — the bus, with recording and bad-traffic counting;
//! * [`engine`] — the launch's state and message handling;
//! * [`deploy`] / [`decide`] — opening and closing a robot's deployment;
//! * [`lockstep`] / [`realtime`] — the two clocks;
//! * [`finish`] / [`summary`] / [`progress`] / [`recording`] — the ending,
//!   the report, the terminal, the MCAP file;
//! * [`swarm_lock`] — one live launch per swarm name;
//! * [`scale`] — the real-time scale benchmark (`orchestrator bench scale`).

pub mod config;
pub mod decide;
pub mod deploy;
pub mod engine;
pub mod finish;
pub mod gate;
pub mod lockstep;
pub mod ports;
pub mod progress;
pub mod realtime;
pub mod recording;
pub mod scale;
pub mod summary;
pub mod supervise;
pub mod swarm_lock;

pub use config::{Clock, LaunchConfig, OnDeath};
pub use engine::World;
pub use summary::{Outcome, RobotEnd, Summary};
pub use supervise::AgentCommand;

use anyhow::{Context, Result};
use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::Swarm;
use bycoms_sim::agent_process::{ipc_config, AgentArgs, ClockKind};
use engine::Launch;
use ports::Ports;
use recording::Recording;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use supervise::Supervisor;

/// Environment variable naming the agent executable.
pub const AGENT_BIN_ENV: &str = "BYCOMS_SIM_AGENT";

/// Which executable runs the agents: `explicit` (the `--agent-bin` flag),
/// else `$BYCOMS_SIM_AGENT`, else `configured` (the config file), else
/// `sim-agent` next to this executable, else this executable itself as
/// `orchestrator sim-agent` (so `cargo run --bin orchestrator`, which builds
/// no other binary, still works).
pub fn agent_command(explicit: Option<&Path>, configured: Option<&Path>) -> Result<AgentCommand> {
    let chosen = explicit
        .map(Path::to_path_buf)
        .or_else(|| std::env::var_os(AGENT_BIN_ENV).map(PathBuf::from))
        .or_else(|| configured.map(Path::to_path_buf));
    if let Some(program) = chosen {
        return Ok(AgentCommand { program, prefix: Vec::new() });
    }
    let me = std::env::current_exe().context("cannot locate the orchestrator executable")?;
    let beside = me.with_file_name(format!("sim-agent{}", std::env::consts::EXE_SUFFIX));
    if beside.is_file() {
        return Ok(AgentCommand { program: beside, prefix: Vec::new() });
    }
    Ok(AgentCommand { program: me, prefix: vec!["sim-agent".into()] })
}

/// The process-wide Ctrl-C flag (the handler is installed once).
pub fn interrupt_flag() -> Arc<AtomicBool> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let handler_flag = Arc::clone(&flag);
        // Another handler (a second subcommand in-process) only means Ctrl-C
        // keeps its default effect.
        let _ = ctrlc::set_handler(move || handler_flag.store(true, Ordering::SeqCst));
        flag
    })
    .clone()
}

/// Runs one launch to its end. Errors before the first agent starts are
/// returned; anything after ends in the summary (outcome `error`).
pub fn run(cfg: LaunchConfig, world: World, agent: AgentCommand) -> Result<Summary> {
    cfg.validate()?;
    bycoms_sim::agent_process::cli::quiet_iceoryx2();
    let swarm_name = cfg.swarm.clone().unwrap_or_else(|| format!("launch-{}", std::process::id()));
    let swarm = Swarm::new(&swarm_name).with_context(|| format!("bad swarm name {swarm_name:?}"))?;
    // Held until the launch has ended (dropped last): one live launch per swarm.
    let _swarm_lock = swarm_lock::SwarmLock::acquire(&swarm_name)?;
    let recording = match &cfg.record {
        Some(path) => Recording::create(path)?,
        None => Recording::off(),
    };
    let mut ipc = ipc_config(cfg.robots);
    ipc.cleanup_on_start = true;
    ipc.node_name = Some(format!("bycoms-{swarm_name}-orchestrator"));
    let bus = IpcBus::new(ipc).context("cannot open the iceoryx2 bus")?;
    let mut ports = Ports::open(bus, swarm, recording).context("cannot open the orchestrator's ports")?;
    let meta =
        serde_json::json!({ "terrain": world.name, "start": world.start, "goal": world.goal, "config": cfg });
    ports.recording.json(&format!("bycoms/{swarm_name}/run"), "bycoms.LaunchConfig", &meta);
    let template = AgentArgs {
        swarm: swarm_name,
        robot: 1,
        terrain: PathBuf::from("-"),
        eps: cfg.eps,
        noise: cfg.noise,
        seed: cfg.seed,
        clock: match cfg.clock {
            Clock::Lockstep => ClockKind::Lockstep,
            Clock::Realtime => ClockKind::Realtime,
        },
        speed: cfg.speed,
        swarm_size: Some(cfg.robots),
        peers: None,
        parent_pid: Some(std::process::id() as i32),
        heartbeat_ms: (cfg.supervision.heartbeat_interval * 1000.0).round().max(1.0) as u64,
    };
    let sup = Supervisor::new(
        agent,
        LaunchConfig::secs(cfg.supervision.register_timeout),
        LaunchConfig::secs(cfg.supervision.heartbeat_timeout),
    );
    let stop = interrupt_flag();
    stop.store(false, Ordering::SeqCst);
    let clock = cfg.clock;
    let mut launch = Launch::new(cfg, world, ports, sup, template, stop);
    let result = match clock {
        Clock::Lockstep => launch.run_lockstep(),
        Clock::Realtime => launch.run_realtime(),
    };
    Ok(launch.finish(result))
}
