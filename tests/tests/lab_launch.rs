//! The paper's lab experiments end to end through `orchestrator launch
//! --agents real`: the test starts the emulated lab (`sim-agent lab`, one
//! emulated ESP32 per robot behind a real UDP socket, true poses on the bus
//! as simulated motion capture), and the launch starts one `gateway`
//! per robot, asks the operator (the lab's emulated one) to place each
//! robot at the start, enables it, sends it goal bearings in the lab's
//! frame and judges it from poses alone with the real-robot gate settings
//! of `deploy/lab/launch.toml`.
//!
//! Every process is killed and reaped on drop ([`Proc`]); every wait has a
//! deadline; swarm names are unique. UDP ports for the robots file are
//! taken by binding port 0 and releasing it (the robots file names fixed
//! addresses, as a real robot's flashed settings). At most two run at once
//! ([`TURNS`]): the lab runs `SPEED` times faster than real time and must
//! never stall, yet a whole lab run (lab, launch, gateways) uses under a
//! tenth of a core here (`ps` over an exp-short run: 3–4 % the lab, 2 % the
//! orchestrator, 1–2 % each gateway), so two leave most of both cores to
//! the other tests. The last two run the experiments with the lab
//! seen through NatNet (`--natnet`) and replay their recordings; exp-long
//! runs there and once more with its poses from a ROS 2 driver (every
//! other run reads poses from the bus).

mod mixed;

use bycoms_protocol::fault::FaultConfig;
use bycoms_protocol::link::proxy::LinkProxy;
use bycoms_tests::{agents_of, bin, is_zombie, signal, swarm_name, wait_for, wait_for_pose, Finished, Proc};
use nix::sys::signal::Signal;
use serde_json::Value;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// Lab time per wall time (the launch and its gateways are told the same).
/// The gateways report a link lost after 300 ms of lab time without a
/// robot frame, 100 ms of wall time at 3×: the lab (debug build, sound for
/// every microphone) must never stall that long, and keeps up at 3× on two
/// busy cores.
const SPEED: f64 = 3.0;
/// NatNet frames per second of lab time (Motive's default is 120; 60 keeps
/// the debug-built orchestrator's decoding light at 3× real time).
pub(crate) const NATNET_HZ: &str = "60";

/// Lab runs at once, at most.
const AT_ONCE: u32 = 2;

/// Turns to run a lab: a counting semaphore of [`AT_ONCE`].
static TURNS: (Mutex<u32>, Condvar) = (Mutex::new(0), Condvar::new());

/// A turn to run a lab, given back on drop.
struct Turn;

impl Turn {
    fn take() -> Self {
        let (count, freed) = &TURNS;
        let mut running = count.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        while *running >= AT_ONCE {
            running = freed.wait(running).unwrap_or_else(std::sync::PoisonError::into_inner);
        }
        *running += 1;
        Turn
    }
}

impl Drop for Turn {
    fn drop(&mut self) {
        let (count, freed) = &TURNS;
        *count.lock().unwrap_or_else(std::sync::PoisonError::into_inner) -= 1;
        freed.notify_one();
    }
}

use bycoms_tests::{free_udp_port as free_port, TEST_KEYS as KEYS};

fn unix_ms() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).expect("clock").as_millis() as u64
}

/// Writes robots file `name` in `dir`: robot k at `robots[k-1]`, its
/// gateway at `gateways[k-1]`, its key file `robot-k.key` (written too).
fn write_robots(dir: &Path, name: &str, robots: &[SocketAddr], gateways: &[SocketAddr]) -> PathBuf {
    let mut text = String::new();
    for (i, (robot, gateway)) in robots.iter().zip(gateways).enumerate() {
        let id = i + 1;
        std::fs::write(dir.join(format!("robot-{id}.key")), KEYS[i]).expect("key file");
        text += &format!(
            "[[robot]]\nid = {id}\naddress = \"{robot}\"\ngateway = \"{gateway}\"\nkey_file = \"robot-{id}.key\"\n"
        );
    }
    let path = dir.join(name);
    std::fs::write(&path, text).expect("robots file");
    path
}

/// A lab of `n` robots on free ports: (robots file, robot addresses, gateway addresses).
fn robots_file(dir: &Path, n: usize) -> (PathBuf, Vec<SocketAddr>, Vec<SocketAddr>) {
    let robots: Vec<SocketAddr> = (0..n).map(|_| free_port()).collect();
    let gateways: Vec<SocketAddr> = (0..n).map(|_| free_port()).collect();
    (write_robots(dir, "robots.toml", &robots, &gateways), robots, gateways)
}

fn lab(swarm: &str, scenario: &str, robots: &Path) -> Proc {
    lab_with(swarm, scenario, robots, &[])
}

fn lab_with(swarm: &str, scenario: &str, robots: &Path, extra: &[&str]) -> Proc {
    let robots = robots.to_str().expect("utf-8");
    let speed = SPEED.to_string();
    let args = [
        "lab",
        "--scenario",
        scenario,
        "--robots",
        robots,
        "--swarm",
        swarm,
        "--speed",
        &speed,
        "--seed",
        "3",
    ];
    let args: Vec<String> = args.iter().chain(extra).map(|s| s.to_string()).collect();
    Proc::start(&bin("sim-agent"), &args)
}

fn shipped(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy/lab").join(file)
}

/// `orchestrator launch --agents real` over the lab, with the shipped
/// real-robot settings (`deploy/lab/launch.toml`).
fn launch(swarm: &str, scenario: &str, robots: u32, robots_file: &Path) -> Proc {
    launch_with(&shipped("launch.toml"), swarm, scenario, robots, robots_file, &[])
}

fn launch_with(config: &Path, swarm: &str, scenario: &str, robots: u32, file: &Path, extra: &[&str]) -> Proc {
    let (n, speed) = (robots.to_string(), SPEED.to_string());
    let config = config.to_str().expect("utf-8");
    let file = file.to_str().expect("utf-8");
    let args = [
        "launch",
        "--config",
        config,
        "--agents",
        "real",
        "--robots-file",
        file,
        "--lab-scenario",
        scenario,
        "--robots",
        &n,
        "--speed",
        &speed,
        "--swarm",
        swarm,
        "--json",
    ];
    Proc::orchestrator(&[&args[..], extra].concat())
}

/// The lab's JSON summary after SIGTERM.
fn lab_summary(lab: Proc) -> Value {
    signal(lab.pid(), Signal::SIGTERM);
    lab.wait(Duration::from_secs(20)).json()
}

/// Asserts that the launch ended with a robot at the goal (exit 0); if not,
/// fails with the launch's log and the lab's (its summary says how late it
/// ran and what each firmware did), and the lab is ended. Returns the lab.
fn assert_arrived(out: &Finished, lab: Proc) -> Proc {
    if out.status.code() == Some(0) {
        return lab;
    }
    signal(lab.pid(), Signal::SIGTERM);
    let lab = lab.wait(Duration::from_secs(20));
    let tail: Vec<&str> = lab.stderr.lines().rev().take(40).collect();
    let tail: Vec<&str> = tail.into_iter().rev().collect();
    panic!(
        "no robot arrived ({:?}):\n{}\n--- lab summary:\n{}\n--- lab log (last 40 lines):\n{}",
        out.status.code(),
        out.stderr,
        lab.stdout,
        tail.join("\n")
    );
}

fn ends(j: &Value) -> Vec<&str> {
    j["robots"].as_array().expect("robots").iter().map(|r| r["end"].as_str().unwrap_or("?")).collect()
}

/// Nothing of the swarm is left running (gateways carry `--swarm` and `--robot`).
fn assert_no_gateway_left(swarm: &str) {
    let left = wait_for(Duration::from_secs(5), || agents_of(swarm).is_empty().then_some(()));
    assert!(left.is_some(), "gateways left behind: {:?}", agents_of(swarm));
}

#[test]
fn exp_short_robot_1_sticks_at_the_frame_and_robot_2_reaches_the_goal() {
    let _turn = Turn::take();
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = swarm_name("labshort");
    let (robots, _, _) = robots_file(dir.path(), 2);
    let lab = lab(&swarm, "exp-short", &robots);
    let out = launch(&swarm, "exp-short", 2, &robots).wait(Duration::from_secs(120));
    let lab = assert_arrived(&out, lab);
    let j = out.json();
    assert_eq!(ends(&j), ["stuck", "arrived"], "{j}");
    let (x1, y1) = (j["robots"][0]["x"].as_f64().expect("x"), j["robots"][0]["y"].as_f64().expect("y"));
    // The frame spans x 1.5–1.54, y 0.7–1.3; the body's radius is 0.128 m.
    assert!((1.3..1.5).contains(&x1) && (0.6..1.4).contains(&y1), "robot 1 at the frame: ({x1}, {y1})");
    let (x2, y2) = (j["robots"][1]["x"].as_f64().expect("x"), j["robots"][1]["y"].as_f64().expect("y"));
    assert!((x2 - 2.6).hypot(y2 - 1.0) <= 0.15, "robot 2 within the goal radius: ({x2}, {y2})");
    assert_eq!(j["beacons"].as_array().map(Vec::len), Some(1), "{j}");
    // Each robot was placed by the operator when asked, then enabled.
    for k in [1, 2] {
        assert!(out.stderr.contains(&format!("OPERATOR: place robot {k} at the start")), "{}", out.stderr);
    }
    assert_no_gateway_left(&swarm);
    let lab = lab_summary(lab);
    let r = &lab["robots"];
    assert_eq!((&r[0]["stuck"], &r[1]["stuck"]), (&Value::Bool(true), &Value::Bool(false)), "{lab}");
    assert_eq!(r[0]["state"], "Stopped", "a stuck real robot is stopped (a beacon): {lab}");
}

#[test]
fn a_cut_robot_link_makes_the_robot_a_beacon_within_500_ms_and_the_next_robot_goes() {
    let _turn = Turn::take();
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = swarm_name("labcut");
    // Robot 1 talks to its gateway through a fault proxy the test can cut:
    // the lab's robots file names the proxy as robot 1's gateway, the
    // launch's the gateway itself.
    let robots: Vec<SocketAddr> = (0..2).map(|_| free_port()).collect();
    let gateways: Vec<SocketAddr> = (0..2).map(|_| free_port()).collect();
    let proxy = LinkProxy::start(gateways[0], FaultConfig::none(0)).expect("proxy");
    let lab_file = write_robots(dir.path(), "lab.toml", &robots, &[proxy.robot_side(), gateways[1]]);
    let launch_file = write_robots(dir.path(), "robots.toml", &robots, &gateways);
    let lab = lab(&swarm, "exp-short", &lab_file);
    let run = launch(&swarm, "exp-short", 2, &launch_file);
    // Cut once robot 1 drives (it has left the start by 20 cm).
    wait_for_pose(&swarm, 2, 1, Duration::from_secs(60), |p| p.x > 0.6).expect("robot 1 drives");
    let cut_ms = unix_ms();
    proxy.set_cut(true);
    let out = run.wait(Duration::from_secs(120));
    assert!(matches!(out.status.code(), Some(0 | 3)), "the launch ends normally:\n{}", out.stderr);
    let j = out.json();
    let r1 = &j["robots"][0];
    assert_eq!(r1["end"], "died", "{j}");
    let reason = r1["death"]["reason"].as_str().unwrap_or_default();
    assert!(reason.contains("link"), "{reason}");
    let noticed = r1["death"]["noticed_unix_ms"].as_u64().expect("death time");
    let after = noticed.saturating_sub(cut_ms);
    assert!(after < 500, "the gate applied its lost-robot policy {after} ms after the cut");
    // Where it was last seen is a beacon, and robot 2 was deployed next.
    assert_eq!(j["beacons"][0]["x"], r1["x"], "{j}");
    assert!(j["robots"][1]["deployed_tick"].is_u64(), "robot 2 went next: {j}");
    assert!(proxy.stats().cut > 0, "datagrams were cut");
    assert_no_gateway_left(&swarm);
    // Robot 1's firmware heard nothing more: its failsafe stopped its motors.
    let lab = lab_summary(lab);
    assert_eq!(lab["robots"][0]["state"], "Failsafe", "{lab}");
}

#[test]
fn killing_a_gateway_then_the_lab_ends_the_launch_saying_motion_capture_is_gone_and_leaves_no_process() {
    let _turn = Turn::take();
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = swarm_name("labkill");
    let (robots, _, _) = robots_file(dir.path(), 3);
    let mut lab = lab(&swarm, "exp-long", &robots);
    let run = launch(&swarm, "exp-long", 3, &robots);
    let gateway = |k: u32| {
        wait_for(Duration::from_secs(30), || {
            agents_of(&swarm).into_iter().find(|(_, r)| *r == k).map(|(p, _)| p)
        })
        .unwrap_or_else(|| panic!("robot {k}'s gateway never appeared"))
    };
    let first = gateway(1);
    // Killed half way to the frame (clear of the start, so robot 2 can pass).
    wait_for_pose(&swarm, 3, 1, Duration::from_secs(60), |p| p.x > 1.0).expect("robot 1 drives");
    signal(first, Signal::SIGKILL);
    // Robot 2 is asked for and placed; once it drives, the whole lab dies.
    wait_for_pose(&swarm, 3, 2, Duration::from_secs(60), |p| p.x > 0.5).expect("robot 2 drives");
    let lab_pid = lab.pid();
    lab.kill();
    let out = run.wait(Duration::from_secs(60));
    // The room is gone, not robot 2's link: said as such (an error, exit 1).
    assert_eq!(out.status.code(), Some(1), "motion capture gone:\n{}", out.stderr);
    let j = out.json();
    assert_eq!(j["outcome"], "error", "{j}");
    let error = j["error"].as_str().unwrap_or_default();
    assert!(error.starts_with("motion capture gone: no pose of any robot for "), "{j}");
    assert!(error.contains("link was lost with it"), "said at the first lost link: {j}");
    assert!(out.stderr.contains(error), "the error is said:\n{}", out.stderr);
    assert_eq!(ends(&j), ["died", "moving", "not_deployed"], "{j}");
    assert!(j["robots"][0]["death"]["reason"].as_str().unwrap_or_default().contains("signal: 9"), "{j}");
    assert!(j["robots"][1]["death"].is_null(), "robot 2 is not judged dead for its link: {j}");
    drop(lab);
    assert!(is_zombie(lab_pid) && is_zombie(first), "the lab and the killed gateway are gone");
    assert_no_gateway_left(&swarm);
}

/// Gateways that cannot bind their robots' UDP ports (another program
/// holds them): each is started once more, then its robot is absent; with
/// no robot left the launch ends (exit 1), and its error gives the
/// gateway's own reason, not only its exit status. No lab: no robot could
/// reach its gateway anyway.
#[test]
fn gateways_that_cannot_bind_end_the_launch_with_the_real_reason() {
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = swarm_name("labbind");
    let (robots, _, gateways) = robots_file(dir.path(), 2);
    let held: Vec<std::net::UdpSocket> =
        gateways.iter().map(|a| std::net::UdpSocket::bind(a).expect("hold the gateway's port")).collect();
    let out = launch(&swarm, "exp-short", 2, &robots).wait(Duration::from_secs(60));
    drop(held);
    assert_eq!(out.status.code(), Some(1), "{}", out.stderr);
    let error = out.stderr.lines().find(|l| l.contains("no agent ever registered")).unwrap_or_default();
    let bind = format!("cannot listen for robot 1 on {}: Address already in use", gateways[0]);
    assert!(error.contains("its process ended") && error.contains(&bind), "{}", out.stderr);
    assert!(out.stderr.contains("starting it once more"), "started once more first:\n{}", out.stderr);
    assert_no_gateway_left(&swarm);
}

/// The lab serves its bodies by NatNet (`--natnet`) and publishes no pose
/// on the bus; the launch reads them with `deploy/lab/launch-natnet.toml`
/// (its server address replaced by the test's free port), records the run,
/// and `orchestrator replay` re-runs the gate from the recording to the
/// same decisions.
fn natnet_run(scenario: &str, robots: u32, ends_expected: &[&str]) -> Finished {
    natnet_run_with(scenario, robots, ends_expected, None)
}

/// [`natnet_run`] with the cameras' faults (`sim-agent lab --natnet-faults`).
fn natnet_run_with(scenario: &str, robots: u32, ends_expected: &[&str], faults: Option<&str>) -> Finished {
    let _turn = Turn::take();
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = swarm_name("labnatnet");
    let (file, _, _) = robots_file(dir.path(), robots as usize);
    let natnet = free_port().to_string();
    let text = std::fs::read_to_string(shipped("launch-natnet.toml")).expect("launch-natnet.toml");
    assert!(text.contains("server = \"127.0.0.1:1510\""), "the shipped file names Motive's port");
    let config = dir.path().join("launch.toml");
    std::fs::write(&config, text.replace("127.0.0.1:1510", &natnet)).expect("config");
    let faults_file = dir.path().join("faults.toml");
    let mut extra = vec!["--natnet", &natnet, "--natnet-rate", NATNET_HZ];
    if let Some(text) = faults {
        std::fs::write(&faults_file, text).expect("faults file");
        extra.extend(["--natnet-faults", faults_file.to_str().expect("utf-8")]);
    }
    let lab = lab_with(&swarm, scenario, &file, &extra);
    let record = dir.path().join("run.mcap");
    let record = record.to_str().expect("utf-8");
    let out = launch_with(&config, &swarm, scenario, robots, &file, &["--record", record])
        .wait(Duration::from_secs(180));
    let lab = assert_arrived(&out, lab);
    let j = out.json();
    assert_eq!(ends(&j), ends_expected, "{j}");
    assert_no_gateway_left(&swarm);
    let lab = lab_summary(lab);
    let stuck: Vec<bool> =
        (0..robots as usize).map(|k| lab["robots"][k]["stuck"].as_bool().unwrap_or(false)).collect();
    let expected: Vec<bool> = ends_expected.iter().map(|e| *e == "stuck").collect();
    assert_eq!(stuck, expected, "the lab's own account of who stuck: {lab}");
    // The gate's decisions follow from the recorded mocap poses.
    let replay = Proc::orchestrator(&["replay", record]).wait(Duration::from_secs(60));
    assert_eq!(replay.status.code(), Some(0), "{}\n{}", replay.stdout, replay.stderr);
    assert!(replay.stdout.contains("MATCH:"), "{}", replay.stdout);
    let decisions = 2 * ends_expected.len();
    assert_eq!(replay.stdout.matches("  same ").count(), decisions, "{}", replay.stdout);
    // Its picture tells the summary's time (NatNet's frames are recorded before the gate
    // judges them: the picture once took a later frame for the start, issue 31).
    let svg = dir.path().join("run.svg");
    let drawn = Proc::orchestrator(&["draw", record, "--out", svg.to_str().expect("utf-8")])
        .wait(Duration::from_secs(60));
    assert_eq!(drawn.status.code(), Some(0), "{}", drawn.stderr);
    let picture = std::fs::read_to_string(&svg).expect("the picture");
    let time = format!("after {:.1} s", j["time_s"].as_f64().expect("time_s"));
    assert!(
        picture.contains(&time),
        "the picture's title says {time}: {}",
        &picture[..picture.len().min(600)]
    );
    out
}

/// exp-short over NatNet with everything the cameras get wrong at once:
/// they lose a fifth of all frames and robot 2's body for 1 s in every 4 s
/// (tracking-valid off, as Motive reports it), and swap robot 1's and robot
/// 2's ids for 0.3 s in every 6 s (the paper's 3-robot run mistook robot 1
/// for robot 3 this way). The gate never takes a lost body for a stopped
/// robot; each swapped pose jumps farther than a crawler can drive, so it is
/// rejected and warned about, and no robot is judged from the other's pose.
/// So the outcome is the faultless one — robot 1 stuck at the frame, robot
/// 2 arrived — the losses and swaps are reported, and the recording replays
/// to the same decisions (`natnet_run_with`). One run for what used to be
/// three (faultless, losses, swaps): a lab run is the slowest thing CI does.
#[test]
fn exp_short_over_natnet_keeps_its_outcome_with_lost_frames_occlusions_and_swapped_ids() {
    let mut faults = String::from("seed = 7\nframe_loss = 0.2\n");
    for k in 0..40 {
        let from = 4 * k + 2;
        faults += &format!("[[occlusions]]\nid = 2\nfrom_s = {from}.0\nto_s = {}.0\n", from + 1);
    }
    for k in 0..30 {
        let from = 6.0 * f64::from(k) + 4.0;
        faults += &format!("[[swaps]]\na = 1\nb = 2\nfrom_s = {from:.1}\nto_s = {:.1}\n", from + 0.3);
    }
    let out = natnet_run_with("exp-short", 2, &["stuck", "arrived"], Some(&faults));
    assert!(out.stderr.contains("mocap body robot2"), "robot 2's occlusions are reported:\n{}", out.stderr);
    assert!(out.stderr.contains("identity swap"), "the swaps are warned about:\n{}", out.stderr);
    let j = out.json();
    let x1 = j["robots"][0]["x"].as_f64().expect("robot 1's x");
    assert!((1.2..1.5).contains(&x1), "robot 1 is judged where it stuck at the frame, not at robot 2: {j}");
}

/// exp-long, the paper's second experiment, end to end: robots 1 and 2
/// stick (robot 2 bypassing robot 1 on the upper side), robot 3 reaches the
/// goal, and the recording replays to the same decisions. Run once, over
/// NatNet: the bus pose source is what the exp-short, cut and kill runs
/// use, so a second exp-long over the bus (31 s) would test no other code.
#[test]
fn exp_long_over_natnet_reaches_the_goal_and_replays_to_the_same_decisions() {
    let out = natnet_run("exp-long", 3, &["stuck", "stuck", "arrived"]);
    let j = out.json();
    let y = |k: usize| j["robots"][k]["y"].as_f64().expect("y");
    assert!(y(1) > y(0) + 0.3, "robot 2 bypassed robot 1 on the upper side: {j}");
    let (x3, y3) = (j["robots"][2]["x"].as_f64().expect("x"), y(2));
    assert!((x3 - 3.0).hypot(y3 - 1.0) <= 0.15, "robot 3 within the goal radius: ({x3}, {y3})");
}

/// A ROS 2 motion-capture driver that is not ours
/// (`tests/python/ros2_mocap_driver.py`: OptiTrack's Python NatNet client,
/// eclipse-zenoh, rosbags, xxhash) and the lab's router it runs, killed
/// and reaped on drop.
struct Ros2Driver {
    child: std::process::Child,
    stdin: Option<std::process::ChildStdin>,
    lines: std::sync::mpsc::Receiver<String>,
}

impl Ros2Driver {
    fn start(natnet_port: u16, router: &str, topics: &[String]) -> Self {
        use std::process::{Command, Stdio};
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/ros2_mocap_driver.py");
        let mut child = Command::new("python3")
            .arg(&script)
            .args([&natnet_port.to_string(), router, "0"])
            .args(topics)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("python3 starts");
        let lines = bycoms_tests::stdout_lines(&mut child);
        let stdin = child.stdin.take();
        Self { child, stdin, lines }
    }

    fn line(&self, what: &str) -> String {
        let wait = Duration::from_secs(60);
        self.lines
            .recv_timeout(wait)
            .unwrap_or_else(|_| panic!("the ROS 2 driver printed no {what} within 60 s"))
    }

    /// What it published, once told the run is over.
    fn report(&mut self) -> Value {
        use std::io::Write;
        let mut stdin = self.stdin.take().expect("stdin");
        stdin.write_all(b"done\n").expect("write to the driver");
        drop(stdin);
        serde_json::from_str(&self.line("report")).expect("the report is JSON")
    }
}

impl Drop for Ros2Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// exp-long with its motion capture from ROS 2: the emulated lab serves
/// its bodies by NatNet, and an independent ROS 2 driver (Python:
/// OptiTrack's own NatNet client, rosbags' CDR, rmw_zenoh's keys, tokens
/// and attachments made by hand) republishes each as a `PoseStamped` on
/// `/vrpn_mocap/robot<k>/pose`, Z up, stamped with the mocap frame's time,
/// on the lab's router it runs (rmw_zenohd's place). The launch, with the
/// shipped `deploy/lab/launch-ros2.toml` (its router endpoint replaced by
/// the test's), joins that router as a zenoh client, finds the graph,
/// takes every robot's poses from those topics and runs the experiment to
/// its outcome: robots 1 and 2 stuck, robot 3 at the goal; its recording
/// replays to the same decisions, and the driver sees the launch's
/// subscriptions in the graph.
#[test]
#[ignore = "needs python3 with eclipse-zenoh==1.10.2, rosbags==0.11.9, xxhash==4.1.0 and natnetsdk==4.1.1"]
fn exp_long_with_poses_from_a_ros2_mocap_driver_reaches_the_goal() {
    let _turn = Turn::take();
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = swarm_name("labros2");
    let (file, _, _) = robots_file(dir.path(), 3);
    let natnet = free_port();
    let natnet_flag = natnet.to_string();
    let lab = lab_with(&swarm, "exp-long", &file, &["--natnet", &natnet_flag, "--natnet-rate", NATNET_HZ]);
    // The lab router's port: free when asked (the driver binds it at once).
    let port = std::net::TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port();
    let router = format!("tcp/127.0.0.1:{port}");
    let topics: Vec<String> = (1..=3).map(|k| format!("{k}=/vrpn_mocap/robot{k}/pose")).collect();
    let mut driver = Ros2Driver::start(natnet.port(), &router, &topics);
    assert_eq!(driver.line("ready line"), "ready");
    let text = std::fs::read_to_string(shipped("launch-ros2.toml")).expect("launch-ros2.toml");
    assert!(text.contains("router = \"tcp/127.0.0.1:7447\""), "the shipped file names rmw_zenohd's port");
    let config = dir.path().join("launch.toml");
    std::fs::write(&config, text.replace("tcp/127.0.0.1:7447", &router)).expect("config");
    let record = dir.path().join("run.mcap");
    let record = record.to_str().expect("utf-8");
    let out = launch_with(&config, &swarm, "exp-long", 3, &file, &["--record", record])
        .wait(Duration::from_secs(180));
    let lab = assert_arrived(&out, lab);
    let j = out.json();
    assert_eq!(ends(&j), ["stuck", "stuck", "arrived"], "{j}");
    // The trusted poses are recorded: the gate re-runs from them to the same decisions.
    let replay = Proc::orchestrator(&["replay", record]).wait(Duration::from_secs(60));
    assert_eq!(replay.status.code(), Some(0), "{}\n{}", replay.stdout, replay.stderr);
    assert!(replay.stdout.contains("MATCH:"), "{}", replay.stdout);
    assert_eq!(replay.stdout.matches("  same ").count(), 6, "{}", replay.stdout);
    let (x3, y3) = (j["robots"][2]["x"].as_f64().expect("x"), j["robots"][2]["y"].as_f64().expect("y"));
    assert!((x3 - 3.0).hypot(y3 - 1.0) <= 0.15, "robot 3 within the goal radius: ({x3}, {y3})");
    assert!(out.stderr.contains("connected to the ROS 2 router as a zenoh client"), "{}", out.stderr);
    assert!(out.stderr.contains("the ROS 2 graph is there"), "{}", out.stderr);
    assert!(!out.stderr.contains("nobody publishes"), "every topic has its publisher:\n{}", out.stderr);
    let report = driver.report();
    let hash = report["type_hash"].as_str().expect("rosbags' hash of PoseStamped");
    for k in 1..=3 {
        let topic = format!("/vrpn_mocap/robot{k}/pose");
        let sent = report["published"][&topic].as_u64().unwrap_or(0);
        assert!(sent > 0, "robot {k}'s poses were published: {report}");
        // The launch's subscription, as `ros2 topic info` would list it.
        let seen = serde_json::json!(["bycoms_mocap", topic, "geometry_msgs::msg::dds_::PoseStamped_", hash]);
        let subscriptions = report["subscriptions"].as_array().expect("subscriptions");
        assert!(subscriptions.contains(&seen), "the graph sees {seen}: {report}");
    }
    assert_no_gateway_left(&swarm);
    let lab = lab_summary(lab);
    let stuck: Vec<bool> = (0..3).map(|k| lab["robots"][k]["stuck"].as_bool().unwrap_or(false)).collect();
    assert_eq!(stuck, [true, true, false], "the lab's own account of who stuck: {lab}");
}

/// The lab's ROS 2 router (rmw_zenohd's place), held by the test: a zenoh
/// router on a free loopback port, and its endpoint.
fn ros2_router() -> (bycoms_protocol::bus::zenoh::ZenohBus, String) {
    use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
    ZenohBus::loopback_router(|endpoint| ZenohConfig {
        mode: Mode::Router,
        listen: vec![endpoint.to_string()],
        ..ZenohConfig::default()
    })
    .expect("the lab's ROS 2 router")
}

/// A lab experiment with ROS 2 robot bodies (issue 50): the emulated lab
/// holds one differential-drive body per robot of the shipped
/// `deploy/lab/ros2-robots.toml`, each following the `cmd_vel` it reads on
/// the lab's router; the launch, with the shipped
/// `deploy/lab/launch-ros2-robots.toml` (its router replaced by the
/// test's), starts one `ros2-robot` agent per robot, which senses the
/// field virtually and publishes its commands there. The paper's outcome
/// follows, the recording replays to the same decisions, the lab counted
/// every robot's commands, and the recording exported as a ROS 2 bag
/// holds every one of them on its robot's `cmd_vel` (robot 2's driver
/// takes `TwistStamped` here, the others `Twist`).
fn ros2_robots_run(scenario: &str, robots: u32, ends_expected: &[&str], read: BagRead) -> (Value, Value) {
    let _turn = Turn::take();
    let lab = Ros2Lab::start(scenario);
    let record = lab.dir.path().join("run.mcap");
    let record = record.to_str().expect("utf-8");
    let out = lab.launch(robots, &["--record", record]).wait(Duration::from_secs(240));
    let done = assert_arrived(&out, lab.lab);
    let j = out.json();
    assert_eq!(ends(&j), ends_expected, "{j}");
    let replay = Proc::orchestrator(&["replay", record]).wait(Duration::from_secs(60));
    assert_eq!(replay.status.code(), Some(0), "{}\n{}", replay.stdout, replay.stderr);
    assert!(replay.stdout.contains("MATCH:"), "{}", replay.stdout);
    assert_no_gateway_left(&lab.swarm);
    let summary = lab_summary(done);
    assert_every_command_is_in_the_bag(record, &lab.dir.path().join("bag.mcap"), robots, &summary, read);
    (j, summary)
}

/// The emulated lab of ROS 2 bodies on a router of the test's, and the
/// shipped launch configuration pointed at that router; the shipped robots
/// file but for robot 2, whose driver takes `TwistStamped` here (the
/// others `Twist`).
struct Ros2Lab {
    dir: tempfile::TempDir,
    swarm: String,
    scenario: String,
    config: PathBuf,
    file: PathBuf,
    lab: Proc,
    _router: bycoms_protocol::bus::zenoh::ZenohBus,
}

impl Ros2Lab {
    fn start(scenario: &str) -> Self {
        let dir = tempfile::tempdir().expect("temp dir");
        let swarm = swarm_name("labros2bots");
        let (router, endpoint) = ros2_router();
        let shipped_robots = std::fs::read_to_string(shipped("ros2-robots.toml")).expect("ros2-robots.toml");
        let robot_2 = "id = 2\nkind = \"ros2\"\n";
        assert!(shipped_robots.contains(robot_2), "{shipped_robots}");
        let file = dir.path().join("ros2-robots.toml");
        let stamped = shipped_robots.replace(robot_2, &format!("{robot_2}message = \"twist-stamped\"\n"));
        std::fs::write(&file, stamped).expect("robots file");
        let lab = lab_with(&swarm, scenario, &file, &["--ros2-router", &endpoint]);
        let text =
            std::fs::read_to_string(shipped("launch-ros2-robots.toml")).expect("launch-ros2-robots.toml");
        assert!(text.contains("router = \"tcp/127.0.0.1:7447\""), "the shipped file names rmw_zenohd's port");
        let config = dir.path().join("launch.toml");
        std::fs::write(&config, text.replace("tcp/127.0.0.1:7447", &endpoint)).expect("config");
        Self { dir, swarm, scenario: scenario.to_owned(), config, file, lab, _router: router }
    }

    fn launch(&self, robots: u32, extra: &[&str]) -> Proc {
        launch_with(&self.config, &self.swarm, &self.scenario, robots, &self.file, extra)
    }
}

/// How an exported bag of a ROS 2 robots' run is read: counted here (the
/// `mcap` crate: channels, types, messages), or also decoded message by
/// message by readers that are not ours (`tests/python/ros2_bag.py`:
/// `mcap-ros2-support` and rosbags; `#[ignore]`d tests only).
#[derive(Clone, Copy, PartialEq, Eq)]
enum BagRead {
    Counted,
    DecodedByPython,
}

/// Commands per `cmd_vel` topic in `bag`, with each topic's type; and per
/// robot, the `Commanded` reports in the recording at `record` (variant
/// index 10, the byte after the version).
fn bag_and_recording_commands(bag: &Path, record: &str) -> (Value, Value) {
    let bytes = std::fs::read(bag).expect("the bag");
    let (mut counts, mut types) = (serde_json::Map::new(), serde_json::Map::new());
    for m in mcap::MessageStream::new(&bytes).expect("a bag") {
        let m = m.expect("a message");
        if m.channel.topic.ends_with("/cmd_vel") {
            let n = counts.entry(m.channel.topic.clone()).or_insert(Value::from(0u64));
            *n = Value::from(n.as_u64().unwrap_or(0) + 1);
            let schema = m.channel.schema.as_ref().map_or("", |s| s.name.as_str());
            types.insert(m.channel.topic.clone(), Value::from(schema));
        }
    }
    let recording = std::fs::read(record).expect("the recording");
    let mut reported = serde_json::Map::new();
    for m in mcap::MessageStream::new(&recording).expect("a recording") {
        let m = m.expect("a message");
        let from_agent = m.channel.schema.as_ref().is_some_and(|s| s.name == "bycoms.FromAgent");
        if from_agent && m.data.get(1) == Some(&10) {
            let robot =
                m.channel.topic.split("/robot/").nth(1).and_then(|r| r.split('/').next()).expect("robot");
            let n = reported.entry(robot.to_string()).or_insert(Value::from(0u64));
            *n = Value::from(n.as_u64().unwrap_or(0) + 1);
        }
    }
    (serde_json::json!({ "counts": counts, "types": types }), Value::Object(reported))
}

/// `record export --ros2` of a ROS 2 robots' recording: each robot's
/// `cmd_vel` holds as many commands of its type as the lab's body
/// received (the last zero each agent sends as it ends included), and as its agent reported in the recording; with
/// [`BagRead::DecodedByPython`], `mcap-ros2-support` and rosbags decode
/// every one of them.
fn assert_every_command_is_in_the_bag(record: &str, bag: &Path, robots: u32, lab: &Value, read: BagRead) {
    let out = bag.to_str().expect("utf-8");
    let export = Proc::orchestrator(&["record", "export", "--ros2", record, "--out", out])
        .wait(Duration::from_secs(60));
    assert!(export.status.success(), "the export failed:\n{}", export.stderr);
    let (in_bag, reported) = bag_and_recording_commands(bag, record);
    for k in 1..=robots {
        let topic = format!("/robot_{k}/cmd_vel");
        let n = in_bag["counts"][&topic].as_u64().unwrap_or(0);
        let sent = reported[k.to_string()].as_u64().unwrap_or(0);
        // Every sample the lab's body got: followed, or for a robot not
        // placed on the arena (exp-long's robot 3, never deployed, sent a
        // zero as its agent ended), lost.
        let counted = &lab["robots"][k as usize - 1]["cmd_vel"];
        let received = ["commands", "unplaced"].iter().map(|c| counted[c].as_u64().expect("lab count")).sum();
        assert_eq!((n, sent), (received, received), "robot {k}: bag, recording, lab: {in_bag} {reported}");
        let wanted = if k == 2 { "geometry_msgs/msg/TwistStamped" } else { "geometry_msgs/msg/Twist" };
        if n > 0 {
            assert_eq!(in_bag["types"][&topic], wanted, "{in_bag}");
        }
    }
    if read == BagRead::Counted {
        return;
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/ros2_bag.py");
    let read =
        std::process::Command::new("python3").arg(script).args([record, out]).output().expect("python3");
    assert!(read.status.success(), "the readers failed: {}", String::from_utf8_lossy(&read.stderr));
    let report: Value = serde_json::from_slice(&read.stdout).expect("the script prints JSON");
    let (rosbags, mcap) = (&report["rosbags"], &report["mcap_ros2"]);
    assert_eq!(rosbags["undecoded"], 0, "{report}");
    assert_eq!(rosbags["counts"], mcap["counts"], "both readers decoded every message: {report}");
    assert_eq!(mcap["hash_mismatch"], serde_json::json!([]), "{report}");
    assert_eq!(report["recording_commanded"], reported, "{report}");
    for (topic, n) in in_bag["counts"].as_object().expect("counts") {
        assert_eq!(&mcap["counts"][topic], n, "{topic} decoded by mcap-ros2-support: {report}");
        assert_eq!(rosbags["types"][topic], in_bag["types"][topic], "{report}");
    }
}

#[test]
fn exp_short_with_ros2_robots_sensing_the_field_virtually_robot_1_sticks_and_robot_2_arrives() {
    let (j, lab) = ros2_robots_run("exp-short", 2, &["stuck", "arrived"], BagRead::Counted);
    let (x2, y2) = (j["robots"][1]["x"].as_f64().expect("x"), j["robots"][1]["y"].as_f64().expect("y"));
    assert!((x2 - 2.6).hypot(y2 - 1.0) <= 0.15, "robot 2 within the goal radius: ({x2}, {y2})");
    for k in 0..2 {
        let r = &lab["robots"][k];
        assert_eq!(r["kind"], "ros2", "{lab}");
        assert_eq!(r["cmd_vel"]["undecodable"], 0, "{lab}");
        assert!(
            r["cmd_vel"]["commands"].as_u64().is_some_and(|n| n > 10),
            "robot {} was driven: {lab}",
            k + 1
        );
    }
    assert_eq!(
        (&lab["robots"][0]["stuck"], &lab["robots"][1]["stuck"]),
        (&Value::Bool(true), &Value::Bool(false)),
        "{lab}"
    );
}

/// exp-long with ROS 2 bodies, the paper's outcome: robot 1 sticks at
/// the frame, robot 2 walks around it on the upper side and sticks at the
/// frame too, robot 3 walks around both below the frame's end and arrives.
/// The virtual field is symmetric about the line robot 1 drove, so the side
/// robot 2 takes is decided by where the operator set it down: the
/// scenario sets it 4 cm above the mark (`placed`), as the paper's run had
/// it go up (on the mark exactly, slip noise decides).
#[test]
fn exp_long_with_ros2_robots_sensing_the_field_virtually_robots_1_and_2_stick_and_robot_3_arrives() {
    let (j, lab) = ros2_robots_run("exp-long", 3, &["stuck", "stuck", "arrived"], BagRead::Counted);
    let y = |k: usize| j["robots"][k]["y"].as_f64().expect("y");
    assert!(y(1) > y(0) + 0.3, "robot 2 bypassed robot 1 on the upper side: {j}");
    let (x3, y3) = (j["robots"][2]["x"].as_f64().expect("x"), y(2));
    assert!((x3 - 3.0).hypot(y3 - 1.0) <= 0.15, "robot 3 within the goal radius: ({x3}, {y3})");
    let stuck: Vec<&Value> = (0..3).map(|k| &lab["robots"][k]["stuck"]).collect();
    assert_eq!(stuck, [&Value::Bool(true), &Value::Bool(true), &Value::Bool(false)], "{lab}");
}

/// A ROS 2 robot revoked mid-run (issue 50 item 3): the launch tells its
/// agent to stop, the agent sends zero, and the body stands where the
/// launch judged it stopped; the next robot goes. The body's own `cmd_vel`
/// timeout would stop it too, so what tells the revocation's zero from the
/// timeout is the last command the body received: zero.
#[test]
fn a_ros2_robot_revoked_mid_run_is_sent_zero_and_the_next_robot_goes() {
    let _turn = Turn::take();
    let lab = Ros2Lab::start("exp-short");
    // Robot 2 is set down inside robot 1's ε (0.65 m): it may walk around
    // it for good, so the run's time bounds the launch.
    let launch = lab.launch(2, &["--time-limit", "30"]);
    // Motion capture sees robot 1 driving, a third of the way to the frame.
    wait_for_pose(&lab.swarm, 2, 1, Duration::from_secs(60), |p| p.x > 0.7)
        .expect("robot 1 drives within 60 s");
    let args = ["revoke", "--robot", "1", "--swarm", &lab.swarm, "--why", "e2e: lost its marker"];
    let revoke = Proc::orchestrator(&args).wait(Duration::from_secs(20));
    assert_eq!(revoke.status.code(), Some(0), "{}", revoke.stderr);
    assert!(revoke.stdout.contains("told to stop"), "{}", revoke.stdout);
    let out = launch.wait(Duration::from_secs(240));
    let j = out.json();
    let robot1 = &j["robots"][0];
    assert_eq!(robot1["end"], "died", "{j}");
    assert!(j["robots"][1]["deployed_tick"].is_u64(), "robot 2 went on: {j}");
    let lab_robots = lab_summary(lab.lab);
    let body1 = &lab_robots["robots"][0];
    assert_eq!(body1["cmd_vel"]["last"], serde_json::json!([0.0, 0.0]), "the last command was zero: {body1}");
    assert_eq!(body1["stuck"], false, "stopped by its agent, not by the frame: {body1}");
    let (x, y) = (body1["x"].as_f64().expect("x"), body1["y"].as_f64().expect("y"));
    assert!(x > 0.7 && x < 1.3, "it had driven off the start and stopped short of the frame: {body1}");
    let (jx, jy) = (robot1["x"].as_f64().expect("x"), robot1["y"].as_f64().expect("y"));
    assert!(
        (x - jx).hypot(y - jy) < 0.05,
        "it stands where the launch judged it stopped: {body1} / {robot1}"
    );
    assert_no_gateway_left(&lab.swarm);
}

/// exp-short with ROS 2 bodies, its bag read by readers that are not ours:
/// `mcap-ros2-support` and rosbags decode every command on each robot's
/// `cmd_vel` (`Twist`, and robot 2's `TwistStamped`), as many as the lab's
/// bodies received.
#[test]
#[ignore = "needs python3 with rosbags==0.11.9, mcap==1.6.0 and mcap-ros2-support==0.6.0"]
fn exp_short_with_ros2_robots_every_command_is_decoded_from_the_exported_bag() {
    ros2_robots_run("exp-short", 2, &["stuck", "arrived"], BagRead::DecodedByPython);
}
