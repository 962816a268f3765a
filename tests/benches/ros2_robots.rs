//! Issue 50's figures for ROS 2 ground robots, from real processes: the
//! emulated lab (`sim-agent lab`, one differential-drive body per robot
//! following its `cmd_vel`), `orchestrator launch --agents real` with one
//! `ros2-robot` agent process per robot, and one zenoh router (this
//! process's, rmw_zenohd's place) that every `cmd_vel` crosses. An
//! independent subscriber on that router (this process, not the lab)
//! decodes every command with its arrival time.
//!
//! Figures:
//! * **swarm**: [`ROBOTS`] ROS 2 robots in one launch (their robots file
//!   and a walled-off scenario generated in a temporary directory, so that
//!   robot after robot is deployed, drives into the wall and sticks, until
//!   the run's [`SWARM_TIME_LIMIT_S`], with ε and dwell [`SWARM_GATE`]), at real speed: per robot, the
//!   commands seen, its spells of commanding (a deployed robot commands once
//!   per control period until a second after its stop; a spell ends at a
//!   silence of a second or more), the periods missed within them (a gap
//!   of g periods, g ≥ 1.5, misses round(g) − 1) and the longest gap (the
//!   robot's last command, the zero every agent sends as it ends, is left
//!   out of the spells: it follows its stop's zeros after however long the
//!   run went on),
//!   and the CPU its `ros2-robot` process used (utime + stime from
//!   `/proc/<pid>/stat`, sampled every [`CPU_EVERY`] while it lives) over
//!   its observed life. BYCOMS deploys one robot at a time, so at most one
//!   robot drives at any moment; the others' agents are running (bus,
//!   heartbeats, failsafe) and waiting.
//! * **stop**: rounds of the same launch, each stopped once robot 1
//!   drives, alternately by `orchestrator stop --now` (timed from spawning
//!   the command) and by a call of the launch's `/emergency` ROS 2 service
//!   (`std_srvs/srv/Trigger`, called here as rmw_zenoh's client does; timed
//!   from the call): the time until a zero velocity arrived on every
//!   robot's `cmd_vel` (every agent is told `Stop`, deployed or not), p50
//!   and p99 over the rounds of each way.
//!
//! `cargo build --release --bins -p bycoms-orchestrator -p bycoms-sim-agent
//! -p bycoms-ros2-robot && cargo bench -p bycoms-tests --bench ros2_robots`
//! (`BYCOMS_BENCH_SAMPLES=N`: stop rounds of each way, default 20). The
//! binaries are the ones of the bench's profile (`target/release`).
//! Wall-clock figures belong here, never in a test.

use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
use bycoms_ros2::msgs::{RosMessage, TriggerRequest, Twist, TRIGGER};
use bycoms_ros2::rmw_zenoh::{topic_key_expr, Attachment};
use bycoms_ros2::velocity::VelocityMessage;
use bycoms_runtime::stats::quantile;
use bycoms_tests::{agents_of, bin, is_zombie, signal, swarm_name, Finished, Proc};
use nix::sys::signal::Signal;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};
use zenoh::Wait;

/// ROS 2 robots in the launch.
const ROBOTS: u32 = 20;
/// The agents' control period at real speed.
const PERIOD: Duration = Duration::from_millis(100);
/// The swarm launch's run time, s (`--time-limit`).
const SWARM_TIME_LIMIT_S: u32 = 60;
/// The swarm launch's ε and dwell (m, s): a robot walks around the stopped
/// ones close enough to meet the wall soon, and counts as stuck after a
/// second still, so that more robots take their turn within the time.
const SWARM_GATE: [&str; 4] = ["--eps", "0.3", "--dwell", "1"];
/// How often the agents' CPU times are read.
const CPU_EVERY: Duration = Duration::from_millis(200);
/// A silence this long ends a spell of commanding.
const SPELL_GAP: Duration = Duration::from_secs(1);
/// The longest wait for anything: a launch to start driving, a zero to come.
const WAIT: Duration = Duration::from_secs(60);

/// One command as the independent subscriber saw it.
#[derive(Clone, Copy, Debug)]
struct Seen {
    robot: u32,
    at: Instant,
    linear: f64,
    angular: f64,
}

fn main() {
    let rounds: usize = std::env::var("BYCOMS_BENCH_SAMPLES").ok().and_then(|s| s.parse().ok()).unwrap_or(20);
    let dir = tempfile::tempdir().expect("temp dir");
    let (router, endpoint) = ZenohBus::loopback_router(|e| ZenohConfig {
        mode: Mode::Router,
        listen: vec![e.to_string()],
        ..ZenohConfig::default()
    })
    .expect("the lab's zenoh router");
    let seen = subscribe_every_cmd_vel(&router);
    let lab = Lab::write(dir.path(), &endpoint);
    let binaries = bin("orchestrator").parent().map(|d| d.display().to_string()).unwrap_or_default();
    println!(
        "ROS 2 robots: {ROBOTS} bodies, one launch, one zenoh router ({endpoint}), binaries of {binaries}"
    );
    swarm_figure(&lab, &seen);
    stop_figure(&lab, &router, &seen, rounds);
}

/// The subscriber on the router: every robot's `cmd_vel`, decoded.
fn subscribe_every_cmd_vel(router: &ZenohBus) -> Receiver<Seen> {
    let (tx, rx) = channel();
    let description = VelocityMessage::Twist.description();
    for robot in 1..=ROBOTS {
        let topic = format!("/robot_{robot}/cmd_vel");
        let key = topic_key_expr(0, &topic, description.name, &description.rihs01());
        let tx = tx.clone();
        let subscriber = router
            .session()
            .declare_subscriber(key)
            .callback(move |sample| {
                let at = Instant::now();
                if let Ok(t) = Twist::from_cdr(&sample.payload().to_bytes()) {
                    let (linear, angular) = (t.linear.0.x, t.angular.0.z);
                    let _ = tx.send(Seen { robot, at, linear, angular });
                }
            })
            .wait()
            .expect("a cmd_vel subscriber");
        // Held for the whole bench.
        std::mem::forget(subscriber);
    }
    rx
}

/// The generated lab: its robots file, scenario and launch config.
struct Lab {
    robots: PathBuf,
    scenario: PathBuf,
    config: PathBuf,
    endpoint: String,
}

impl Lab {
    /// [`ROBOTS`] TurtleBot 3s on `/robot_<k>/cmd_vel` (`Twist`), a 4 × 3 m
    /// room whose goal a wall 0.5 m ahead of the start closes off, and the
    /// shipped `deploy/lab/launch-ros2-robots.toml` on `endpoint`.
    fn write(dir: &Path, endpoint: &str) -> Self {
        let robots = dir.join("ros2-robots.toml");
        let entries: String =
            (1..=ROBOTS).map(|k| format!("[[robot]]\nid = {k}\nkind = \"ros2\"\n\n")).collect();
        std::fs::write(&robots, entries).expect("robots file");
        let tones: Vec<String> = (0..ROBOTS).map(|k| format!("{:.1}", 200.0 + 40.0 * f64::from(k))).collect();
        let scenario = dir.join("walled.toml");
        let text = format!(
            "name = \"walled\"\nwidth = 4.0\nheight = 3.0\nstart = {{ x = 0.4, y = 1.5, heading = 0.0 }}\n\
             goal = {{ x = 3.6, y = 1.5 }}\ngoal_radius = 0.15\ntones = [{}]\n\n\
             [[obstacles]]\nx0 = 0.9\ny0 = 0.0\nx1 = 0.94\ny1 = 3.0\n",
            tones.join(", ")
        );
        std::fs::write(&scenario, text).expect("scenario");
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy/lab/launch-ros2-robots.toml");
        let shipped = std::fs::read_to_string(shipped).expect("launch-ros2-robots.toml");
        let config = dir.join("launch.toml");
        std::fs::write(&config, shipped.replace("tcp/127.0.0.1:7447", endpoint)).expect("config");
        Self { robots, scenario, config, endpoint: endpoint.into() }
    }

    /// The emulated lab of swarm `swarm`.
    fn start(&self, swarm: &str) -> Proc {
        let args = [
            "lab",
            "--scenario",
            path(&self.scenario),
            "--robots",
            path(&self.robots),
            "--swarm",
            swarm,
            "--speed",
            "1",
            "--seed",
            "3",
            "--ros2-router",
            &self.endpoint,
        ];
        Proc::start(&bin("sim-agent"), &args.map(String::from))
    }

    /// The launch of swarm `swarm` over the lab, its run `time_limit_s`
    /// long, with `extra` flags.
    fn launch(&self, swarm: &str, time_limit_s: u32, extra: &[&str]) -> Proc {
        let (n, limit) = (ROBOTS.to_string(), time_limit_s.to_string());
        let args = [
            "launch",
            "--config",
            path(&self.config),
            "--agents",
            "real",
            "--robots-file",
            path(&self.robots),
            "--lab-scenario",
            path(&self.scenario),
            "--robots",
            &n,
            "--speed",
            "1",
            "--time-limit",
            &limit,
            "--swarm",
            swarm,
            "--json",
        ];
        Proc::orchestrator(&[&args[..], extra].concat())
    }
}

fn path(p: &Path) -> &str {
    p.to_str().expect("utf-8")
}

/// One agent process as watched: its CPU ticks and when it was seen.
struct Watched {
    robot: u32,
    ticks: u64,
    first: Instant,
    last: Instant,
}

/// Reads every agent's CPU time until the launch ends.
fn watch_agents(swarm: &str, launch: &Proc) -> BTreeMap<u32, Watched> {
    let mut agents: BTreeMap<u32, Watched> = BTreeMap::new();
    let started = Instant::now();
    while !is_zombie(launch.pid()) && started.elapsed() < WAIT * 5 {
        let now = Instant::now();
        for (pid, robot) in agents_of(swarm) {
            let Some(ticks) = bycoms_bench::procfs::cpu_ticks(&pid.to_string()) else { continue };
            let w = agents.entry(pid).or_insert(Watched { robot, ticks, first: now, last: now });
            (w.ticks, w.last) = (ticks, now);
        }
        std::thread::sleep(CPU_EVERY);
    }
    agents
}

/// The swarm figure: one launch of [`ROBOTS`] robots for [`SWARM_TIME_LIMIT_S`].
fn swarm_figure(lab: &Lab, seen: &Receiver<Seen>) {
    let swarm = swarm_name("r2swarm");
    let lab_proc = lab.start(&swarm);
    let launch = lab.launch(&swarm, SWARM_TIME_LIMIT_S, &SWARM_GATE);
    let agents = watch_agents(&swarm, &launch);
    let done = launch.wait(WAIT);
    let lab_cpu = bycoms_bench::procfs::cpu_ticks(&lab_proc.pid().to_string());
    end_lab(lab_proc);
    let commands: Vec<Seen> = seen.try_iter().collect();
    print_swarm(&done, &agents, &commands, lab_cpu);
}

fn end_lab(lab: Proc) {
    signal(lab.pid(), Signal::SIGTERM);
    lab.wait(Duration::from_secs(20));
}

/// One robot's commands in spells: (commands, spells, missed periods, longest gap in a spell).
fn spells(times: &[Instant]) -> (usize, usize, u64, Duration) {
    let (mut spells, mut missed, mut longest) = (usize::from(!times.is_empty()), 0, Duration::ZERO);
    for pair in times.windows(2) {
        let gap = pair[1] - pair[0];
        if gap >= SPELL_GAP {
            spells += 1;
            continue;
        }
        longest = longest.max(gap);
        let periods = gap.as_secs_f64() / PERIOD.as_secs_f64();
        if periods >= 1.5 {
            missed += periods.round() as u64 - 1;
        }
    }
    (times.len(), spells, missed, longest)
}

fn print_swarm(done: &Finished, agents: &BTreeMap<u32, Watched>, commands: &[Seen], lab_cpu: Option<u64>) {
    let summary = done.json();
    let ends: Vec<String> = summary["robots"]
        .as_array()
        .map(|r| r.iter().map(|r| r["end"].as_str().unwrap_or("?").to_string()).collect())
        .unwrap_or_default();
    println!(
        "swarm: {ROBOTS} robots, {SWARM_TIME_LIMIT_S} s at real speed ({}); outcome {}",
        SWARM_GATE.join(" "),
        summary["outcome"]
    );
    println!("  ends: {}", ends.join(" "));
    let hz = nix::unistd::sysconf(nix::unistd::SysconfVar::CLK_TCK).ok().flatten().unwrap_or(100) as f64;
    println!("  robot  commands  spells  missed  longest gap ms  cpu s  cpu % of a core");
    let (mut total_missed, mut total_cpu, mut driven) = (0, 0.0, 0);
    for robot in 1..=ROBOTS {
        let times: Vec<Instant> = commands.iter().filter(|c| c.robot == robot).map(|c| c.at).collect();
        let driving = commands.iter().any(|c| c.robot == robot && (c.linear != 0.0 || c.angular != 0.0));
        // The last: the zero its agent sent as it ended.
        let (_, spells, missed, longest) = spells(times.split_last().map_or(&[][..], |(_, before)| before));
        let n = times.len();
        let w = agents.values().find(|w| w.robot == robot);
        let cpu = w.map_or(f64::NAN, |w| w.ticks as f64 / hz);
        let life = w.map_or(f64::NAN, |w| (w.last - w.first).as_secs_f64());
        println!(
            "  {robot:5}  {n:8}  {spells:6}  {missed:6}  {:14.1}  {cpu:5.2}  {:5.2}{}",
            longest.as_secs_f64() * 1e3,
            100.0 * cpu / life,
            if driving { "  (moved)" } else { "" }
        );
        (total_missed, total_cpu, driven) =
            (total_missed + missed, total_cpu + cpu, driven + usize::from(driving));
    }
    println!(
        "  {driven} robots were sent a non-zero command; missed periods in all: {total_missed}; agents' CPU in all {total_cpu:.2} s \
         ({:.3} s per robot); lab {:.2} s",
        total_cpu / f64::from(ROBOTS),
        lab_cpu.map_or(f64::NAN, |t| t as f64 / hz)
    );
}

/// How a round stops the launch.
#[derive(Clone, Copy, Debug)]
enum Way {
    /// `orchestrator stop --now --swarm S`.
    Cli,
    /// A call of the launch's `/emergency` ROS 2 service.
    Service,
}

/// The stop figure: `rounds` launches stopped each way.
fn stop_figure(lab: &Lab, router: &ZenohBus, seen: &Receiver<Seen>, rounds: usize) {
    let mut figures: BTreeMap<&str, Vec<Duration>> = BTreeMap::new();
    for round in 0..2 * rounds {
        let way = if round % 2 == 0 { Way::Cli } else { Way::Service };
        match stop_round(lab, router, seen, way) {
            Ok(all_zero) => figures.entry(way.name()).or_default().push(all_zero),
            Err(why) => println!("  stop round {round} ({}) left out: {why}", way.name()),
        }
    }
    println!("stop: → a zero on every one of the {ROBOTS} robots' cmd_vel (ms), {rounds} rounds each way");
    for (name, times) in &figures {
        let ns: Vec<u64> = times.iter().map(|d| d.as_nanos() as u64).collect();
        let ms = |q: f64| quantile(&ns, q).map_or(f64::NAN, |n| n as f64 / 1e6);
        let worst = ns.iter().max().map_or(f64::NAN, |&n| n as f64 / 1e6);
        println!(
            "  {name:22}  p50 {:.1}  p99 {:.1}  worst {worst:.1}  ({} rounds)",
            ms(0.5),
            ms(0.99),
            ns.len()
        );
    }
}

impl Way {
    fn name(self) -> &'static str {
        match self {
            Self::Cli => "orchestrator stop --now",
            Self::Service => "/emergency service",
        }
    }
}

/// One launch, stopped `way` once robot 1 drives: the time from the stop
/// until every robot's `cmd_vel` had a zero.
fn stop_round(lab: &Lab, router: &ZenohBus, seen: &Receiver<Seen>, way: Way) -> Result<Duration, String> {
    let swarm = swarm_name("r2stop");
    let lab_proc = lab.start(&swarm);
    let launch = lab.launch(&swarm, 600, &[]);
    let result = stop_when_driving(&swarm, router, seen, way);
    let done = launch.wait(WAIT);
    end_lab(lab_proc);
    let result = result?;
    if done.status.code() != Some(130) {
        return Err(format!("the launch exited {:?}, not 130: {}", done.status.code(), done.stderr));
    }
    Ok(result)
}

fn stop_when_driving(
    swarm: &str,
    router: &ZenohBus,
    seen: &Receiver<Seen>,
    way: Way,
) -> Result<Duration, String> {
    let deadline = Instant::now() + WAIT;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match seen.recv_timeout(left) {
            Ok(c) if c.robot == 1 && c.linear > 0.0 => break,
            Ok(_) => {}
            Err(_) => return Err("robot 1 did not drive".into()),
        }
    }
    let t0 = Instant::now();
    let stopper = match way {
        Way::Cli => Some(Proc::orchestrator(&["stop", "--now", "--swarm", swarm])),
        Way::Service => {
            call_emergency(router)?;
            None
        }
    };
    let mut zero: BTreeMap<u32, Instant> = BTreeMap::new();
    while zero.len() < ROBOTS as usize {
        let left = (t0 + Duration::from_secs(5)).saturating_duration_since(Instant::now());
        match seen.recv_timeout(left) {
            Ok(c) if c.at >= t0 && c.linear == 0.0 && c.angular == 0.0 => {
                zero.entry(c.robot).or_insert(c.at);
            }
            Ok(_) => {}
            Err(_) => return Err(format!("zeros from {} of {ROBOTS} robots within 5 s", zero.len())),
        }
    }
    if let Some(stopper) = stopper {
        stopper.wait(WAIT);
    }
    Ok(zero.values().max().map_or(Duration::ZERO, |last| *last - t0))
}

/// Calls `/emergency` (`std_srvs/srv/Trigger`) as rmw_zenoh's client does:
/// a get on the service's key with the request in CDR and an attachment.
fn call_emergency(router: &ZenohBus) -> Result<(), String> {
    let key = topic_key_expr(0, "/emergency", TRIGGER.name, &TRIGGER.rihs01());
    let attachment = Attachment { sequence_number: 1, source_timestamp_ns: 0, gid: [7; 16] };
    router
        .session()
        .get(key)
        .payload(TriggerRequest.to_cdr())
        .attachment(attachment.encode().to_vec())
        .callback(|_| {})
        .wait()
        .map_err(|e| format!("the /emergency call: {e}"))
}
