//! A real (or emulated) lab's world for the launch: start, goal and arena
//! in metres, from the lab's scenario file (`deploy/lab/`, `exp-short` and
//! `exp-long` built in), and the operator who puts each robot on the start.
//!
//! Why from the lab's scenario and not a terrain: real robots live in a
//! room measured in metres, and their poses (motion capture) and goal
//! bearings are in the room's frame. The scenario file is the lab's one
//! description, read by the emulated lab too (`sim-agent lab`), so the two
//! cannot disagree on where the start and the goal are. The orchestrator
//! still knows no obstacle: of the scenario it keeps only the arena, the
//! start and the goal (the frames are the lab's business). The launch's
//! world is an obstacle-free terrain of whole metres (the arena rounded up)
//! with the exact start and goal, which the recording and the live view
//! draw as they draw any terrain; the picture (`--svg`, `draw`) draws the
//! run in the scenario's room instead ([`World::room`]): its own size and
//! its frames, which the robots stick at.
//!
//! Placement (the launch core's `Placing` phase): before robot k is enabled, the operator
//! is asked — on the terminal, in the log and on the bus
//! (`bycoms/<swarm>/operator`, where the emulated lab's operator reads it)
//! — to put it on the start, and the launch waits until motion capture
//! (whatever the pose source) has seen it there for the hold time
//! (`mocap::PlacementWatch`). A robot enabled elsewhere would be judged
//! from the wrong start.

use super::SimArena;
use super::World;
use anyhow::{Context, Result};
use bycoms_lab::arena;
use bycoms_lab::process::load_scenario;
use bycoms_lab::robots::RobotsFile;
use bycoms_lab::scenario::Scenario;
use bycoms_runtime::exit::usage;
use bycoms_sim::terrain::{to_text, Terrain};
use bycoms_sim::Vec2;

/// The launch's world from lab scenario `name` (a built-in name or a
/// file), for a launch of `robots` robots: as many as the scenario has (one
/// tone each; every process of a swarm sizes the bus for the same number),
/// or, for a mixed swarm (`file` has simulated members), as many as the
/// robots file has, the simulated ones running in the arena
/// ([`mixed_arena`]).
pub fn lab_world(name: &str, robots: u32, file: Option<&RobotsFile>) -> Result<World> {
    let scenario = load_scenario(name).map_err(|e| usage(e.to_string()))?;
    if let Some(file) = file.filter(|f| !f.sim.is_empty()) {
        let (arena, start, goal) = mixed_arena(&scenario, file).map_err(|e| usage(format!("{e:#}")))?;
        return world_of(&scenario).map(|w| World { simulated: Some(arena), start, goal, ..w });
    }
    let have = scenario.tones.len();
    if have != robots as usize {
        return Err(usage(format!(
            "lab scenario {} has {have} robots (one tone each): launch it with --robots {have}, not {robots}",
            scenario.name
        )));
    }
    world_of(&scenario)
}

/// The arena a mixed swarm's simulated members run in: the scenario's room
/// in cells of [`arena::DEFAULT_CELL`], blocked where a body of the
/// scenario's radius would touch a frame or a wall, and their speed: the
/// slowest of the file's ROS 2 robots' `max_linear` (a TurtleBot 3 Burger's
/// when all are simulated), so that a simulated robot drives as the real
/// ones do; with the start and the goal in metres as the simulated world
/// has them (its cells × the cell: within a rounding of the scenario's),
/// which the launch deploys to and judges by, so that an all-simulated
/// swarm in lockstep is the in-process runner's run on this arena, bit for
/// bit.
pub fn mixed_arena(scenario: &Scenario, file: &RobotsFile) -> Result<(SimArena, Vec2, Vec2)> {
    let cell = arena::DEFAULT_CELL;
    let terrain = arena::terrain(scenario, cell)?;
    let robot_speed = simulated_robot_speed(file);
    let arena = SimArena { terrain_text: to_text(&terrain), cell, robot_speed, members: file.sim.clone() };
    let world = bycoms_sim::RunConfig { cell, ..bycoms_sim::RunConfig::paper(1.0) };
    Ok((arena, world.in_world(terrain.start()), world.in_world(terrain.goal())))
}

/// The robots of a launch that have a real body: every robot of a launch
/// of real robots (`agents.source = "real"`) but a mixed swarm's simulated
/// members; none when the agents simulate their robots. What the pictures,
/// the live view, Foxglove and the ROS 2 output mark, and the recording
/// keeps (its run metadata).
pub fn real_robots(cfg: &crate::LaunchConfig, world: &World) -> Vec<u32> {
    if cfg.agents.source != crate::config::AgentSourceKind::Real {
        return Vec::new();
    }
    let simulated = world.simulated.as_ref().map(|a| a.members.as_slice()).unwrap_or_default();
    (1..=cfg.robots).filter(|k| !simulated.contains(k)).collect()
}

/// `--sim-speed` other than 1 needs a mixed swarm: simulated members
/// beside real robots (a swarm of simulated robots only runs at `--speed`).
pub fn check_sim_speed(sim_speed: f64, world: &World, robots: u32) -> Result<()> {
    let members = world.simulated.as_ref().map_or(0, |a| a.members.len());
    if sim_speed == 1.0 || (members > 0 && members < robots as usize) {
        return Ok(());
    }
    Err(usage(format!(
        "sim_speed (--sim-speed) {sim_speed} speeds up a mixed swarm's simulated robots; this launch has {}: \
         give a robots file with kind = \"sim\" robots beside real ones, or set --speed",
        if members == 0 { "no simulated robot".to_string() } else { "simulated robots only".to_string() }
    )))
}

/// How fast a simulated robot drives in a lab's arena, m/s: as the slowest
/// of the file's ROS 2 robots (their `max_linear`), or, without any, as a
/// TurtleBot 3 Burger ([`DEFAULT_SIMULATED_SPEED`]).
pub fn simulated_robot_speed(file: &RobotsFile) -> f64 {
    let slowest = file.ros2.iter().map(|r| r.limits.linear).fold(f64::INFINITY, f64::min);
    if slowest.is_finite() {
        slowest
    } else {
        DEFAULT_SIMULATED_SPEED
    }
}

/// A simulated robot's speed in a lab's arena without real robots to match,
/// m/s: a TurtleBot 3 Burger's (`orchestrator simulate --lab-scenario`'s
/// default, and a robots file's of simulated robots only).
pub const DEFAULT_SIMULATED_SPEED: f64 = bycoms_agent::wheeled::Limits::TURTLEBOT3_BURGER.linear;

/// The world of a parsed scenario: arena, start and goal, no obstacle.
pub fn world_of(s: &Scenario) -> Result<World> {
    let cells = |m: f64| (m.ceil() as usize).max(1);
    let mut terrain = Terrain::new(cells(s.width), cells(s.height));
    let (start, goal) = (Vec2::new(s.start.x, s.start.y), Vec2::new(s.goal.x, s.goal.y));
    terrain.set_start(start);
    terrain.set_goal(goal);
    let text = to_text(&terrain);
    World::new(
        format!("lab scenario {}", s.name),
        text,
        start,
        goal,
        bycoms_study::draw::snapshot::Unit::Metre,
    )
    .map(|world| World { room: Some(s.clone()), ..world })
    .with_context(|| {
        format!("lab scenario {}: start and goal must lie in different square metres of the arena", s.name)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lab_world_keeps_the_arena_start_and_goal_in_metres_and_no_obstacle() {
        let w = lab_world("exp-long", 3, None).expect("built in");
        assert_eq!((w.start, w.goal), (Vec2::new(0.4, 1.0), Vec2::new(3.0, 1.0)));
        let t = bycoms_sim::terrain::parse(&w.terrain_text).expect("parses");
        assert_eq!((t.width(), t.height()), (4, 3), "3.5 m × 2.5 m rounded up to whole metres");
        assert!(!w.terrain_text.contains('#'), "the orchestrator knows no obstacle: {}", w.terrain_text);
        let err = lab_world("exp-nowhere", 3, None).unwrap_err().to_string();
        assert!(err.contains("exp-nowhere"), "{err}");
        let err = lab_world("exp-short", 3, None).unwrap_err().to_string();
        assert!(err.contains("--robots 2"), "{err}");
    }

    /// `--sim-speed` speeds up a mixed swarm's simulated members: a swarm
    /// with no simulated robot, or with simulated robots only, is refused.
    #[test]
    fn a_sim_speed_needs_simulated_robots_beside_real_ones() {
        let world = lab_world("exp-long", 3, None).expect("built in");
        let arena = |members: Vec<u32>| SimArena {
            terrain_text: String::new(),
            cell: 0.02,
            robot_speed: 0.22,
            members,
        };
        let mixed = World { simulated: Some(arena(vec![1, 3])), ..world.clone() };
        check_sim_speed(4.0, &mixed, 3).expect("robots 1 and 3 simulated, 2 real");
        check_sim_speed(1.0, &world, 3).expect("1 is no speed-up");
        let all = World { simulated: Some(arena(vec![1, 2, 3])), ..world.clone() };
        for (w, has) in [(&world, "has no simulated robot"), (&all, "has simulated robots only")] {
            let e = check_sim_speed(4.0, w, 3).expect_err("refused");
            assert_eq!(bycoms_runtime::exit::code_of(&e), bycoms_runtime::exit::USAGE, "{e:#}");
            assert!(e.to_string().contains(has), "{e}");
        }
    }

    #[test]
    fn a_lab_larger_than_any_terrain_is_a_usage_error_not_a_grid_past_memory() {
        let dir = tempfile::tempdir().expect("temp dir");
        for width in ["1e300", "1e5"] {
            let text = bycoms_lab::scenario::EXP_SHORT.replace("width = 3.0", &format!("width = {width}"));
            let file = dir.path().join("huge.toml");
            std::fs::write(&file, text).expect("scenario");
            let err = lab_world(file.to_str().expect("utf-8"), 2, None).expect_err("too large");
            assert_eq!(bycoms_runtime::exit::code_of(&err), bycoms_runtime::exit::USAGE, "{err:#}");
            assert!(format!("{err:#}").contains("at most 1000 m"), "{err:#}");
        }
    }

    #[test]
    fn the_shipped_real_robot_config_is_valid_and_in_metres() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../deploy/lab/launch.toml");
        let mut cfg = crate::LaunchConfig::load(&path).expect("deploy/lab/launch.toml loads");
        cfg.robots = 2;
        cfg.validate().expect("valid with the lab's robots file and exp-short");
        assert_eq!(cfg.agents.source, crate::config::AgentSourceKind::Real);
        let scenario = cfg.agents.scenario.as_deref().expect("a lab scenario");
        let world = lab_world(scenario, cfg.robots, None).expect("exp-short");
        assert_eq!(cfg.goal_radius, 0.15, "the scenarios' goal radius, m");
        assert!(cfg.gate.stop_speed < 0.3 / 10.0, "well below a crawler's 0.3 m/s");
        assert_eq!(world.goal, Vec2::new(2.6, 1.0));
        // The NatNet variant: the same gate, bodies robot1..3 for any scenario.
        let path = path.with_file_name("launch-natnet.toml");
        let mut natnet = crate::LaunchConfig::load(&path).expect("launch-natnet.toml loads");
        assert_eq!((natnet.gate.clone(), natnet.goal_radius), (cfg.gate.clone(), cfg.goal_radius));
        for robots in [2, 3] {
            natnet.robots = robots;
            natnet.validate().expect("valid for exp-short and exp-long alike");
        }
        let bodies = natnet.mocap.natnet.as_ref().expect("[mocap.natnet]").for_robots(2).bodies;
        assert_eq!(bodies.keys().collect::<Vec<_>>(), ["robot1", "robot2"]);
        // The ROS 2 variant: the same gate and tracker, one topic per body.
        let mut ros2 = crate::LaunchConfig::load(&path.with_file_name("launch-ros2.toml"))
            .expect("launch-ros2.toml loads");
        assert_eq!((ros2.gate.clone(), ros2.goal_radius), (cfg.gate.clone(), cfg.goal_radius));
        for robots in [2, 3] {
            ros2.robots = robots;
            ros2.validate().expect("valid for exp-short and exp-long alike");
        }
        let topics = ros2.mocap.ros2.as_ref().expect("[mocap.ros2]");
        let natnet_tracking = natnet.mocap.natnet.as_ref().expect("[mocap.natnet]");
        assert_eq!((topics.tracker, &ros2.placement), (natnet_tracking.tracker, &natnet.placement));
        assert_eq!(
            topics.for_robots(2).topics.keys().collect::<Vec<_>>(),
            ["/vrpn_mocap/robot1/pose", "/vrpn_mocap/robot2/pose"]
        );
    }
}
