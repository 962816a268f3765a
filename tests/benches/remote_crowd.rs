//! Issue 20, "Across hosts": a lockstep launch of `ROBOTS` (default 300)
//! remote agents spread over `HOSTS` (default 3) agent hosts over zenoh
//! ends with the `simulate` result; its ticks per second beside the same
//! launch on one host.
//!
//! The world is the paper's long-obstacle case (ε 3, as `remote_lockstep`)
//! with `--robots ROBOTS`: robots 1 and 2 get stuck, robot 3 arrives, and
//! the run ends there (`arrived`, 983 active steps), the other agents
//! registered and waiting. (`orchestrator bench crowd`'s all-stuck terrain,
//! which deploys every robot, does not give the `simulate` result: its
//! `--stop-turn-rate 0` takes a robot turning in place for stuck, and with
//! the gate that tells turning apart, `simulate` itself finds a robot that
//! never sticks, past 15 robots, and runs to the time limit.)
//!
//! Set-ups, one launch each, in this order:
//!
//! * `ipc, spawned, 1 host` — the default launch: the orchestrator spawns
//!   each agent when its robot is (about to be) needed, over iceoryx2;
//! * `zenoh, spawned, 1 host` — the same over zenoh tcp on 127.0.0.1;
//! * `zenoh, remote, 1 host` — `--agents remote` on 127.0.0.1: every agent
//!   started by hand, as below, with no network namespace;
//! * `zenoh, remote, H hosts` — the orchestrator in the hub of a
//!   [`Star`] of network namespaces, listening on each link's address;
//!   agent k started by hand in spoke `(k - 1) mod H`, connecting to its
//!   link's address: `sim-agent --transport zenoh --connect ENDPOINT
//!   --swarm S --robot K`, the run's settings from the orchestrator
//!   (README, "Agents on other hosts").
//!
//! Remote agents are started once the orchestrator listens, robot
//! `ROBOTS` first and robot 1 last: the run starts when robot 1's agent has
//! registered, so it runs with every agent connected (heartbeats, liveliness
//! tokens), not while they start. The launch awaits robot 1's agent for up
//! to [`REGISTER_TIMEOUT_S`] and fails (`--missing fail`) rather than
//! skipping a robot whose agent never came, which would change the result.
//!
//! Each launch's `--json` summary gives ticks, wall time (`wall_s`, from
//! the open bus to the end, wind-down included), `sim_speed` (ticks × 0.1 s
//! / wall) and when robot 1 first moved (`first_moving_s`, counted from
//! the command's start). Ticks per second are given over `wall_s`, and over
//! the lockstep clock alone (`clock`: from the orchestrator's "robot 1:
//! deployed at" line to its "arrived at the goal" line, as this process
//! reads them; no start-up, registration or wind-down). `agents` counts
//! the agents the launch had: remote ones that registered, spawned ones it
//! started (only when their robot is about to be needed). The result is compared
//! with `bycoms_sim::run` on the same terrain and settings: outcome, total
//! steps, robots used, and each robot's end, final position (bit for bit)
//! and steps; ticks must be the same in every set-up. The table is printed,
//! then the bench fails (exit 1, naming the differences) if a launch failed
//! or differed; a launch that printed no summary has its log kept in the
//! temporary directory, and the remote agents' exit statuses are counted.
//!
//! `cargo build --release --bins -p bycoms-orchestrator -p bycoms-sim &&
//! cargo bench -p bycoms-tests --bench remote_crowd` (root for the
//! namespaces; without them the last row is left out with a notice). Every
//! agent holds two pipes of this process (its stdout and stderr): the bench
//! raises its soft open-files limit to the hard one.

use bycoms_runtime::{BusArgs, Transport};
use bycoms_sim::terrain::to_text;
use bycoms_sim::{run, RunConfig, RunResult};
use bycoms_sim_agent::AgentArgs;
use bycoms_study::scenario::{load, TerrainSource};
use bycoms_tests::netns::{not_permitted, Star, PORT};
use bycoms_tests::{agents_of, bin, is_zombie, simulate_differences, swarm_name, wait_for, Finished, Proc};
use nix::sys::resource::{getrlimit, setrlimit, Resource};
use serde_json::Value;
use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// The world: the paper's three-robot case.
const SCENARIO: &str = "long-obstacle";
/// ε of the run.
const EPS: f64 = 3.0;
/// Simulated time budget (the launch's default).
const TIME_LIMIT: f64 = 10_000.0;
/// How long the launch awaits an agent at its robot's turn, s: robot 1's
/// agent is started last, after every other, each opening its zenoh
/// session on a machine the launch shares (300 took about 1 s here).
const REGISTER_TIMEOUT_S: &str = "120";
/// Longest one launch may take (300 remote agents: about 1 minute here).
const WAIT: Duration = Duration::from_secs(10 * 60);
/// How long the agents get to exit after their launch ended.
const AGENTS_EXIT: Duration = Duration::from_secs(60);

/// What every set-up launches.
struct Launch {
    robots: u32,
    terrain: String,
    /// [`EPS`] and [`TIME_LIMIT`] as flags.
    eps: String,
    time_limit: String,
}

/// One launch's summary, how many agents it had and how long its clock ran.
struct Launched {
    summary: Value,
    agents: usize,
    /// From robot 1's start pose to robot 3's arrival, as logged.
    clock: Option<Duration>,
}

impl Launch {
    /// `orchestrator launch …` of this world, lockstep, in swarm `swarm`.
    fn args<'a>(&'a self, swarm: &'a str, robots: &'a str) -> Vec<&'a str> {
        let mut args = vec!["launch", "--clock", "lockstep", "--json", "--swarm", swarm, "--robots", robots];
        args.extend(["--terrain", &self.terrain, "--eps", &self.eps, "--time-limit", &self.time_limit]);
        args.extend(["--register-timeout", REGISTER_TIMEOUT_S, "--missing", "fail"]);
        args
    }

    /// A launch that starts its own agents, over `transport`, on this host.
    fn spawned(&self, zenoh: bool) -> Launched {
        let swarm = swarm_name("crowd");
        let robots = self.robots.to_string();
        let mut args = self.args(&swarm, &robots);
        if zenoh {
            args.extend(["--transport", "zenoh", "--listen", "tcp/127.0.0.1:0"]);
        }
        let (out, clock) = timed(Proc::orchestrator(&args));
        let summary = summary(out);
        let agents =
            summary["robots"].as_array().map_or(0, |r| r.iter().filter(|r| !r["pid"].is_null()).count());
        Launched { summary, agents, clock }
    }

    /// A `--agents remote` launch whose agents are started by hand, robot
    /// `robots` first: on this host (`star` none) or spread round-robin
    /// over the spokes of `star`, the orchestrator in its hub.
    fn remote(&self, star: Option<&Star>) -> Launched {
        let swarm = swarm_name("crowd");
        let robots = self.robots.to_string();
        let mut args = self.args(&swarm, &robots);
        args.extend(["--agents", "remote", "--transport", "zenoh"]);
        let listen: Vec<String> = match star {
            None => vec!["tcp/127.0.0.1:0".into()],
            // In a private namespace no one else holds the port.
            Some(star) => star.links.iter().map(|l| l.hub.endpoint(PORT)).collect(),
        };
        for endpoint in &listen {
            args.extend(["--listen", endpoint]);
        }
        let orch = match star {
            None => Proc::orchestrator(&args),
            Some(star) => star.hub().start("orchestrator", &args),
        };
        // Every listener is in the one line the orchestrator logs once it
        // listens: the agents start after it.
        let first = listen[0].trim_end_matches(|c: char| c.is_ascii_digit());
        let logged = orch.logged_endpoint(first, Duration::from_secs(60));
        let endpoints = match star {
            None => vec![logged],
            Some(_) => listen,
        };
        let start = |k: u32| {
            let at = (k as usize - 1) % endpoints.len();
            let agent = AgentArgs {
                bus: BusArgs {
                    transport: Transport::Zenoh,
                    connect: vec![endpoints[at].clone()],
                    zenoh_config: None,
                },
                ..AgentArgs::new(&swarm, k)
            };
            let flags = agent.to_flags();
            match star {
                None => Proc::start(&bin("sim-agent"), &flags),
                Some(star) => {
                    let flags: Vec<&str> = flags.iter().map(String::as_str).collect();
                    star.links[at].spoke.start("sim-agent", &flags)
                }
            }
        };
        let started = Instant::now();
        let agents: Vec<Proc> = (1..=self.robots).rev().map(start).collect();
        println!("  {} agents started by hand in {:.1} s", agents.len(), started.elapsed().as_secs_f64());
        let (out, clock) = timed(orch);
        let registered = out.stderr.matches(": agent registered").count();
        let summary = summary(out);
        // Sent `Shutdown` at the end, the agents exit by themselves; those
        // still running after AGENTS_EXIT are killed.
        let _ = wait_for(AGENTS_EXIT, || agents_of(&swarm).is_empty().then_some(()));
        println!("  agents: {}", exits(agents));
        Launched { summary, agents: registered, clock }
    }
}

/// How the agents ended: exit statuses counted, the last line of the
/// first failed one's log; those still running are killed.
fn exits(agents: Vec<Proc>) -> String {
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    let mut failed = None;
    for agent in agents {
        if !is_zombie(agent.pid()) {
            *counts.entry("killed".into()).or_default() += 1;
            continue;
        }
        let done = agent.wait(Duration::from_secs(5));
        if !done.status.success() && failed.is_none() {
            failed = done.stderr.lines().last().map(str::to_owned);
        }
        *counts.entry(done.status.to_string()).or_default() += 1;
    }
    let counts: Vec<String> = counts.iter().map(|(how, n)| format!("{n} {how}")).collect();
    match failed {
        Some(line) => format!("{}; the first failed one said: {line}", counts.join(", ")),
        None => counts.join(", "),
    }
}

/// The launch `orch` once ended, and the wall time from its first robot's
/// start pose to the arrival that ended the run (its lockstep clock
/// alone: no start-up, registration or wind-down), from the lines it logs
/// as they come; [`WAIT`] in all.
fn timed(orch: Proc) -> (Finished, Option<Duration>) {
    let deadline = Instant::now() + WAIT;
    let left = || deadline.saturating_duration_since(Instant::now()).max(Duration::from_secs(1));
    let deployed = orch.stderr_line(left(), |l| l.contains("robot 1: deployed at").then(Instant::now));
    let arrived = orch.stderr_line(left(), |l| l.contains(": arrived at the goal").then(Instant::now));
    let clock = deployed.zip(arrived).map(|(from, to)| to - from);
    (orch.wait(left()), clock)
}

/// The launch's `--json` summary; without one, panics, naming its log
/// (kept in the temporary directory) and its last lines.
fn summary(out: Finished) -> Value {
    serde_json::from_str(&out.stdout).unwrap_or_else(|e| {
        static KEPT: AtomicU32 = AtomicU32::new(0);
        let n = KEPT.fetch_add(1, Ordering::SeqCst);
        let log = std::env::temp_dir().join(format!("remote_crowd-{}-{n}.log", std::process::id()));
        let kept =
            std::fs::write(&log, &out.stderr).map_or("not kept".into(), |()| log.display().to_string());
        let lines: Vec<&str> = out.stderr.lines().collect();
        let tail = lines[lines.len().saturating_sub(5)..].join("\n");
        panic!("no summary ({e}; {}); its log: {kept}, ending:\n{tail}", out.status)
    })
}

/// One set-up's launch, or why it gave none.
struct Row {
    name: String,
    launch: Result<Launched, String>,
}

/// Runs `launch` as set-up `name`; a panic (no summary, a timeout) is the
/// row's failure, and the next set-up still runs.
fn row(name: String, launch: impl FnOnce() -> Launched) -> Row {
    println!("{name} …");
    let launch = catch_unwind(AssertUnwindSafe(launch)).map_err(|e| {
        e.downcast_ref::<String>()
            .cloned()
            .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "panicked".into())
    });
    Row { name, launch }
}

/// Prints the table; the problems found, if any.
fn table(expected: &RunResult, rows: &[Row]) -> Vec<String> {
    let mut problems = Vec::new();
    let ticks = rows.iter().find_map(|r| r.launch.as_ref().ok().map(|l| l.summary["ticks"].clone()));
    println!(
        "| set-up | agents | ticks | wall s | ticks per second | sim speed | robot 1 moving after, s | clock s | \
         ticks per second, clock | equal to simulate |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let Launched { summary: j, agents, clock } = match &r.launch {
            Ok(l) => l,
            Err(why) => {
                println!("| {} | – | – | – | – | – | – | – | – | no: failed |", r.name);
                problems.push(format!("{}: failed: {why}", r.name));
                continue;
            }
        };
        let diff = simulate_differences(expected, j);
        let n = j["ticks"].as_u64().unwrap_or(0);
        let wall = j["wall_s"].as_f64().unwrap_or(f64::NAN);
        let moving = j["first_moving_s"].as_f64().unwrap_or(f64::NAN);
        let clock = clock.map_or(f64::NAN, |c| c.as_secs_f64());
        println!(
            "| {} | {agents} | {n} | {wall:.1} | {:.0} | {:.1}x | {moving:.1} | {clock:.2} | {:.0} | {} |",
            r.name,
            n as f64 / wall,
            j["sim_speed"].as_f64().unwrap_or(f64::NAN),
            n as f64 / clock,
            if diff.is_empty() { "yes" } else { "no" }
        );
        problems.extend(diff.into_iter().take(10).map(|d| format!("{}: {d}", r.name)));
        if let Some(t) = ticks.as_ref().filter(|t| **t != j["ticks"]) {
            problems.push(format!("{}: {} ticks, another set-up {t}", r.name, j["ticks"]));
        }
    }
    problems
}

/// Raises this process's soft open-files limit to the hard one (every
/// agent's stdout and stderr are pipes held here; the processes started
/// inherit the limit).
fn raise_open_files() {
    let Ok((soft, hard)) = getrlimit(Resource::RLIMIT_NOFILE) else { return };
    if soft < hard && setrlimit(Resource::RLIMIT_NOFILE, hard, hard).is_ok() {
        println!("open files: soft limit raised from {soft} to {hard}");
    }
}

fn env_u32(name: &str, default: u32) -> u32 {
    std::env::var(name).ok().and_then(|s| s.parse().ok()).unwrap_or(default)
}

fn main() {
    let robots = env_u32("ROBOTS", 300);
    let hosts = env_u32("HOSTS", 3) as usize;
    raise_open_files();
    let dir = tempfile::tempdir().expect("temp dir");
    let world = load(&TerrainSource::Scenario(SCENARIO.into())).expect("built-in scenario").terrain;
    let path = dir.path().join("terrain.txt");
    std::fs::write(&path, to_text(&world)).expect("write terrain");
    let mut cfg = RunConfig::paper(EPS);
    cfg.max_robots = Some(robots);
    cfg.time_limit = TIME_LIMIT;
    let expected = run(&world, &cfg);
    println!(
        "lockstep launch --robots {robots} ({SCENARIO}, eps {EPS}), one launch per set-up; \
         simulate: {:?}, {} steps, {} robots used",
        expected.outcome, expected.steps, expected.robots_used
    );
    let launch = Launch {
        robots,
        terrain: path.to_str().expect("utf-8 path").into(),
        eps: format!("{EPS:?}"),
        time_limit: format!("{TIME_LIMIT:?}"),
    };
    let started = Instant::now();
    let mut rows = vec![
        row("ipc, spawned, 1 host".into(), || launch.spawned(false)),
        row("zenoh, spawned, 1 host".into(), || launch.spawned(true)),
        row("zenoh, remote, 1 host".into(), || launch.remote(None)),
    ];
    match not_permitted() {
        Some(why) => println!("zenoh, remote, {hosts} hosts: left out ({why})"),
        None => rows.push(row(format!("zenoh, remote, {hosts} hosts"), || {
            let star = Star::create("bench-crowd", hosts).expect("namespaces");
            launch.remote(Some(&star))
        })),
    }
    println!();
    let problems = table(&expected, &rows);
    println!("({:.0} s in all)", started.elapsed().as_secs_f64());
    if !problems.is_empty() {
        eprintln!("remote_crowd: a launch failed or differs from simulate:");
        for p in &problems {
            eprintln!("  {p}");
        }
        std::process::exit(1);
    }
}
