//! The sweep's terrains: generated into width bins, or read from a directory.
//!
//! Generation draws candidates from one stream — candidate `i` of seed `s`
//! is the Perlin terrain of seed `mix(s, i)` — keeps the feasible ones
//! (a 4-connected path joins start and goal), measures their minimum path
//! width and files each into the first bin that still has room, in
//! candidate order. Candidates are evaluated in parallel in chunks, but
//! assigned in order, so the result does not depend on the number of cores.

use super::mix;
use anyhow::{bail, Context, Result};
use bycoms_sim::terrain::{generate, min_path_width, read_terrain_file, GenParams, Generated, Terrain};
use rayon::prelude::*;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// Width of a bin: bin w holds w ≤ width < w + BIN_SIZE.
pub const BIN_SIZE: f64 = 0.5;

/// A terrain of the sweep.
#[derive(Debug, Clone)]
pub struct SweepTerrain {
    /// Stable name: `c<candidate>` for generated ones, the file stem for files.
    pub id: String,
    pub terrain: Terrain,
    /// Measured minimum path width.
    pub width: f64,
    /// Perlin threshold a (generated terrains only).
    pub threshold: Option<f64>,
}

/// The seed of candidate `index` of stream `seed`.
pub fn candidate_seed(seed: u64, index: u64) -> u64 {
    mix(seed, index)
}

/// The bin (index into `bins`) a width falls in, if any.
pub fn bin_of(width: f64, bins: &[f64]) -> Option<usize> {
    bins.iter().position(|&b| b <= width && width < b + BIN_SIZE)
}

/// The first feasible candidate of a stream within `budget` candidates.
pub fn first_feasible(seed: u64, budget: u64) -> Option<(u64, Generated)> {
    let params = GenParams::default();
    (0..budget).map(|i| (i, generate(candidate_seed(seed, i), &params))).find(|(_, g)| g.feasible)
}

/// Fills every bin with `per_bin` generated terrains; `on_progress(filled, needed)`
/// is called after each chunk. Fails if `budget` candidates do not suffice,
/// or if `stop` is raised (Ctrl-C).
pub fn generate_bins(
    seed: u64,
    bins: &[f64],
    per_bin: usize,
    budget: u64,
    stop: &AtomicBool,
    on_progress: impl FnMut(usize, usize),
) -> Result<Vec<Vec<SweepTerrain>>> {
    let found = search_bins(seed, bins, per_bin, budget, stop, on_progress)?;
    if found.iter().any(|b| b.len() < per_bin) {
        let fill: Vec<String> =
            bins.iter().zip(&found).map(|(b, t)| format!("{b}: {}/{per_bin}", t.len())).collect();
        bail!(
            "{budget} candidate terrains did not fill every width bin ({}); \
             narrow --widths, lower --terrains-per-bin or raise --max-candidates",
            fill.join(", ")
        );
    }
    Ok(found)
}

/// Like [`generate_bins`], but when `budget` candidates run out it returns
/// what it found (some bins hold fewer than `per_bin`) instead of failing,
/// so `orchestrator terrain` can keep the terrains it did find.
pub fn search_bins(
    seed: u64,
    bins: &[f64],
    per_bin: usize,
    budget: u64,
    stop: &AtomicBool,
    mut on_progress: impl FnMut(usize, usize),
) -> Result<Vec<Vec<SweepTerrain>>> {
    const CHUNK: u64 = 256;
    let params = GenParams::default();
    let mut out: Vec<Vec<SweepTerrain>> = vec![Vec::new(); bins.len()];
    let needed = bins.len() * per_bin;
    let mut next = 0u64;
    while out.iter().any(|b| b.len() < per_bin) && next < budget {
        if stop.load(Ordering::Relaxed) {
            bail!("interrupted while generating terrains");
        }
        let end = (next + CHUNK).min(budget);
        let found: Vec<(u64, Generated, f64)> = (next..end)
            .into_par_iter()
            .filter_map(|i| {
                let g = generate(candidate_seed(seed, i), &params);
                g.feasible.then(|| {
                    let w = min_path_width(&g.terrain);
                    (i, g, w)
                })
            })
            .collect();
        for (i, g, width) in found {
            if let Some(b) = bin_of(width, bins) {
                if out[b].len() < per_bin {
                    out[b].push(SweepTerrain {
                        id: format!("c{i}"),
                        terrain: g.terrain,
                        width,
                        threshold: Some(g.threshold),
                    });
                }
            }
        }
        next = end;
        on_progress(out.iter().map(Vec::len).sum(), needed);
    }
    Ok(out)
}

/// Reads every `*.txt` terrain in `dir` (sorted by name), measures its width
/// and files it into its bin; at most `per_bin` per bin, extra ones ignored.
pub fn load_bins(dir: &Path, bins: &[f64], per_bin: usize) -> Result<Vec<Vec<SweepTerrain>>> {
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read terrain directory {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "txt"))
        .collect();
    paths.sort();
    if paths.is_empty() {
        bail!("no *.txt terrain files in {}", dir.display());
    }
    let loaded: Vec<Result<SweepTerrain>> = paths
        .par_iter()
        .map(|p| {
            let terrain = read_terrain_file(p).map_err(|e| crate::runs::file_error(p, e))?;
            let width = min_path_width(&terrain);
            let id = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            Ok(SweepTerrain { id, terrain, width, threshold: None })
        })
        .collect();
    let mut out: Vec<Vec<SweepTerrain>> = vec![Vec::new(); bins.len()];
    for t in loaded {
        let t = t?;
        if let Some(b) = bin_of(t.width, bins) {
            if out[b].len() < per_bin {
                out[b].push(t);
            }
        }
    }
    Ok(out)
}

/// File name for a generated terrain: bin, candidate and measured width.
pub fn file_name(t: &SweepTerrain, bin: f64) -> String {
    format!("w{bin:.1}_{}_width{:.2}.txt", t.id, t.width)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_are_half_open() {
        let bins = [1.0, 1.5, 2.0];
        assert_eq!(bin_of(1.0, &bins), Some(0));
        assert_eq!(bin_of(1.49, &bins), Some(0));
        assert_eq!(bin_of(1.5, &bins), Some(1));
        assert_eq!(bin_of(2.49, &bins), Some(2));
        assert_eq!(bin_of(2.5, &bins), None);
        assert_eq!(bin_of(0.9, &bins), None);
    }

    #[test]
    fn generation_is_deterministic_and_fills_bins() {
        let bins = [2.0, 3.0];
        let a = generate_bins(5, &bins, 2, 100_000, &AtomicBool::new(false), |_, _| {}).unwrap();
        let b = generate_bins(5, &bins, 2, 100_000, &AtomicBool::new(false), |_, _| {}).unwrap();
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.len(), 2);
            for (s, t) in x.iter().zip(y) {
                assert_eq!(s.id, t.id);
                assert_eq!(s.terrain, t.terrain);
            }
        }
        for (b, ts) in bins.iter().zip(&a) {
            assert!(ts.iter().all(|t| bin_of(t.width, &[*b]) == Some(0)));
        }
    }

    #[test]
    fn budget_exhaustion_is_a_clear_error() {
        let err = generate_bins(5, &[1.0], 1000, 10, &AtomicBool::new(false), |_, _| {}).unwrap_err();
        assert!(err.to_string().contains("did not fill every width bin"));
        let some = search_bins(5, &[2.0], 1000, 300, &AtomicBool::new(false), |_, _| {}).unwrap();
        assert!(!some[0].is_empty() && some[0].len() < 1000, "{}", some[0].len());
        let first = generate_bins(5, &[2.0], some[0].len(), 300, &AtomicBool::new(false), |_, _| {}).unwrap();
        let ids = |b: &[SweepTerrain]| b.iter().map(|t| t.id.clone()).collect::<Vec<_>>();
        assert_eq!(ids(&first[0]), ids(&some[0]), "what was found is what a smaller count finds");
    }
}
