//! A lockstep `orchestrator launch` over processes gives exactly the
//! in-process simulator's result: same outcome, same robots, the same stuck
//! and final positions bit for bit (`x_bits`/`y_bits` against
//! `f64::to_bits`) and the same step counts.
//!
//! Step mapping (documented in `orchestrator/gate/src/gate.rs`): a
//! robot's `steps` in the launch summary are its *active* periods — from its
//! start pose to its last change of pose — which is the runner's
//! `RobotRun::steps`; the gate's dwell and settle ticks move no robot and
//! are only in `ticks`. The summary's `steps` (their sum) is the runner's
//! `steps`, so the arrival step is the same too.
//!
//! Cases: the built-in scenarios and two generated Perlin terrains, with and
//! without sensing noise, ending by arrival, by robots exhausted and by the
//! time limit; and the same over zenoh (loopback tcp, port 0) instead of
//! iceoryx2.

use bycoms_sim::runner::RobotRunEnd;
use bycoms_sim::sensing::NoiseModel;
use bycoms_sim::terrain::{generate, to_text, GenParams, Terrain};
use bycoms_sim::{run, RunConfig, RunOutcome};
use bycoms_study::scenario::{load, TerrainSource};
use bycoms_tests::{simulate_differences, swarm_name, Proc};
use std::time::Duration;

struct Case {
    name: String,
    terrain: Terrain,
    eps: f64,
    noise: Option<u64>,
    robots: u32,
    time_limit: f64,
}

fn scenario(name: &str) -> Terrain {
    load(&TerrainSource::Scenario(name.into())).expect("built-in scenario").terrain
}

fn config(case: &Case) -> RunConfig {
    let mut cfg = RunConfig::paper(case.eps);
    cfg.noise = case.noise.map(|_| NoiseModel::paper());
    cfg.seed = case.noise.unwrap_or(0);
    cfg.max_robots = Some(case.robots);
    cfg.time_limit = case.time_limit;
    cfg
}

fn check(case: &Case) -> RunOutcome {
    check_over(case, &[])
}

/// [`check`] with extra launch flags (e.g. another transport).
fn check_over(case: &Case, extra: &[&str]) -> RunOutcome {
    let expected = run(&case.terrain, &config(case));
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("terrain.txt");
    std::fs::write(&path, to_text(&case.terrain)).expect("write terrain");
    let swarm = swarm_name("parity");
    let (eps, robots, limit) = (case.eps.to_string(), case.robots.to_string(), case.time_limit.to_string());
    let seed = case.noise.unwrap_or(0).to_string();
    let mut args = vec!["launch", "--clock", "lockstep", "--json", "--swarm", &swarm];
    args.extend(["--terrain", path.to_str().expect("utf-8 path"), "--eps", &eps, "--robots", &robots]);
    args.extend(["--time-limit", &limit, "--seed", &seed]);
    if case.noise.is_some() {
        args.push("--noise");
    }
    args.extend(extra);
    let out = Proc::orchestrator(&args).wait(Duration::from_secs(180));
    let j = out.json();
    let name = &case.name;
    let outcome = match expected.outcome {
        RunOutcome::Arrived => "arrived",
        RunOutcome::RobotsExhausted => "robots_exhausted",
        RunOutcome::TimeLimit => "time_limit",
    };
    assert_eq!(j["outcome"], outcome, "{name}: outcome; stderr:\n{}", out.stderr);
    assert_eq!(out.status.code(), Some(if expected.success { 0 } else { 3 }), "{name}: exit code");
    let robots = j["robots"].as_array().expect("robots array");
    assert_eq!(robots.len() as u32, case.robots, "{name}");
    let differences = simulate_differences(&expected, &j);
    assert!(differences.is_empty(), "{name}: {differences:#?}\nstderr:\n{}", out.stderr);
    assert_eq!(j["bad_traffic"]["garbage"], 0, "{name}");
    expected.outcome
}

fn case(name: &str, terrain: Terrain, eps: f64, noise: Option<u64>, robots: u32, time_limit: f64) -> Case {
    Case { name: name.into(), terrain, eps, noise, robots, time_limit }
}

#[test]
fn the_default_launch_is_the_papers_three_robot_experiment() {
    // Robots 1 and 2 get stuck, robot 3 goes around their fields.
    let c = case("long-obstacle ε3", scenario("long-obstacle"), 3.0, None, 3, 10_000.0);
    let expected = run(&c.terrain, &config(&c));
    let ends: Vec<RobotRunEnd> = expected.robots.iter().map(|r| r.end).collect();
    assert_eq!(ends, [RobotRunEnd::Stuck, RobotRunEnd::Stuck, RobotRunEnd::Arrived]);
    assert_eq!(check(&c), RunOutcome::Arrived);
}

#[test]
fn built_in_scenarios_without_noise() {
    let cases = [
        case("long-wall ε3", scenario("long-wall"), 3.0, None, 6, 10_000.0),
        case("gap3 ε1", scenario("gap3"), 1.0, None, 4, 10_000.0),
        case("gap3 ε2 (robots exhausted)", scenario("gap3"), 2.0, None, 3, 10_000.0),
        case("long-wall ε1 (time limit)", scenario("long-wall"), 1.0, None, 20, 150.0),
    ];
    let outcomes: Vec<RunOutcome> = cases.iter().map(check).collect();
    for o in [RunOutcome::Arrived, RunOutcome::RobotsExhausted, RunOutcome::TimeLimit] {
        assert!(outcomes.contains(&o), "no case ends with {o:?}: {outcomes:?}");
    }
}

#[test]
fn a_robot_stopping_in_the_very_last_period_is_a_beacon_in_both() {
    // Robot 1 of long-obstacle ε3 enters the obstacle on its 206th period;
    // with a 20.6 s limit that is the last budgeted period.
    let c = case("long-obstacle ε3, limit 20.6 s", scenario("long-obstacle"), 3.0, None, 3, 20.6);
    let expected = run(&c.terrain, &config(&c));
    assert_eq!(expected.robots[0].steps, 206);
    assert_eq!(expected.robots[0].end, RobotRunEnd::Stuck);
    assert_eq!(check(&c), RunOutcome::TimeLimit);
    // One period earlier the robot is still moving at the limit.
    let c = case("long-obstacle ε3, limit 20.5 s", scenario("long-obstacle"), 3.0, None, 3, 20.5);
    assert_eq!(run(&c.terrain, &config(&c)).robots[0].end, RobotRunEnd::Moving);
    assert_eq!(check(&c), RunOutcome::TimeLimit);
}

#[test]
fn built_in_scenarios_with_noise() {
    for seed in [1, 2] {
        check(&case(
            &format!("long-obstacle ε3 noise seed {seed}"),
            scenario("long-obstacle"),
            3.0,
            Some(seed),
            3,
            10_000.0,
        ));
    }
    check(&case("short-wall ε2.5 noise seed 3", scenario("short-wall"), 2.5, Some(3), 5, 3_000.0));
}

/// The first feasible generated terrains (from a fixed seed) on which the
/// runner leaves at least one beacon within a few robots.
fn generated(count: usize, eps: f64) -> Vec<Terrain> {
    let mut found = Vec::new();
    for seed in 1000.. {
        let g = generate(seed, &GenParams::default());
        if !g.feasible {
            continue;
        }
        let mut cfg = RunConfig::paper(eps);
        cfg.max_robots = Some(4);
        cfg.time_limit = 1_500.0;
        if !run(&g.terrain, &cfg).beacons.is_empty() {
            found.push(g.terrain);
            if found.len() == count {
                return found;
            }
        }
        assert!(seed < 1200, "no suitable generated terrain in 200 seeds");
    }
    found
}

#[test]
fn generated_terrains_with_and_without_noise() {
    for (i, terrain) in generated(2, 2.0).into_iter().enumerate() {
        check(&case(&format!("generated #{i} ε2"), terrain.clone(), 2.0, None, 4, 1_500.0));
        check(&case(&format!("generated #{i} ε2 noise seed 7"), terrain, 2.0, Some(7), 4, 1_500.0));
    }
}

#[test]
fn over_zenoh_too() {
    // The orchestrator listens on a free loopback port; the agents it
    // spawns are told that endpoint.
    let zenoh = ["--transport", "zenoh", "--listen", "tcp/127.0.0.1:0"];
    let c = case("long-obstacle ε3 over zenoh", scenario("long-obstacle"), 3.0, None, 3, 10_000.0);
    assert_eq!(check_over(&c, &zenoh), RunOutcome::Arrived);
    let c = case("short-wall ε2.5 noise seed 3 over zenoh", scenario("short-wall"), 2.5, Some(3), 5, 3_000.0);
    check_over(&c, &zenoh);
    let c = case("gap3 ε2 over zenoh (robots exhausted)", scenario("gap3"), 2.0, None, 3, 10_000.0);
    assert_eq!(check_over(&c, &zenoh), RunOutcome::RobotsExhausted);
}

/// A swarm simulated in a lab's arena (issue 52): a robots file of
/// simulated robots only (`kind = "sim"`), launched in lockstep with the lab
/// scenario exp-long, runs the paper's simulation in the arena in metres
/// (`bycoms_lab::arena`: 2 cm cells, the frame grown by a body's radius; a
/// TurtleBot 3's 0.22 m/s), and gives the in-process runner's run on that
/// arena bit for bit: what a mixed swarm's simulated members run, with
/// nothing real beside them; and so does `orchestrator simulate
/// --lab-scenario exp-long`, which runs that runner on that arena.
#[test]
fn a_swarm_simulated_in_a_labs_arena_is_the_runners_run_bit_for_bit() {
    use bycoms_lab::arena::{terrain as arena, DEFAULT_CELL};
    let scenario = bycoms_lab::scenario::Scenario::builtin("exp-long").expect("built in");
    let (eps, robots, goal_radius, time_limit) = (0.3, 6u32, 0.15, 300.0);
    let mut cfg = RunConfig::paper(eps);
    cfg.cell = DEFAULT_CELL;
    cfg.kinematics.speed = bycoms_agent::wheeled::Limits::TURTLEBOT3_BURGER.linear;
    cfg.success_radius = goal_radius;
    cfg.max_robots = Some(robots);
    cfg.time_limit = time_limit;
    let expected = run(&arena(&scenario, DEFAULT_CELL).expect("an arena"), &cfg);
    let ends: Vec<RobotRunEnd> = expected.robots.iter().map(|r| r.end).collect();
    assert_eq!(ends, [RobotRunEnd::Stuck, RobotRunEnd::Stuck, RobotRunEnd::Stuck, RobotRunEnd::Arrived]);
    // `simulate --lab-scenario` runs the runner on the same arena.
    let (eps_arg, n_arg, radius_arg) = (eps.to_string(), robots.to_string(), goal_radius.to_string());
    let simulate = Proc::orchestrator(&[
        "simulate",
        "--lab-scenario",
        "exp-long",
        "--eps",
        &eps_arg,
        "--success-radius",
        &radius_arg,
        "--max-robots",
        &n_arg,
        "--time-limit",
        "300",
        "--json",
        "--no-svg",
    ])
    .wait(Duration::from_secs(60));
    let simulated = simulate.json();
    let got: Vec<(u64, u64, u64)> = simulated["robots"]
        .as_array()
        .expect("robots")
        .iter()
        .map(|r| {
            let bits = |v: &serde_json::Value| v.as_f64().expect("a number").to_bits();
            (bits(&r["position"]["x"]), bits(&r["position"]["y"]), r["steps"].as_u64().expect("steps"))
        })
        .collect();
    let want: Vec<(u64, u64, u64)> =
        expected.robots.iter().map(|r| (r.position.x.to_bits(), r.position.y.to_bits(), r.steps)).collect();
    assert_eq!(got, want, "simulate --lab-scenario is the runner on the arena: {simulated}");
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("robots.toml");
    let text: String = (1..=robots).map(|id| format!("[[robot]]\nid = {id}\nkind = \"sim\"\n")).collect();
    std::fs::write(&file, text).expect("robots file");
    let swarm = swarm_name("labparity");
    let mut args = vec!["launch", "--clock", "lockstep", "--json", "--swarm", &swarm, "--agents", "real"];
    args.extend(["--robots-file", file.to_str().expect("utf-8"), "--lab-scenario", "exp-long"]);
    args.extend(["--eps", &eps_arg, "--robots", &n_arg, "--goal-radius", &radius_arg, "--time-limit", "300"]);
    let out = Proc::orchestrator(&args).wait(Duration::from_secs(180));
    let j = out.json();
    assert_eq!(out.status.code(), Some(0), "{}", out.stderr);
    let differences = simulate_differences(&expected, &j);
    assert!(differences.is_empty(), "{differences:#?}\nstderr:\n{}", out.stderr);
}
