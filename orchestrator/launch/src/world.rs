//! The world as the orchestrator knows it: the terrain (as text for the
//! agents, parsed once for the scene), the start and the goal.
//!
//! Why a file of its own: nearly every part of a launch reads it (the
//! driver, the setup, the recording, the observers), and `orchestrator/launch/src/lib.rs`
//! runs them all (no file cycles).

use anyhow::{Context, Result};
use bycoms_sim::Vec2;

/// The world as the orchestrator knows it: where robots start and the goal.
/// The terrain text is handed on to the simulated agents (they parse it as
/// a process would); the orchestrator parses it once, here.
#[derive(Clone, Debug)]
pub struct World {
    /// Where the terrain came from.
    pub name: String,
    /// The terrain in the text format, for the agents' simulated bodies.
    pub terrain_text: String,
    /// The same terrain, parsed once (its start and goal are the run's),
    /// for the scene and the picture.
    pub terrain: bycoms_sim::terrain::Terrain,
    /// Start position.
    pub start: Vec2,
    /// Goal position.
    pub goal: Vec2,
    /// What a unit of it is: a cell of a simulated terrain, or a metre of a
    /// lab (how its pictures are drawn).
    pub unit: bycoms_study::draw::snapshot::Unit,
    /// A lab's room (its scenario), which the picture draws the run in:
    /// its size and frames, which the terrain does not hold.
    pub room: Option<bycoms_lab::scenario::Scenario>,
    /// A mixed swarm's arena for its simulated members (none: no robot is
    /// simulated in a lab, or the terrain above is the simulated world).
    pub simulated: Option<SimArena>,
}

/// What a mixed swarm's simulated members run in: the lab's room as a
/// terrain of small cells (`bycoms_lab::arena`), in metres, driving as fast
/// as its real robots. Their run settings hold it in place of the world's
/// terrain; the orchestrator's own world (the gate, the pictures) stays the
/// room's.
#[derive(Clone, Debug, PartialEq)]
pub struct SimArena {
    /// The arena in the terrain text format.
    pub terrain_text: String,
    /// Metres per cell.
    pub cell: f64,
    /// A simulated member's straight-line speed, m/s.
    pub robot_speed: f64,
    /// The simulated members' ids, in order.
    pub members: Vec<u32>,
}

impl World {
    /// The world of terrain `text` (which must parse) with the run's
    /// `start` and `goal`.
    pub fn new(
        name: String,
        text: String,
        start: Vec2,
        goal: Vec2,
        unit: bycoms_study::draw::snapshot::Unit,
    ) -> Result<Self> {
        let mut terrain = bycoms_sim::terrain::parse(&text).context("the launch's terrain")?;
        terrain.set_start(start);
        terrain.set_goal(goal);
        Ok(Self { name, terrain_text: text, terrain, start, goal, unit, room: None, simulated: None })
    }

    /// A 3×3 world with one wall cell, start bottom left, goal top right
    /// (the unit tests' world, here and in the crates above).
    #[cfg(any(test, feature = "testing"))]
    pub fn tiny() -> Self {
        let text = "..G\n.#.\nS..\n".to_string();
        Self::new(
            "tiny".into(),
            text,
            Vec2::new(0.5, 0.5),
            Vec2::new(2.5, 2.5),
            bycoms_study::draw::snapshot::Unit::Cell,
        )
        .expect("the tiny world parses")
    }
}
