//! Where a run's world comes from: a terrain file, a generated terrain, or
//! one of the built-in scenarios embedded in the binary (so the headline
//! commands work on a fresh machine with no data files).

use crate::sweep::terrains::first_feasible;
use anyhow::{bail, Context, Result};
use bycoms_sim::terrain::{parse, read_terrain_file, Terrain};
use std::path::PathBuf;

/// Name of the scenario used when none is given.
pub const DEFAULT: &str = "long-wall";

/// Built-in scenarios: name, one-line description, terrain text.
pub const BUILT_IN: &[(&str, &str, &str)] = &[
    (
        "long-wall",
        "a long wall across the start→goal line (after the paper's long-obstacle experiment)",
        include_str!("../scenarios/long-wall.txt"),
    ),
    (
        "short-wall",
        "a short wall across the start→goal line (after the paper's short-obstacle experiment)",
        include_str!("../scenarios/short-wall.txt"),
    ),
    (
        "long-obstacle",
        "a long obstacle across the start→goal line, reaching far to one side: robots 1 and 2 get stuck, robot 3 goes around their fields (the paper's fig:exp_inside_long; `launch`'s default, ε = 3)",
        include_str!("../scenarios/long-obstacle.txt"),
    ),
    (
        "gap3",
        "a wall with a gap of width 3 between start and goal",
        include_str!("../scenarios/gap3.txt"),
    ),
];

/// The names clap accepts for `--scenario`.
pub fn names() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(BUILT_IN.iter().map(|(n, _, _)| *n))
}

/// Where a world comes from.
#[derive(Debug, Clone)]
pub enum TerrainSource {
    File(PathBuf),
    Generated(u64),
    Scenario(String),
}

/// A terrain with a name to show in reports.
#[derive(Debug, Clone)]
pub struct NamedTerrain {
    pub name: String,
    pub terrain: Terrain,
}

/// Loads the world, with a message naming the file (and line/column) on error.
pub fn load(source: &TerrainSource) -> Result<NamedTerrain> {
    match source {
        TerrainSource::File(path) => {
            let terrain = read_terrain_file(path).map_err(|e| crate::runs::file_error(path, e))?;
            Ok(NamedTerrain { name: path.display().to_string(), terrain })
        }
        TerrainSource::Generated(seed) => {
            let (index, g) = first_feasible(*seed, 10_000).with_context(|| {
                format!("no feasible terrain in the first 10000 candidates of seed {seed}")
            })?;
            Ok(NamedTerrain {
                name: format!("generated (seed {seed}, candidate {index})"),
                terrain: g.terrain,
            })
        }
        TerrainSource::Scenario(name) => {
            let Some((_, _, text)) = BUILT_IN.iter().find(|(n, _, _)| n == name) else {
                bail!("unknown scenario {name:?}");
            };
            let terrain = parse(text).with_context(|| format!("built-in scenario {name} is malformed"))?;
            Ok(NamedTerrain { name: format!("scenario {name}"), terrain })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_scenario_parses_and_is_connected() {
        for (name, _, _) in BUILT_IN {
            let w = load(&TerrainSource::Scenario(name.to_string())).unwrap();
            assert!(bycoms_sim::terrain::is_connected(&w.terrain), "{name}");
        }
    }

    #[test]
    fn missing_file_is_a_clear_error() {
        let err = load(&TerrainSource::File("/nonexistent/t.txt".into())).unwrap_err();
        assert!(format!("{err:#}").contains("cannot read terrain file /nonexistent/t.txt"));
    }
}
