//! Runs a sweep's pending runs on all cores.
//!
//! Workers take runs in canonical order from a shared counter, so results
//! arrive nearly in order; the writer holds the few that arrive early and
//! writes each row as soon as all rows before it are written. On Ctrl-C the
//! workers finish the run in hand and stop taking new ones; every row that
//! could be written in order is kept.

use super::mix;
use super::plan::{Axes, RunSpec};
use super::rows::{Row, RowWriter};
use super::terrains::SweepTerrain;
use anyhow::Result;
use bycoms_sim::sensing::NoiseModel;
use bycoms_sim::{run, RunConfig};
use indicatif::ProgressBar;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;

/// The noise seed of a run: from the sweep seed, the terrain's name and
/// the value of ε (not its position on the axis, so adding radii to a
/// sweep does not change the others' results). `merge` recomputes it to
/// tell a row of another sweep (`super::verify`).
pub fn run_seed(sweep_seed: u64, terrain_id: &str, eps: f64) -> u64 {
    let id_hash = terrain_id
        .bytes()
        .fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3));
    mix(mix(sweep_seed, id_hash), eps.to_bits())
}

/// Everything needed to turn a run index into a row.
pub struct Job<'a> {
    pub axes: &'a Axes,
    /// Terrains per width bin (`bins[b][t]`).
    pub terrains: &'a [Vec<SweepTerrain>],
    /// Time limit, robot budget etc.; ε, noise and seed are set per run.
    pub base: RunConfig,
    pub seed: u64,
}

impl Job<'_> {
    /// The noise seed of run `spec` (see [`run_seed`]).
    fn run_seed(&self, spec: &RunSpec, terrain: &SweepTerrain) -> u64 {
        run_seed(self.seed, &terrain.id, self.axes.eps[spec.eps])
    }

    /// Whether a row (e.g. from a CSV being resumed) is the run its index names in this plan.
    pub fn matches(&self, row: &Row) -> bool {
        if row.index >= self.axes.total_runs() {
            return false;
        }
        let spec = self.axes.spec(row.index);
        let terrain = &self.terrains[spec.bin][spec.terrain];
        row.noise == spec.noise
            && row.eps == self.axes.eps[spec.eps]
            && row.width_bin == self.axes.widths[spec.bin]
            && row.terrain == terrain.id
            && row.seed == self.run_seed(&spec, terrain)
    }

    /// Runs one simulation and makes its row.
    pub fn row(&self, index: usize) -> Row {
        self.row_and_steps(index).0
    }

    /// [`Self::row`] and the robot-steps (control periods) the run simulated.
    pub fn row_and_steps(&self, index: usize) -> (Row, u64) {
        let spec = self.axes.spec(index);
        let terrain = &self.terrains[spec.bin][spec.terrain];
        let mut cfg = self.base.clone();
        cfg.eps = self.axes.eps[spec.eps];
        cfg.noise = spec.noise.then(NoiseModel::paper);
        cfg.seed = self.run_seed(&spec, terrain);
        cfg.record_trajectories = false;
        let r = run(&terrain.terrain, &cfg);
        let row = Row {
            index,
            noise: spec.noise,
            eps: cfg.eps,
            width_bin: self.axes.widths[spec.bin],
            terrain: terrain.id.clone(),
            width: terrain.width,
            seed: cfg.seed,
            success: r.success,
            outcome: serde_json::to_value(r.outcome)
                .ok()
                .and_then(|v| v.as_str().map(str::to_owned))
                .unwrap_or_default(),
            time_s: r.time,
            robots_used: r.robots_used,
            beacons: r.beacons.len(),
        };
        (row, r.steps)
    }
}

/// What [`execute`] did: rows written (in order) and the robot-steps of those runs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Executed {
    pub rows: usize,
    pub robot_steps: u64,
}

/// Runs `pending` (canonical indices, ascending) with `threads` workers and
/// appends their rows in order. Returns how many rows were written and
/// their robot-steps (for the speed line `orchestrator sweep` prints).
pub fn execute(
    job: &Job,
    pending: &[usize],
    writer: &mut RowWriter,
    threads: usize,
    progress: &ProgressBar,
    stop: &AtomicBool,
) -> Result<Executed> {
    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<(usize, (Row, u64))>();
    std::thread::scope(|scope| {
        for _ in 0..threads.max(1) {
            let tx = tx.clone();
            let next = &next;
            scope.spawn(move || loop {
                if stop.load(Ordering::Relaxed) {
                    break;
                }
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(&index) = pending.get(k) else { break };
                if tx.send((k, job.row_and_steps(index))).is_err() {
                    break;
                }
            });
        }
        drop(tx);
        let mut early = BTreeMap::new();
        let mut written = 0usize;
        let mut successes = 0usize;
        let mut robot_steps = 0u64;
        for (k, row) in rx {
            early.insert(k, row);
            while let Some((row, steps)) = early.remove(&written) {
                writer.write(&row)?;
                robot_steps += steps;
                successes += usize::from(row.success);
                written += 1;
                progress.inc(1);
                progress.set_message(format!("{successes} arrived"));
            }
        }
        Ok(Executed { rows: written, robot_steps })
    })
}
