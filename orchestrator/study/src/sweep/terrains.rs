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
use bycoms_sim::terrain::{
    generate_feasible, min_path_width, read_terrain_file, GenParams, Generated, Terrain,
};
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
    (0..budget).find_map(|i| generate_feasible(candidate_seed(seed, i), &params).map(|g| (i, g)))
}

/// Fills every bin with `per_bin` generated terrains; `on_progress(filled, needed)`
/// is called after each chunk. Fails if `budget` candidates do not suffice,
/// or if `stop` is raised (Ctrl-C; the sweep needs all of its terrains).
pub fn generate_bins(
    seed: u64,
    bins: &[f64],
    per_bin: usize,
    budget: u64,
    stop: &AtomicBool,
    on_progress: impl FnMut(usize, usize),
) -> Result<Vec<Vec<SweepTerrain>>> {
    let found = search_bins(seed, bins, per_bin, budget, stop, on_progress)?;
    if stop.load(Ordering::Relaxed) {
        bail!("interrupted while generating terrains");
    }
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

/// Like [`generate_bins`], but when `budget` candidates run out, or `stop`
/// is raised (Ctrl-C: the caller checks it), it returns what it found (some
/// bins hold fewer than `per_bin`) instead of failing, so `orchestrator
/// terrain` can keep the terrains it did find.
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
            break;
        }
        let end = (next + CHUNK).min(budget);
        let found: Vec<(u64, Generated, f64)> = (next..end)
            .into_par_iter()
            .filter_map(|i| {
                let g = generate_feasible(candidate_seed(seed, i), &params)?;
                let w = min_path_width(&g.terrain);
                Some((i, g, w))
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

/// The terrains of a directory filed into width bins, and those left out.
#[derive(Debug)]
pub struct Loaded {
    /// Each bin's terrains, at most `per_bin`, in name order.
    pub bins: Vec<Vec<SweepTerrain>>,
    /// Terrains whose width lies in no bin: (name, width), in name order.
    pub outside: Vec<(String, f64)>,
    /// Terrains of a bin that already had `per_bin`.
    pub extra: usize,
}

impl Loaded {
    /// The terrains left out because no bin takes their width, in words
    /// (`None` when every terrain fits a bin): how many, and which.
    pub fn outside_text(&self, dir: &Path) -> Option<String> {
        const SHOWN: usize = 20;
        if self.outside.is_empty() {
            return None;
        }
        let mut names: Vec<String> =
            self.outside.iter().take(SHOWN).map(|(id, w)| format!("{id} (width {w:.2})")).collect();
        if self.outside.len() > SHOWN {
            names.push(format!("and {} more", self.outside.len() - SHOWN));
        }
        Some(format!(
            "{} of {} lie in no width bin of --widths and are not used: {}",
            crate::runs::count(self.outside.len() as u64, "terrain"),
            dir.display(),
            names.join(", ")
        ))
    }
}

/// Reads every `*.txt` terrain in `dir` (sorted by name), measures its width
/// and files it into its bin; at most `per_bin` per bin. Those left out are
/// counted ([`Loaded`]) for the command to say.
pub fn load_bins(dir: &Path, bins: &[f64], per_bin: usize) -> Result<Loaded> {
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
    let mut out = Loaded { bins: vec![Vec::new(); bins.len()], outside: Vec::new(), extra: 0 };
    for t in loaded {
        let t = t?;
        match bin_of(t.width, bins) {
            Some(b) if out.bins[b].len() < per_bin => out.bins[b].push(t),
            Some(_) => out.extra += 1,
            None => out.outside.push((t.id, t.width)),
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
    fn terrains_of_a_directory_outside_every_bin_are_counted_and_named() {
        let dir = tempfile::tempdir().unwrap();
        let open = |n: usize| {
            let mut rows = vec![".".repeat(n); n];
            rows[0].replace_range(0..1, "S");
            rows[n - 1].replace_range(n - 1..n, "G");
            rows.join("\n") + "\n"
        };
        for name in ["a.txt", "b.txt", "c.txt"] {
            std::fs::write(dir.path().join(name), open(12)).unwrap();
        }
        let width = min_path_width(&bycoms_sim::terrain::parse(&open(12)).unwrap());
        let loaded = load_bins(dir.path(), &[width + 1.0], 1).unwrap();
        assert!(loaded.bins.iter().all(Vec::is_empty));
        let names: Vec<&str> = loaded.outside.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["a", "b", "c"]);
        let text = loaded.outside_text(dir.path()).expect("said");
        assert!(text.starts_with("3 terrains of "), "{text}");
        assert!(text.contains("lie in no width bin of --widths and are not used: a (width "), "{text}");
        let bin = (width * 2.0).floor() / 2.0;
        let kept = load_bins(dir.path(), &[bin], 1).unwrap();
        assert_eq!((kept.bins[0].len(), kept.extra), (1, 2), "one per bin, two more");
        assert!(kept.outside.is_empty() && kept.outside_text(dir.path()).is_none());
    }

    #[test]
    fn an_interrupted_search_keeps_what_it_found_and_generation_fails() {
        let stop = AtomicBool::new(false);
        let kept = search_bins(5, &[2.0, 2.5], 1000, 100_000, &stop, |found, _| {
            if found > 0 {
                stop.store(true, Ordering::Relaxed);
            }
        })
        .expect("an interrupted search is not an error");
        let found: usize = kept.iter().map(Vec::len).sum();
        assert!(found > 0 && found < 2000, "kept {found} of 2000");
        let err = generate_bins(5, &[2.0], 1000, 100_000, &stop, |_, _| {}).unwrap_err();
        assert!(err.to_string().contains("interrupted"), "{err}");
    }

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
