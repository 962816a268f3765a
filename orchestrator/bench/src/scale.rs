//! The real-time scale benchmark: how many agent processes keep their 10 Hz.
//!
//! Why without the gate: the question is what the machine sustains, not
//! what a run needs (a run moves one robot at a time). `N` agents are
//! started on the real-time clock, all deployed within one period (their
//! phases spread, as robots deployed one by one) on an empty arena
//! with no peers (so each step is the controller plus its body, as in a
//! run), and watched for a while. A period counts as missed when an agent's
//! pose frame number jumps (the agent skips a period whose deadline passed
//! before it got to it — as a real robot would). Memory is read from
//! `/proc/<pid>/status` (RSS, split into anonymous, file and shared-memory
//! pages) and `/proc/<pid>/smaps_rollup` (PSS: shared pages divided among
//! the processes sharing them, the fair per-agent share), by the benches'
//! one reader of `/proc` ([`super::procfs`]).

use super::procfs::{memory, Memory};
use anyhow::{bail, Context, Result};
use bycoms_launch::agents::spawned::{AgentCommand, Spawned};
use bycoms_launch::agents::AgentSource;
use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::bus::{BusExt, TypedFanIn, TypedPublisher, TypedSubscriber};
use bycoms_protocol::msg::{Deploy, FromAgent, GoalBearing, Pose, ToAgent};
use bycoms_protocol::{RobotId, Swarm};
use bycoms_runtime::{ipc_config, BusArgs, Transport};
use bycoms_sim::terrain::{to_text, Terrain};
use bycoms_sim_agent::{AgentArgs, Clock, DEFAULT_SETTINGS_TIMEOUT_S};
use serde::Serialize;
use std::collections::BTreeSet;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

type Bus = IpcBus;

/// Agents started at a time.
const BATCH: u32 = 100;
type Sub<M> = TypedSubscriber<<Bus as bycoms_protocol::bus::Bus>::Subscriber, M>;
type Pub<M> = TypedPublisher<<Bus as bycoms_protocol::bus::Bus>::Publisher, M>;

/// What the scale benchmark measured.
#[derive(Clone, Debug, Serialize)]
pub struct ScaleReport {
    pub agents: u32,
    pub seconds: f64,
    pub periods: u64,
    pub missed: u64,
    pub missed_percent: f64,
    pub agents_with_misses: u32,
    pub mean: Memory,
    pub max_rss_kb: u64,
    pub max_pss_kb: u64,
    pub start_s: f64,
}

/// Runs `agents` real-time agents at 10 Hz × `speed` for `seconds`.
pub fn run(agent: AgentCommand, agents: u32, seconds: f64, speed: f64) -> Result<ScaleReport> {
    if agents == 0 || !(seconds.is_finite() && seconds > 0.0) {
        return Err(bycoms_runtime::exit::usage("--agents and --seconds must be positive"));
    }
    bycoms_runtime::check_speed(speed)
        .map_err(|e| bycoms_runtime::exit::usage(format!("bad --speed: {e}")))?;
    let files = bycoms_launch::limits::files_needed(agents, Transport::Ipc);
    bycoms_launch::limits::ensure_open_files(files, agents).map_err(bycoms_runtime::exit::usage)?;
    let stop = bycoms_launch::interrupt_flag();
    bycoms_runtime::cli::quiet_iceoryx2();
    let name = format!("scale-{}", std::process::id());
    let swarm = Swarm::new(&name)?;
    let mut cfg = ipc_config(agents);
    cfg.cleans_dead_nodes = true;
    let bus = IpcBus::new(cfg).context("cannot open the iceoryx2 bus")?;
    let topics: Vec<_> = (1..=agents).map(|id| swarm.from_agent(RobotId(id))).collect();
    let reports: TypedFanIn<<Bus as bycoms_protocol::bus::Bus>::FanIn, FromAgent> =
        bus.typed_fan_in(&topics)?;
    let mut commands: Vec<Pub<ToAgent>> = Vec::new();
    let mut poses: Vec<Sub<Pose>> = Vec::new();
    for id in 1..=agents {
        commands.push(bus.typed_publisher(&swarm.to_agent(RobotId(id)))?);
        poses.push(bus.typed_subscriber(&swarm.pose(RobotId(id)))?);
    }
    let mut sup = Spawned::new(agent);
    let terrain = Terrain::paper();
    let text = to_text(&terrain);
    let started = Instant::now();
    start_in_batches(&mut sup, &reports, &name, agents, speed, &text, &stop)?;
    let start_s = started.elapsed().as_secs_f64();
    deploy_spread(&commands, &terrain, speed)?;
    // Let every agent take its deployment, then count from a clean slate.
    std::thread::sleep(Duration::from_secs_f64(0.5));
    let mut last: Vec<Option<u64>> = vec![None; agents as usize];
    let (mut periods, mut missed) = (0u64, vec![0u64; agents as usize]);
    let end = Instant::now() + Duration::from_secs_f64(seconds);
    let mut memories = Vec::new();
    let drain = |last: &mut Vec<Option<u64>>, missed: &mut Vec<u64>, periods: &mut u64| {
        for (i, sub) in poses.iter().enumerate() {
            while let Ok(Some(p)) = sub.try_recv() {
                if let Some(prev) = last[i] {
                    *periods += p.step.saturating_sub(prev);
                    missed[i] += p.step.saturating_sub(prev).saturating_sub(1);
                }
                last[i] = Some(p.step);
            }
        }
    };
    while Instant::now() < end && !stop.load(Ordering::SeqCst) {
        drain(&mut last, &mut missed, &mut periods);
        while let Ok(Some((_, msg))) = reports.try_recv() {
            sup.heard(msg.robot().0);
        }
        if let Some((id, gone)) = sup.poll().into_iter().next() {
            bail!("agent {id} is gone: {gone}");
        }
        if memories.is_empty() && end.saturating_duration_since(Instant::now()) < Duration::from_secs(2) {
            memories = (1..=agents).filter_map(|id| sup.pid(id)).map(memory).collect();
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    // What was published while the loop read /proc is still queued.
    drain(&mut last, &mut missed, &mut periods);
    let ids: Vec<u32> = (1..=agents).collect();
    let mut shutdown = |id: u32| drop(commands[id as usize - 1].publish(&ToAgent::Shutdown));
    bycoms_launch::driver::wind_down(&mut sup, &ids, Duration::from_secs(5), &mut shutdown);
    Ok(report(agents, seconds, periods, &missed, &memories, start_s))
}

/// Deploys every agent at the terrain's start, spread over one period: an
/// agent's periods run from its deployment, and a thousand deployed at
/// once would all wake at the same instants (0.21 % of periods missed
/// against 0.002 % spread, 20 s at load 150), where real robots, deployed
/// one by one, keep their own phases.
fn deploy_spread(commands: &[Pub<ToAgent>], terrain: &Terrain, speed: f64) -> Result<()> {
    let (start, goal) = (terrain.start(), terrain.goal());
    let heading = start.bearing_to(goal);
    let period = Duration::from_secs_f64(0.1 / speed);
    let deploying = Instant::now();
    for (i, c) in commands.iter().enumerate() {
        let robot = RobotId(i as u32 + 1);
        let at = deploying + period.mul_f64(i as f64 / commands.len() as f64);
        std::thread::sleep(at.saturating_duration_since(Instant::now()));
        c.publish(&ToAgent::Deploy(Deploy { robot, x: start.x, y: start.y, heading }))?;
        c.publish(&ToAgent::GoalBearing(GoalBearing { robot, bearing: heading, step: 0 }))?;
    }
    Ok(())
}

/// The flags of agent `id` of a scale run: the paper's terrain from
/// stdin, real time at 10 Hz × `speed`, the bus of this host.
fn agent_args(name: &str, id: u32, agents: u32, speed: f64) -> AgentArgs {
    AgentArgs {
        terrain: Some(PathBuf::from("-")),
        eps: Some(2.0),
        clock: Clock::Realtime,
        speed,
        swarm_size: Some(agents),
        parent_pid: Some(std::process::id() as i32),
        heartbeat_ms: 100,
        settings_timeout: DEFAULT_SETTINGS_TIMEOUT_S,
        bus: BusArgs { transport: Transport::Ipc, connect: Vec::new(), zenoh_config: None },
        ..AgentArgs::new(name, id)
    }
}

/// Starts the agents in batches, each batch registered before the next.
///
/// Why batches: hundreds of processes opening the same iceoryx2 services
/// at once contend for them and slow every start down (500 agents: batches
/// of 25 started in 6.2 s, of 100 in 5.3 s, all at once in 9.2 s, one run
/// each on a loaded machine).
fn start_in_batches(
    sup: &mut Spawned,
    reports: &TypedFanIn<<Bus as bycoms_protocol::bus::Bus>::FanIn, FromAgent>,
    name: &str,
    agents: u32,
    speed: f64,
    text: &str,
    stop: &AtomicBool,
) -> Result<()> {
    let mut registered = BTreeSet::new();
    for first in (1..=agents).step_by(BATCH as usize) {
        let last = (first + BATCH - 1).min(agents);
        for id in first..=last {
            let args = agent_args(name, id, agents, speed);
            sup.spawn(id, &args.to_flags(), text)?;
        }
        let deadline = Instant::now() + Duration::from_secs(60);
        while registered.len() < last as usize {
            if Instant::now() > deadline || stop.load(Ordering::SeqCst) {
                bail!("only {} of the first {last} agents registered within 60 s", registered.len());
            }
            // Once per wait, not per message: a poll is a `wait4` per agent,
            // and the registered agents' heartbeats (10 a second each)
            // outran a loop that polled all of them per message, so later
            // batches' registrations were lost behind them (500 agents
            // never started).
            if let Some((id, gone)) = sup.poll().into_iter().next() {
                bail!("agent {id} is gone: {gone}");
            }
            let mut next = reports.recv_timeout(Duration::from_millis(10));
            while let Ok(Some((_, msg))) = next {
                sup.heard(msg.robot().0);
                if let FromAgent::Register(r) = msg {
                    registered.insert(r.robot.0);
                }
                next = reports.try_recv();
            }
        }
    }
    Ok(())
}

/// The figures of a scale run: periods missed, and the agents' memory.
fn report(
    agents: u32,
    seconds: f64,
    periods: u64,
    missed: &[u64],
    memories: &[Memory],
    start_s: f64,
) -> ScaleReport {
    let n = memories.len().max(1) as u64;
    let sum = |f: fn(&Memory) -> u64| memories.iter().map(f).sum::<u64>() / n;
    let total_missed: u64 = missed.iter().sum();
    ScaleReport {
        agents,
        seconds,
        periods,
        missed: total_missed,
        missed_percent: if periods > 0 { 100.0 * total_missed as f64 / periods as f64 } else { 0.0 },
        agents_with_misses: missed.iter().filter(|&&m| m > 0).count() as u32,
        mean: Memory {
            rss_kb: sum(|m| m.rss_kb),
            rss_anon_kb: sum(|m| m.rss_anon_kb),
            rss_file_kb: sum(|m| m.rss_file_kb),
            rss_shmem_kb: sum(|m| m.rss_shmem_kb),
            pss_kb: sum(|m| m.pss_kb),
        },
        max_rss_kb: memories.iter().map(|m| m.rss_kb).max().unwrap_or(0),
        max_pss_kb: memories.iter().map(|m| m.pss_kb).max().unwrap_or(0),
        start_s,
    }
}
