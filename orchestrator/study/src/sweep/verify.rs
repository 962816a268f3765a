//! Does a row belong to a sweep, and does it agree with itself?
//!
//! Why: `merge` turns whatever rows it is given into the study's tables. A
//! shard file copied from another sweep (another seed, other axes, other
//! terrains) has the same columns and plausible numbers, so without a check
//! it silently changes the success rates. Every row names its run
//! completely (index, noise, ε, width bin, terrain, measured width, noise
//! seed), and all of that follows from the sweep's parameters
//! (`sweep.json`) and its terrain list (`terrains.csv`): a row whose fields
//! are not exactly what its index means in this sweep is foreign. The run
//! seed alone already tells sweeps of different seeds apart, so the check
//! works even without a terrain list. A row can also contradict itself
//! (`success=true` with `outcome=time_limit`, more beacons than robots): a
//! hand-edited or corrupted file, refused too.

use super::execute::run_seed;
use super::plan::Axes;
use super::rows::Row;
use super::terrains::BIN_SIZE;
use anyhow::{Context, Result};
use serde::Deserialize;
use std::path::Path;

/// The file beside `sweep.json` that lists the terrains of each width bin.
pub const TERRAIN_LIST: &str = "terrains.csv";

/// One terrain of a sweep's terrain list.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct ListedTerrain {
    /// Its width bin.
    pub width_bin: f64,
    /// Its stable name (`c<candidate>` or a file stem).
    pub terrain: String,
    /// Its measured minimum path width.
    pub width: f64,
}

/// The terrain list of a sweep directory, per width bin of `axes` (in
/// order), or `None` if the directory has none.
pub fn read_terrain_list(dir: &Path, axes: &Axes) -> Result<Option<Vec<Vec<ListedTerrain>>>> {
    let path = dir.join(TERRAIN_LIST);
    if !path.exists() {
        return Ok(None);
    }
    let text = super::read_text(&path)?;
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let mut bins: Vec<Vec<ListedTerrain>> = vec![Vec::new(); axes.widths.len()];
    for (i, entry) in reader.deserialize::<ListedTerrain>().enumerate() {
        let entry = entry.with_context(|| format!("{}: bad row {}", path.display(), i + 2))?;
        let bin = axes.widths.iter().position(|&w| w == entry.width_bin).with_context(|| {
            format!(
                "{}: row {} names width bin {}, not one of this sweep's",
                path.display(),
                i + 2,
                entry.width_bin
            )
        })?;
        bins[bin].push(entry);
    }
    Ok(Some(bins))
}

/// What the rows of one sweep must agree with.
#[derive(Debug, Clone, Copy)]
pub struct Expected<'a> {
    /// The sweep's axes.
    pub axes: &'a Axes,
    /// The sweep seed.
    pub seed: u64,
    /// Simulated time limit per run, s.
    pub time_limit: f64,
    /// Robots per run, if limited.
    pub max_robots: Option<u32>,
    /// The terrain list per width bin, when known.
    pub terrains: Option<&'a [Vec<ListedTerrain>]>,
}

/// The outcomes a run can have (`bycoms_sim::RunOutcome`, as the CSV writes them).
const OUTCOMES: [&str; 3] = ["arrived", "time_limit", "robots_exhausted"];

impl Expected<'_> {
    /// Why `row` is not a run of this sweep, or `None` if it is.
    pub fn foreign(&self, row: &Row) -> Option<String> {
        let total = self.axes.total_runs();
        if row.index >= total {
            return Some(format!("run index {} is outside this sweep's {total} runs", row.index));
        }
        let spec = self.axes.spec(row.index);
        let (eps, bin) = (self.axes.eps[spec.eps], self.axes.widths[spec.bin]);
        if row.noise != spec.noise {
            return Some(format!(
                "noise {} (run {} has noise {})",
                on_off(row.noise),
                row.index,
                on_off(spec.noise)
            ));
        }
        if row.eps != eps {
            return Some(format!("ε = {} (run {} has ε = {eps})", row.eps, row.index));
        }
        if row.width_bin != bin {
            return Some(format!("width bin {} (run {} is in bin {bin})", row.width_bin, row.index));
        }
        if let Some(listed) = self.terrains.and_then(|t| t.get(spec.bin)?.get(spec.terrain)) {
            if row.terrain != listed.terrain {
                return Some(format!(
                    "terrain {} (run {} is on terrain {})",
                    row.terrain, row.index, listed.terrain
                ));
            }
            if row.width != listed.width {
                return Some(format!(
                    "terrain {} measured {} (the terrain list says {})",
                    row.terrain, row.width, listed.width
                ));
            }
        } else if self.terrains.is_some() {
            return Some(format!("run {} has no terrain in the terrain list", row.index));
        }
        let seed = run_seed(self.seed, &row.terrain, eps);
        if row.seed != seed {
            return Some(format!(
                "run seed {} (this sweep, seed {}, gives terrain {} at ε = {eps} the seed {seed})",
                row.seed, self.seed, row.terrain
            ));
        }
        None
    }

    /// Why `row` contradicts itself (or this sweep's limits), or `None`.
    pub fn inconsistent(&self, row: &Row) -> Option<String> {
        if !OUTCOMES.contains(&row.outcome.as_str()) {
            return Some(format!("unknown outcome {:?} (one of {})", row.outcome, OUTCOMES.join(", ")));
        }
        if row.success != (row.outcome == "arrived") {
            return Some(format!("success={} with outcome={}", row.success, row.outcome));
        }
        if !(row.width >= row.width_bin && row.width < row.width_bin + BIN_SIZE) {
            return Some(format!(
                "width {} outside its bin [{}, {})",
                row.width,
                row.width_bin,
                row.width_bin + BIN_SIZE
            ));
        }
        let slack = 1e-9 * self.time_limit.max(1.0);
        if !(row.time_s.is_finite() && row.time_s >= 0.0 && row.time_s <= self.time_limit + slack) {
            return Some(format!("time {} s outside [0, {}] (the time limit)", row.time_s, self.time_limit));
        }
        if row.beacons > row.robots_used as usize {
            return Some(format!("{} beacons of {} robots", row.beacons, row.robots_used));
        }
        if row.success && row.robots_used == 0 {
            return Some("arrived with no robot".to_owned());
        }
        match self.max_robots {
            Some(m) if row.robots_used > m => {
                Some(format!("{} robots used with at most {m} per run", row.robots_used))
            }
            None if row.outcome == "robots_exhausted" => {
                Some("outcome=robots_exhausted in a sweep without a robot limit".to_owned())
            }
            _ => None,
        }
    }
}

fn on_off(noise: bool) -> &'static str {
    if noise {
        "on"
    } else {
        "off"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axes() -> Axes {
        Axes { eps: vec![1.0, 4.0], widths: vec![2.0, 3.0], terrains_per_bin: 2, noise: vec![false, true] }
    }

    fn list() -> Vec<Vec<ListedTerrain>> {
        let t = |bin: f64, id: &str, width: f64| ListedTerrain { width_bin: bin, terrain: id.into(), width };
        vec![vec![t(2.0, "c3", 2.25), t(2.0, "c8", 2.0)], vec![t(3.0, "c1", 3.4), t(3.0, "c5", 3.0)]]
    }

    /// Run `index` of the sweep of seed 7 as `sweep` writes it.
    fn row(index: usize) -> Row {
        let a = axes();
        let spec = a.spec(index);
        let listed = &list()[spec.bin][spec.terrain];
        let eps = a.eps[spec.eps];
        Row {
            index,
            noise: spec.noise,
            eps,
            width_bin: a.widths[spec.bin],
            terrain: listed.terrain.clone(),
            width: listed.width,
            seed: run_seed(7, &listed.terrain, eps),
            success: true,
            outcome: "arrived".into(),
            time_s: 123.4,
            robots_used: 3,
            beacons: 2,
        }
    }

    #[test]
    fn every_run_of_the_sweep_belongs_and_agrees_with_itself() {
        let (a, l) = (axes(), list());
        let e = Expected { axes: &a, seed: 7, time_limit: 2000.0, max_robots: None, terrains: Some(&l) };
        for i in 0..a.total_runs() {
            assert_eq!(e.foreign(&row(i)), None, "run {i}");
            assert_eq!(e.inconsistent(&row(i)), None, "run {i}");
        }
    }

    #[test]
    fn a_row_of_another_seed_or_other_axes_or_terrains_is_foreign() {
        let (a, l) = (axes(), list());
        let with_list =
            Expected { axes: &a, seed: 7, time_limit: 2000.0, max_robots: None, terrains: Some(&l) };
        let without = Expected { terrains: None, ..with_list };
        let other_seed = Expected { seed: 8, ..without };
        assert!(other_seed.foreign(&row(5)).unwrap().contains("run seed"), "another seed, no terrain list");
        let cases: Vec<(Row, &str)> = vec![
            (Row { index: 16, ..row(0) }, "outside this sweep's 16 runs"),
            (Row { noise: true, ..row(0) }, "noise on"),
            (Row { eps: 2.0, ..row(0) }, "ε = 2"),
            (Row { width_bin: 3.0, ..row(0) }, "width bin 3"),
            (Row { terrain: "c9".into(), ..row(0) }, "terrain c9"),
            (Row { width: 2.3, ..row(0) }, "measured 2.3"),
            (Row { seed: row(0).seed ^ 1, ..row(0) }, "run seed"),
        ];
        for (r, why) in cases {
            let said = with_list.foreign(&r).unwrap_or_default();
            assert!(said.contains(why), "{why:?} not in {said:?}");
        }
        assert_eq!(without.foreign(&Row { width: 2.3, ..row(0) }), None, "widths need the terrain list");
    }

    #[test]
    fn a_row_that_contradicts_itself_is_refused() {
        let a = axes();
        let e = Expected { axes: &a, seed: 7, time_limit: 2000.0, max_robots: Some(5), terrains: None };
        let cases: Vec<(Row, &str)> = vec![
            (Row { outcome: "time_limit".into(), ..row(0) }, "success=true with outcome=time_limit"),
            (Row { success: false, ..row(0) }, "success=false with outcome=arrived"),
            (Row { outcome: "won".into(), ..row(0) }, "unknown outcome"),
            (Row { width: 2.5, ..row(0) }, "outside its bin"),
            (Row { time_s: 2000.5, ..row(0) }, "time 2000.5 s"),
            (Row { time_s: f64::NAN, ..row(0) }, "time NaN"),
            (Row { beacons: 4, ..row(0) }, "4 beacons of 3 robots"),
            (Row { robots_used: 6, beacons: 0, ..row(0) }, "6 robots used with at most 5"),
        ];
        for (r, why) in cases {
            let said = e.inconsistent(&r).unwrap_or_default();
            assert!(said.contains(why), "{why:?} not in {said:?}");
        }
        let unlimited = Expected { max_robots: None, ..e };
        let exhausted = Row { success: false, outcome: "robots_exhausted".into(), ..row(0) };
        assert!(unlimited.inconsistent(&exhausted).unwrap().contains("without a robot limit"));
        assert_eq!(e.inconsistent(&exhausted), None);
    }

    #[test]
    fn the_terrain_list_is_read_per_bin() {
        let dir = tempfile::tempdir().unwrap();
        let a = axes();
        assert_eq!(read_terrain_list(dir.path(), &a).unwrap(), None);
        std::fs::write(
            dir.path().join(TERRAIN_LIST),
            "width_bin,terrain,width,threshold\n2.0,c3,2.25,0.1\n3.0,c1,3.4,\n2.0,c8,2.0,0.2\n3.0,c5,3.0,\n",
        )
        .unwrap();
        assert_eq!(read_terrain_list(dir.path(), &a).unwrap(), Some(list()));
        std::fs::write(dir.path().join(TERRAIN_LIST), "width_bin,terrain,width,threshold\n9.0,c3,9.1,\n")
            .unwrap();
        let err = read_terrain_list(dir.path(), &a).unwrap_err().to_string();
        assert!(err.contains("width bin 9"), "{err}");
    }
}
