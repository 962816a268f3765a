//! `orchestrator bench`: the process layer's figures, measured on this
//! machine (run the release build: `cargo run --release --bin orchestrator
//! -- bench ...`).
//!
//! * `bench launch` — the default `launch --robots 3` (lockstep) a few
//!   times: gate reaction (from the decision that a robot stopped to the next
//!   robot's first pose) and lockstep speed (simulated seconds per wall
//!   second);
//! * `bench scale` — N real-time agents at 10 Hz at once: missed periods
//!   and memory per agent;
//! * `bench crowd` — whole lockstep launches of N robots on a terrain where
//!   every robot gets stuck, measured from outside: memory of all their
//!   processes, open files, wall time per tick (`launch::crowd`);
//! * `bench stop` — `stop --now` → every robot stopped (its agent answered `Stop`) in real-time
//!   launches of N robots, timed from the asking side over ipc and zenoh
//!   (`launch::stopbench`);
//! * `bench schedules` — the launch core's simulation testing
//!   (`launch::harness`): seeded fault schedules played in virtual time,
//!   schedules per second and robot-ticks per second, each schedule checked.
//!   Only in a build with `--features testing` (the harness is a test
//!   harness, kept out of the release binary).
//!
//! Figures are printed, never asserted: speed is proven here, not in timed
//! unit tests.

use crate::commands::launch as launch_cmd;
use anyhow::{bail, Result};
use bycoms_launch::config::{check_robot_count, Transport};
use bycoms_launch::{self as launch, LaunchConfig, Outcome};
use bycoms_runtime::seconds::seconds;
use bycoms_runtime::stats::quantile;
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub what: What,
    /// Print the figures as JSON.
    #[arg(long, global = true)]
    pub json: bool,
    /// Agent executable [default: $BYCOMS_SIM_AGENT, else sim-agent next to orchestrator, else
    /// orchestrator itself as `orchestrator sim-agent`, with a warning: its memory and start-up
    /// figures are not sim-agent's].
    #[arg(long, global = true, value_name = "FILE")]
    pub agent_bin: Option<PathBuf>,
}

#[derive(Debug, clap::Subcommand)]
pub enum What {
    /// Gate reaction and lockstep speed of the default `launch --robots 3`.
    Launch {
        /// Launches to run.
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
        runs: u32,
        /// The bus the launches run over.
        #[arg(long, value_enum, default_value_t = Transport::Ipc)]
        transport: Transport,
        /// Start each agent only when the gate opens (measures the process start).
        #[arg(long)]
        no_prespawn: bool,
    },
    /// The most real-time agents at 10 Hz: missed periods and memory.
    Scale {
        /// Agents running at once.
        #[arg(long, default_value_t = 200)]
        agents: u32,
        /// Seconds to watch them.
        #[arg(long, default_value_t = 20.0, value_parser = seconds)]
        seconds: f64,
        /// Real-time speed-up (1 = 10 Hz).
        #[arg(long, default_value_t = 1.0)]
        speed: f64,
    },
    /// Whole lockstep launches where every robot sticks: memory, open files, time per tick.
    Crowd {
        /// Swarm sizes, one launch each (`--repeat` for more).
        #[arg(long, value_delimiter = ',', default_value = "10,100,300,1000")]
        robots: Vec<u32>,
        /// Longest one launch may take, s (then it is stopped).
        #[arg(long, default_value_t = 1800.0, value_name = "SECONDS", value_parser = seconds)]
        timeout: f64,
        /// Also run each launch recorded (`--record`), after it runs
        /// without: the recording's size and its cost in wall time per tick.
        #[arg(long)]
        record: bool,
        /// Launches per swarm size; with more than one, each size's median
        /// µs/agent and ms/tick are printed too (a small crowd's µs/agent
        /// comes from about a hundred ticks and swings by a third from one
        /// launch to the next).
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
        repeat: u32,
    },
    /// `stop --now` → every robot stopped (answered `Stop`): real-time launches timed from the asking side.
    Stop {
        /// Robots (spawned sim-agents) per launch.
        #[arg(long, default_value_t = 100)]
        robots: u32,
        /// Launches (one stop each) per transport.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
        runs: u32,
        /// The buses to measure over.
        #[arg(long, value_enum, value_delimiter = ',', default_value = "ipc,zenoh")]
        transport: Vec<Transport>,
        /// Real-time speed-up of the launches (10 Hz × speed).
        #[arg(long, default_value_t = 10.0)]
        speed: f64,
        /// Longest wait for every agent to run, and for the launch to exit, s.
        #[arg(long, default_value_t = 300.0, value_name = "SECONDS", value_parser = seconds)]
        timeout: f64,
    },
    /// Seeded fault schedules of the launch core in virtual time, per second (a build with `--features testing` only).
    Schedules {
        /// Schedules to play (seeds 0..N, as the test suite draws them).
        #[arg(long, default_value_t = 10_000, value_parser = clap::value_parser!(u64).range(1..))]
        count: u64,
        /// Rounds to time (the median is reported).
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
        rounds: u32,
    },
}

pub fn run(args: Args) -> Result<i32> {
    if let What::Schedules { count, rounds } = args.what {
        #[cfg(feature = "testing")]
        return schedules(count, rounds, args.json);
        #[cfg(not(feature = "testing"))]
        return Err(without_harness(count, rounds));
    }
    // (Every bench below starts agents; say which executable runs them.)
    warn_if_agents_are_this_executable(&launch::agent_command(args.agent_bin.as_deref(), None)?);
    if let What::Crowd { robots, timeout, record, repeat } = args.what {
        return crowd(robots, timeout, record, repeat, args.agent_bin, args.json);
    }
    if let What::Stop { robots, runs, transport, speed, timeout } = args.what {
        return stop(robots, runs, transport, speed, timeout, args.agent_bin, args.json);
    }
    let agent = launch::agent_command(args.agent_bin.as_deref(), None)?;
    match args.what {
        What::Schedules { .. } | What::Crowd { .. } | What::Stop { .. } => unreachable!("handled above"),
        What::Launch { runs, no_prespawn, transport } => {
            launch_figures(runs, no_prespawn, transport, agent, args.json)?;
        }
        What::Scale { agents, seconds, speed } => {
            let r = bycoms_bench::scale::run(agent, agents, seconds, speed)?;
            if args.json {
                bycoms_runtime::outln!("{}", serde_json::to_string_pretty(&r)?)?;
            } else {
                bycoms_runtime::outln!(
                    "{} agents at {} Hz for {} s (all started in {:.1} s): {} of {} periods missed ({:.4} %, {} agents missed any)\n  memory per agent: RSS {} kB mean (anon {}, file {}, shmem {}), max {} kB; PSS {} kB mean, max {} kB",
                    r.agents, 10.0 * speed, r.seconds, r.start_s, r.missed, r.periods, r.missed_percent, r.agents_with_misses,
                    r.mean.rss_kb, r.mean.rss_anon_kb, r.mean.rss_file_kb, r.mean.rss_shmem_kb, r.max_rss_kb, r.mean.pss_kb, r.max_pss_kb
                )?;
            }
        }
    }
    Ok(bycoms_runtime::exit::SUCCESS)
}

/// `bench schedules` in a build without the launch harness (the release
/// binary): a usage error that says which build has it.
#[cfg_attr(feature = "testing", allow(dead_code))]
fn without_harness(count: u64, rounds: u32) -> anyhow::Error {
    bycoms_runtime::exit::usage(format!(
        "bench schedules (--count {count}, --rounds {rounds}) needs a build with `--features testing`: the \
         launch harness is kept out of the release binary (cargo run --release --features testing --bin \
         orchestrator -- bench schedules)"
    ))
}

/// Logs a warning when the agents run as `orchestrator sim-agent` (no
/// `sim-agent` beside this executable): they work the same, but each maps
/// the orchestrator's larger image, so memory and start-up figures are not
/// `sim-agent`'s.
fn warn_if_agents_are_this_executable(agent: &launch::AgentCommand) {
    if let Some(note) = agents_are_this_executable(agent) {
        tracing::warn!("{note}");
    }
}

/// [`warn_if_agents_are_this_executable`]'s sentence, `None` when the
/// agents run from an executable of their own.
fn agents_are_this_executable(agent: &launch::AgentCommand) -> Option<String> {
    agent.prefix.first().is_some_and(|p| p == "sim-agent").then(|| {
        format!(
            "no sim-agent beside {}: the agents run as `orchestrator sim-agent`, whose memory and start-up \
             figures are not sim-agent's (build it: cargo build --release -p bycoms-sim-agent)",
            agent.program.display()
        )
    })
}

/// `bench launch`: `runs` default launches of 3 robots, and their figures
/// (first robot moving, gate reaction, lockstep speed, a tick's time).
fn launch_figures(
    runs: u32,
    no_prespawn: bool,
    transport: Transport,
    agent: launch::AgentCommand,
    json: bool,
) -> Result<()> {
    let (mut reactions, mut speeds, mut walls) = (Vec::new(), Vec::new(), Vec::new());
    let (mut first_moving, mut tick_us, mut per_tick) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..runs {
        let mut cfg =
            LaunchConfig { swarm: Some(format!("bench-{}-{i}", std::process::id())), ..Default::default() };
        cfg.gate.prespawn = !no_prespawn;
        cfg.transport.kind = transport;
        let world = launch_cmd::world(&cfg)?;
        let s = launch::run(cfg, world, agent.clone())?;
        if s.outcome != Outcome::Arrived {
            bail!("run {i} did not end as expected: {}", s.line());
        }
        reactions.extend(s.robots.iter().filter_map(|r| r.gate_reaction_us).map(|us| us as f64 / 1e3));
        speeds.push(s.sim_speed);
        walls.push(s.wall_s);
        first_moving.extend(s.first_moving_s);
        if s.ticks > 0 {
            tick_us.push(s.tick_us);
            per_tick.push(s.ticked_agents as f64 / s.ticks as f64);
        }
    }
    // The runtime's one quantile; NaN (`null` in JSON) for a figure no run gave.
    let percentile = |values: &[f64], q: f64| quantile(values, q).unwrap_or(f64::NAN);
    let figures = serde_json::json!({
        "runs": runs, "prespawn": !no_prespawn, "transport": transport.as_str(),
        "first_moving_s": { "p50": percentile(&first_moving, 0.5), "max": percentile(&first_moving, 1.0) },
        "gate_reaction_ms": { "p50": percentile(&reactions, 0.5), "max": percentile(&reactions, 1.0), "n": reactions.len() },
        "lockstep_sim_s_per_wall_s": { "p50": percentile(&speeds, 0.5), "min": percentile(&speeds, 0.0) },
        "wall_s": { "p50": percentile(&walls, 0.5), "max": percentile(&walls, 1.0) },
        "tick_us": { "p50": percentile(&tick_us, 0.5), "max": percentile(&tick_us, 1.0) },
        "agents_per_tick": { "p50": percentile(&per_tick, 0.5) },
    });
    if json {
        bycoms_runtime::outln!("{}", serde_json::to_string_pretty(&figures)?)?;
    } else {
        bycoms_runtime::outln!(
            "launch --robots 3 (lockstep, {}, prespawn {}), {runs} runs:\n  launch → first robot moving p50 {:.3} s, max {:.3} s\n  gate reaction p50 {:.3} ms, max {:.3} ms ({} deployments)\n  lockstep speed p50 {:.0} simulated s per wall s (min {:.0}); wall time p50 {:.2} s, max {:.2} s\n  a tick (its Ticks to its last answer) p50 {:.1} µs, max {:.1} µs; agents ticked per tick p50 {:.2}",
            transport.as_str(),
            !no_prespawn,
            percentile(&first_moving, 0.5),
            percentile(&first_moving, 1.0),
            percentile(&reactions, 0.5),
            percentile(&reactions, 1.0),
            reactions.len(),
            percentile(&speeds, 0.5),
            percentile(&speeds, 0.0),
            percentile(&walls, 0.5),
            percentile(&walls, 1.0),
            percentile(&tick_us, 0.5),
            percentile(&tick_us, 1.0),
            percentile(&per_tick, 0.5)
        )?;
    }
    Ok(())
}

/// `bench crowd`: `repeat` launches per swarm size, the figures of each
/// (and each size's medians when it ran more than once).
fn crowd(
    robots: Vec<u32>,
    timeout: f64,
    record: bool,
    repeat: u32,
    agent_bin: Option<PathBuf>,
    json: bool,
) -> Result<i32> {
    if robots.is_empty() {
        return Err(bycoms_runtime::exit::usage("--robots takes swarm sizes of at least 1"));
    }
    for &n in &robots {
        check_robot_count("--robots", n)?;
    }
    // In range: the value parser's one check of seconds.
    let timeout = std::time::Duration::from_secs_f64(timeout);
    let opts = bycoms_bench::crowd::Options { robots, agent_bin, timeout, record, repeat };
    let rows = bycoms_bench::crowd::run(&opts)?;
    if json {
        let medians = bycoms_bench::crowd::medians(&rows);
        let figures = serde_json::json!({ "terrain": bycoms_bench::crowd::ALL_STUCK, "launches": rows, "medians": medians });
        bycoms_runtime::outln!("{}", serde_json::to_string_pretty(&figures)?)?;
    } else {
        bycoms_runtime::outln!("{}", bycoms_bench::crowd::table(&rows))?;
    }
    let interrupted = rows.last().is_some_and(|r| r.ended == bycoms_bench::crowd::Ended::Interrupted);
    Ok(if interrupted { bycoms_runtime::exit::INTERRUPTED } else { bycoms_runtime::exit::SUCCESS })
}

/// `bench stop`: `runs` stopped launches per transport, a line each.
fn stop(
    robots: u32,
    runs: u32,
    transports: Vec<Transport>,
    speed: f64,
    timeout: f64,
    agent_bin: Option<PathBuf>,
    json: bool,
) -> Result<i32> {
    check_robot_count("--robots", robots)?;
    let timeout = std::time::Duration::from_secs_f64(timeout);
    let mut all = Vec::new();
    for transport in transports {
        let opts = bycoms_bench::stopbench::Options {
            robots,
            runs,
            transport,
            agent_bin: agent_bin.clone(),
            speed,
            timeout,
        };
        let samples = bycoms_bench::stopbench::run(&opts)?;
        if !json {
            bycoms_runtime::outln!("{}", bycoms_bench::stopbench::line(transport, robots, &samples))?;
        }
        all.push(serde_json::json!({ "transport": transport.as_str(), "robots": robots, "runs": samples }));
    }
    if json {
        bycoms_runtime::outln!("{}", serde_json::to_string_pretty(&all)?)?;
    }
    Ok(bycoms_runtime::exit::SUCCESS)
}

#[cfg(feature = "testing")]
/// `bench schedules`: plays seeds `0..count` (the test suite's schedules)
/// `rounds` times and reports the median rate; every schedule is checked.
fn schedules(count: u64, rounds: u32, json: bool) -> Result<i32> {
    use bycoms_launch::harness::{self, Case, Schedule};
    let mut rates = Vec::new();
    let mut ticks = 0u64;
    let mut tick_rates = Vec::new();
    for _ in 0..rounds {
        let started = std::time::Instant::now();
        ticks = 0;
        for seed in 0..count {
            let case = Case::small(seed);
            let schedule = Schedule::draw(seed, case.robots, 400);
            // The core's log lines (a refused second agent, an unreachable
            // one) are what a schedule provokes, not figures: not printed,
            // so the terminal does not set the pace.
            let report =
                tracing::subscriber::with_default(tracing::subscriber::NoSubscriber::default(), || {
                    harness::run(&case, &schedule)
                });
            if let Err(e) = harness::check(&report, &schedule) {
                bail!("schedule {seed} broke a property: {e}");
            }
            ticks += report.ticks * u64::from(case.robots);
        }
        let s = started.elapsed().as_secs_f64();
        rates.push(count as f64 / s);
        tick_rates.push(ticks as f64 / s);
    }
    let percentile = |values: &[f64], q: f64| quantile(values, q).unwrap_or(f64::NAN);
    let (p50, min, max) = (percentile(&rates, 0.5), percentile(&rates, 0.0), percentile(&rates, 1.0));
    let ticks_p50 = percentile(&tick_rates, 0.5);
    // A start with robots missing (issue 19), in virtual time: its figures
    // do not depend on this machine.
    let missing: Vec<_> = [true, false]
        .into_iter()
        .map(|remote| {
            let f = harness::missing_robots(remote);
            let kind = if remote { "remote" } else { "spawned" };
            (
                kind,
                f.first_deploy_after_register_us as f64 / 1e3,
                f.longest_wait_per_absent_us as f64 / 1e6,
                f.absent.len(),
                f.deployed,
            )
        })
        .collect();
    if json {
        let missing: Vec<_> = missing
            .iter()
            .map(|(kind, first_ms, wait_s, absent, deployed)| {
                serde_json::json!({
                    "agents": kind, "first_deploy_after_registration_ms": first_ms,
                    "longest_wait_per_absent_robot_s": wait_s, "absent": absent, "deployed": deployed,
                })
            })
            .collect();
        let figures = serde_json::json!({
            "missing_robots": missing,
            "schedules": count, "rounds": rounds,
            "schedules_per_s": { "p50": p50, "min": min, "max": max },
            "robot_ticks_per_s": { "p50": ticks_p50 },
            "robot_ticks_per_round": ticks,
        });
        bycoms_runtime::outln!("{}", serde_json::to_string_pretty(&figures)?)?;
    } else {
        bycoms_runtime::outln!(
            "{count} schedules × {rounds} rounds: median {p50:.0} schedules/s (min {min:.0}, max {max:.0}); \
             {ticks_p50:.0} robot-ticks/s ({ticks} robot-ticks per round)"
        )?;
        for (kind, first_ms, wait_s, absent, deployed) in &missing {
            bycoms_runtime::outln!(
                "50 {kind} robots, 5 never come, 5 die before registering (virtual time): first deployment \
                 {first_ms:.1} ms after robot 1's registration; longest wait {wait_s:.2} s per absent robot \
                 (registration timeout 10 s); {absent} absent, {deployed} deployed"
            )?;
        }
    }
    Ok(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedules_without_the_harness_is_a_usage_error_naming_the_feature() {
        let e = without_harness(10_000, 5);
        assert_eq!(bycoms_runtime::exit::code_of(&e), bycoms_runtime::exit::USAGE);
        assert!(
            e.to_string().starts_with(
                "bench schedules (--count 10000, --rounds 5) needs a build with `--features testing`"
            ),
            "{e}"
        );
    }

    #[test]
    fn only_agents_run_as_the_orchestrator_itself_are_warned_about() {
        let program = PathBuf::from("/opt/bycoms/orchestrator");
        let itself =
            launch::AgentCommand { program: program.clone(), prefix: vec!["sim-agent".into()], own: true };
        let note = agents_are_this_executable(&itself).expect("a note");
        assert!(note.contains("/opt/bycoms/orchestrator") && note.contains("-p bycoms-sim-agent"), "{note}");
        let beside =
            launch::AgentCommand { program: program.with_file_name("sim-agent"), prefix: vec![], own: true };
        assert_eq!(agents_are_this_executable(&beside), None);
        let chosen = launch::AgentCommand { program: "/usr/bin/my-agent".into(), prefix: vec![], own: false };
        assert_eq!(agents_are_this_executable(&chosen), None);
    }
}
