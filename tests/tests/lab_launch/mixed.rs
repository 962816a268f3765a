//! Mixed swarms (issue 52): simulated robots beside the emulated lab's ROS
//! 2 bodies, in one launch, one arena and one field. The robots file says
//! which robots are simulated (`kind = "sim"`): the launch starts a
//! `sim-agent` for each, running the paper's simulation in the lab's arena
//! in metres (`bycoms_lab::arena`), and a `ros2-robot` agent for each real
//! one; the lab emulates the real ones' bodies only.

use super::{ends, lab_with, launch_with, ros2_router, shipped, Turn};
use bycoms_tests::swarm_name;
use serde_json::Value;
use std::path::Path;
use std::time::Duration;

/// Robots in the mixed swarm, and which of them are real (interleaved), as
/// the shipped file has them.
const ROBOTS: u32 = 10;
const REAL: [u32; 3] = [2, 3, 5];

/// ε of the runs, m: smaller than the shipped 0.65 m, so that exp-long's
/// frame takes more beacons than three before a robot gets round it.
const EPS: &str = "0.3";

/// The shipped mixed robots file (`deploy/lab/mixed-robots.toml`: robots
/// 2, 3 and 5 ROS 2 robots, the others simulated), or with `real` empty the
/// same swarm all simulated.
fn robots_file(dir: &Path, real: &[u32]) -> std::path::PathBuf {
    let shipped = std::fs::read_to_string(shipped("mixed-robots.toml")).expect("mixed-robots.toml");
    for id in REAL {
        assert!(shipped.contains(&format!("id = {id}\nkind = \"ros2\"\n")), "robot {id} is real: {shipped}");
    }
    assert_eq!(shipped.matches("[[robot]]").count(), ROBOTS as usize);
    let text = if real.is_empty() { shipped.replace("kind = \"ros2\"", "kind = \"sim\"") } else { shipped };
    let file = dir.join("robots.toml");
    std::fs::write(&file, text).expect("robots file");
    file
}

/// One exp-long run of the swarm with `real` robots real: the launch's JSON
/// summary and the poses the launch applied (its recording), robot by
/// robot. With real robots the emulated lab holds their bodies; without,
/// no lab runs (it would have nothing to emulate).
fn run(real: &[u32]) -> (Value, Vec<bycoms_protocol::msg::Pose>) {
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = swarm_name("mixed");
    let (_router, endpoint) = ros2_router();
    let file = robots_file(dir.path(), real);
    let text = std::fs::read_to_string(shipped("launch-ros2-robots.toml")).expect("launch-ros2-robots.toml");
    let config = dir.path().join("launch.toml");
    std::fs::write(&config, text.replace("tcp/127.0.0.1:7447", &endpoint)).expect("config");
    let lab = (!real.is_empty()).then(|| lab_with(&swarm, "exp-long", &file, &["--ros2-router", &endpoint]));
    let record = dir.path().join("run.mcap");
    let extra = ["--eps", EPS, "--time-limit", "300", "--record", record.to_str().expect("utf-8")];
    let out = launch_with(&config, &swarm, "exp-long", ROBOTS, &file, &extra).wait(Duration::from_secs(200));
    drop(lab);
    assert_eq!(out.status.code(), Some(0), "a robot arrives:\n{}", out.stderr);
    let (_, applied) = crate::bad_traffic::recorded_poses(&record);
    (out.json(), applied)
}

/// Where robot `k` (1-based) ended, from a launch's summary.
fn end_of(j: &Value, k: usize) -> (f64, f64) {
    let r = &j["robots"][k - 1];
    (r["x"].as_f64().expect("x"), r["y"].as_f64().expect("y"))
}

/// A 10-robot swarm on exp-long's arena, robots 2, 3 and 5 the lab's ROS 2
/// bodies and the seven others simulated, decides as the same swarm all
/// simulated: the same robots stick, the same one arrives; and every real
/// body, once a simulated robot stuck ahead of it, keeps out of that
/// beacon's ε circle (less what a body at 0.22 m/s covers in the control
/// periods it takes to turn onto the tangent).
#[test]
fn a_mixed_swarm_on_exp_long_decides_as_the_same_swarm_all_simulated() {
    let _turn = Turn::take();
    let (mixed, poses) = run(&REAL);
    let (simulated, _) = run(&[]);
    assert_eq!(ends(&mixed), ends(&simulated), "mixed {mixed}\nall simulated {simulated}");
    let stuck: Vec<usize> =
        (1..=ROBOTS as usize).filter(|&k| mixed["robots"][k - 1]["end"] == "stuck").collect();
    assert!(stuck.len() >= 3, "the frame takes beacons: {mixed}");
    let eps: f64 = EPS.parse().expect("ε");
    let mut checked = 0;
    for &real in REAL.iter().filter(|&&k| k as usize <= stuck.len() + 1) {
        let beacons: Vec<(f64, f64)> = stuck
            .iter()
            .filter(|&&k| k < real as usize && !REAL.contains(&(k as u32)))
            .map(|&k| end_of(&mixed, k))
            .collect();
        let track: Vec<&bycoms_protocol::msg::Pose> = poses.iter().filter(|p| p.robot.0 == real).collect();
        assert!(!track.is_empty(), "robot {real} moved");
        for (bx, by) in &beacons {
            let nearest = track.iter().map(|p| (p.x - bx).hypot(p.y - by)).fold(f64::INFINITY, f64::min);
            assert!(
                nearest > eps - 0.1,
                "robot {real} came {nearest:.3} m from the beacon at ({bx:.2}, {by:.2})"
            );
            checked += 1;
        }
    }
    assert!(checked > 0, "a real body passed a simulated beacon: {mixed}");
}
