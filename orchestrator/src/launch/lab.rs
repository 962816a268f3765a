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
//! with the exact start and goal, which the recording, the picture and the
//! live view draw as they draw any terrain.
//!
//! Placement ([`Launch::place`]): before robot k is enabled, the operator
//! is asked — on the terminal, in the log and on the bus
//! (`bycoms/<swarm>/operator`, where the emulated lab's operator reads it)
//! — to put it on the start, and the launch waits until motion capture
//! (whatever the pose source) has seen it there for the hold time
//! (`mocap::PlacementWatch`). A robot enabled elsewhere would be judged
//! from the wrong start.

use super::engine::{Launch, SlotState, World, SLICE};
use crate::exit::usage;
use crate::mocap::{PlacementConfig, PlacementWatch};
use anyhow::{anyhow, Context, Result};
use bycoms_protocol::msg::Deploy;
use bycoms_protocol::RobotId;
use bycoms_sim::lab::process::load_scenario;
use bycoms_sim::lab::scenario::Scenario;
use bycoms_sim::terrain::{to_text, Terrain};
use bycoms_sim::Vec2;
use std::time::{Duration, Instant};

/// How often the request is repeated (and the terminal reminded) while
/// the operator has not placed the robot.
const REMIND_EVERY: Duration = Duration::from_secs(2);

/// The launch's world from lab scenario `name` (a built-in name or a
/// file), for a launch of `robots` robots: as many as the scenario has (one
/// tone each; every process of a swarm sizes the bus for the same number).
pub fn lab_world(name: &str, robots: u32) -> Result<World> {
    let scenario = load_scenario(name).map_err(|e| usage(e.to_string()))?;
    let have = scenario.tones.len();
    if have != robots as usize {
        return Err(usage(format!(
            "lab scenario {} has {have} robots (one tone each): launch it with --robots {have}, not {robots}",
            scenario.name
        )));
    }
    world_of(&scenario)
}

/// The world of a parsed scenario: arena, start and goal, no obstacle.
pub fn world_of(s: &Scenario) -> Result<World> {
    let cells = |m: f64| (m.ceil() as usize).max(1);
    let mut terrain = Terrain::new(cells(s.width), cells(s.height));
    let (start, goal) = (Vec2::new(s.start.x, s.start.y), Vec2::new(s.goal.x, s.goal.y));
    terrain.set_start(start);
    terrain.set_goal(goal);
    let text = to_text(&terrain);
    bycoms_sim::terrain::parse(&text).with_context(|| {
        format!("lab scenario {}: start and goal must lie in different square metres of the arena", s.name)
    })?;
    Ok(World { name: format!("lab scenario {}", s.name), terrain_text: text, start, goal })
}

/// What became of a placement request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placed {
    /// Motion capture saw the robot at the start: enable it.
    Yes,
    /// Its agent was lost meanwhile (e.g. its link): go on with the next.
    Lost,
    /// The launch must end (Ctrl-C, a fatal error, or the operator did not
    /// place it in time: then a fatal error names the robot).
    End,
}

impl Launch {
    /// Asks the operator to place robot `id` at the start and waits until
    /// motion capture sees it there (see the module docs). Meanwhile the
    /// pose source knows the robot is carried by hand
    /// ([`PoseSource::carried`]), so a hand-speed move to the start is not
    /// rejected as an identity swap.
    ///
    /// [`PoseSource::carried`]: super::poses::PoseSource::carried
    pub fn place(&mut self, id: u32, config: PlacementConfig) -> Result<Placed> {
        self.pose_source.carried(id, true);
        let placed = self.await_placed(id, config);
        self.pose_source.carried(id, false);
        placed
    }

    fn await_placed(&mut self, id: u32, config: PlacementConfig) -> Result<Placed> {
        let start = self.world.start;
        let request =
            Deploy { robot: RobotId(id), x: start.x, y: start.y, heading: start.bearing_to(self.world.goal) };
        let prompt = format!(
            "OPERATOR: place robot {id} at the start ({:.2}, {:.2}) — it is enabled once motion capture sees it there",
            start.x, start.y
        );
        self.progress.event(&prompt);
        tracing::info!(
            robot = id,
            x = start.x,
            y = start.y,
            "operator asked to place the robot at the start"
        );
        self.ports.ask_operator(&request)?;
        let mut watch = PlacementWatch::new(RobotId(id), start, config);
        let began = Instant::now();
        let timeout = Duration::from_secs_f64(config.timeout);
        let (mut reminded, mut seen_us) = (Instant::now(), None);
        loop {
            if self.must_end() {
                return Ok(Placed::End);
            }
            if self.slot(id).is_none_or(|s| s.state != SlotState::Registered) {
                return Ok(Placed::Lost);
            }
            let pose = self.slot(id).and_then(|s| s.last_pose);
            if let Some(p) = pose.filter(|p| seen_us != Some(p.time_us)) {
                seen_us = Some(p.time_us);
                if watch.observe(&p) {
                    self.progress
                        .event(&format!("robot {id}: at the start ({:.2}, {:.2}), enabling it", p.x, p.y));
                    return Ok(Placed::Yes);
                }
            }
            if began.elapsed() >= timeout {
                let last = watch.last().map_or("never".into(), |p| format!("at ({:.2}, {:.2})", p.x, p.y));
                self.fatal = Some(anyhow!(
                    "robot {id} was not seen at the start ({:.2}, {:.2}) within {} s (last seen: {last})",
                    start.x,
                    start.y,
                    config.timeout
                ));
                return Ok(Placed::End);
            }
            if reminded.elapsed() >= REMIND_EVERY {
                reminded = Instant::now();
                self.ports.ask_operator(&request)?;
                tracing::info!(robot = id, "still waiting for the robot at the start");
            }
            self.pump(SLICE)?;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lab_world_keeps_the_arena_start_and_goal_in_metres_and_no_obstacle() {
        let w = lab_world("exp-long", 3).expect("built in");
        assert_eq!((w.start, w.goal), (Vec2::new(0.4, 1.0), Vec2::new(3.0, 1.0)));
        let t = bycoms_sim::terrain::parse(&w.terrain_text).expect("parses");
        assert_eq!((t.width(), t.height()), (4, 3), "3.5 m × 2.5 m rounded up to whole metres");
        assert!(!w.terrain_text.contains('#'), "the orchestrator knows no obstacle: {}", w.terrain_text);
        let err = lab_world("exp-nowhere", 3).unwrap_err().to_string();
        assert!(err.contains("exp-nowhere"), "{err}");
        let err = lab_world("exp-short", 3).unwrap_err().to_string();
        assert!(err.contains("--robots 2"), "{err}");
    }

    #[test]
    fn the_shipped_real_robot_config_is_valid_and_in_metres() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy/lab/launch.toml");
        let mut cfg = crate::launch::LaunchConfig::load(&path).expect("deploy/lab/launch.toml loads");
        cfg.robots = 2;
        cfg.validate().expect("valid with the lab's robots file and exp-short");
        assert_eq!(cfg.agents.source, crate::launch::config::AgentsKind::Real);
        let scenario = cfg.agents.scenario.as_deref().expect("a lab scenario");
        let world = lab_world(scenario, cfg.robots).expect("exp-short");
        assert_eq!(cfg.goal_radius, 0.15, "the scenarios' goal radius, m");
        assert!(cfg.gate.stop_speed < 0.3 / 10.0, "well below a crawler's 0.3 m/s");
        assert_eq!(world.goal, Vec2::new(2.6, 1.0));
        // The NatNet variant: the same gate, bodies robot1..3 for any scenario.
        let path = path.with_file_name("launch-natnet.toml");
        let mut natnet = crate::launch::LaunchConfig::load(&path).expect("launch-natnet.toml loads");
        assert_eq!((natnet.gate.clone(), natnet.goal_radius), (cfg.gate.clone(), cfg.goal_radius));
        for robots in [2, 3] {
            natnet.robots = robots;
            natnet.validate().expect("valid for exp-short and exp-long alike");
        }
        let bodies = natnet.mocap.natnet.as_ref().expect("[mocap.natnet]").for_robots(2).bodies;
        assert_eq!(bodies.keys().collect::<Vec<_>>(), ["robot1", "robot2"]);
    }
}
