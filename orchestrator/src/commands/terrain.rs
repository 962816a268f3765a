//! `orchestrator terrain`: generate terrains of one width bin, as text files
//! named with their measured minimum path width, plus an index CSV.
//!
//! When the candidate budget runs out first, the terrains found are still
//! written (generation is the slow part) and the command says how many are
//! missing and fails, so a script notices. Ctrl-C does the same: the
//! terrains found so far are written with their index rows, and the
//! command exits 130.

use anyhow::{bail, Context, Result};
use bycoms_runtime::exit;
use bycoms_runtime::out::{usage_unless_io, Kind, Outputs};
use bycoms_sim::terrain::to_text;
use bycoms_study::sweep::rows::to_csv_bytes;
use bycoms_study::sweep::terrains::{file_name, search_bins};
use serde::Serialize;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};

/// Generate `--count` terrains whose minimum path width lies in [w, w + 0.5).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Width bin w: keep terrains with w ≤ minimum path width < w + 0.5.
    #[arg(long)]
    pub width: f64,
    /// How many terrains.
    #[arg(long, default_value_t = 10)]
    pub count: usize,
    /// Seed of the candidate stream (the same stream `sweep --seed` uses).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output directory (created if needed).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Give up after this many candidates (the terrains found so far are still written).
    #[arg(long, default_value_t = 2_000_000)]
    pub max_candidates: u64,
    /// Replace terrain files of the same names already in --out (never other
    /// files). The index terrains.csv is updated: rows of other files stay.
    #[arg(long)]
    pub force: bool,
}

/// One line of the index `terrains.csv`.
#[derive(Serialize)]
struct IndexEntry<'a> {
    file: &'a str,
    terrain: &'a str,
    width: f64,
    threshold: Option<f64>,
}

pub fn run(args: Args) -> Result<i32> {
    let top = 2.0 * bycoms_sim::terrain::width::MAX_CLEARANCE - bycoms_study::sweep::terrains::BIN_SIZE;
    if !(args.width.is_finite() && (1.0..=top).contains(&args.width)) {
        return Err(exit::usage(format!(
            "--width must lie in [1, {top}] cells (feasible terrains measure at least 1), got {:?}",
            args.width
        )));
    }
    if args.count == 0 {
        return Err(exit::usage("--count must be at least 1"));
    }
    let index_path = args.out.join("terrains.csv");
    // The index is known before the search (the terrains' names after it):
    // the rule, before it. It is updated, not replaced (a directory collects
    // terrains of several bins), so an index of its own kind is fine; a file
    // of another kind is never written over.
    Outputs::new(true)
        .making_folders()
        .output("--out", &index_path, Kind::Csv)
        .check()
        .map_err(usage_unless_io)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let stop = bycoms_launch::interrupt_flag();
    stop.store(false, Ordering::SeqCst);
    let mut shown = std::time::Instant::now();
    generate(&args, &stop, |found, needed| {
        if shown.elapsed() >= std::time::Duration::from_secs(2) {
            shown = std::time::Instant::now();
            tracing::info!("{found} of {needed} terrains found");
        }
    })
}

/// Searches, writes what it found (also when `stop` was raised meanwhile)
/// and says it; `on_progress(found, needed)` after each chunk of candidates.
fn generate(args: &Args, stop: &AtomicBool, on_progress: impl FnMut(usize, usize)) -> Result<i32> {
    let index_path = args.out.join("terrains.csv");
    let bins = search_bins(args.seed, &[args.width], args.count, args.max_candidates, stop, on_progress)?;
    let found = &bins[0];
    let names: Vec<String> = found.iter().map(|t| file_name(t, args.width)).collect();
    for (t, name) in found.iter().zip(&names) {
        let path = args.out.join(name);
        bycoms_runtime::out::write(&path, Kind::Terrain, args.force, to_text(&t.terrain).as_bytes())
            .map_err(usage_unless_io)?;
    }
    let index = found.iter().zip(&names).map(|(t, name)| IndexEntry {
        file: name,
        terrain: &t.id,
        width: t.width,
        threshold: t.threshold,
    });
    let merged = merged_index(&index_path, &to_csv_bytes(index)?, &names).map_err(exit::usage)?;
    bycoms_runtime::out::write(&index_path, Kind::Csv, true, &merged).map_err(usage_unless_io)?;
    let plural = if found.len() == 1 { "" } else { "s" };
    bycoms_runtime::outln!(
        "wrote {} terrain{plural} of width bin {} to {}",
        found.len(),
        args.width,
        args.out.display()
    )?;
    if stop.load(Ordering::SeqCst) && found.len() < args.count {
        tracing::warn!(
            "interrupted: {} of the {} terrains asked for were found and written; run again with another \
             --seed or --out for more",
            found.len(),
            args.count
        );
        return Ok(exit::INTERRUPTED);
    }
    if found.len() < args.count {
        bail!(
            "{} of the {} terrains asked for are missing: {} candidates gave only {}; \
             raise --max-candidates or choose another --width",
            args.count - found.len(),
            args.count,
            args.max_candidates,
            found.len()
        );
    }
    Ok(exit::SUCCESS)
}

/// Largest `terrains.csv` read back, bytes (a row is under 100 bytes).
const MAX_INDEX_BYTES: u64 = 64 << 20;

/// The index of the directory: the rows of an existing `terrains.csv` whose
/// file was not written again, then this run's rows (`new`, with its header).
fn merged_index(path: &std::path::Path, new: &[u8], written: &[String]) -> Result<Vec<u8>, String> {
    use bycoms_runtime::capped::{read_capped_file_bytes, CappedError};
    let old = match read_capped_file_bytes(path, MAX_INDEX_BYTES) {
        Ok(bytes) if !bytes.is_empty() => bytes,
        Ok(_) | Err(CappedError::Io(_)) => return Ok(new.to_vec()),
        Err(e) => return Err(format!("{}: {e}", path.display())),
    };
    let not_ours = |e: &dyn std::fmt::Display| format!("{} is not a terrains index: {e}", path.display());
    let mut new_reader = csv::Reader::from_reader(new);
    let header = new_reader.headers().map_err(|e| not_ours(&e))?.clone();
    let mut old_reader = csv::Reader::from_reader(old.as_slice());
    if old_reader.headers().map_err(|e| not_ours(&e))? != &header {
        return Err(not_ours(&"its columns differ"));
    }
    let mut out = csv::Writer::from_writer(Vec::new());
    let fail = |e: csv::Error| not_ours(&e);
    out.write_record(&header).map_err(fail)?;
    for row in old_reader.records() {
        let row = row.map_err(fail)?;
        if !written.iter().any(|w| Some(w.as_str()) == row.get(0)) {
            out.write_record(&row).map_err(fail)?;
        }
    }
    for row in new_reader.records() {
        out.write_record(&row.map_err(fail)?).map_err(fail)?;
    }
    out.into_inner().map_err(|e| not_ours(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ctrl-C during the search keeps the terrains found so far: their
    /// files and their index rows, and the command says it was interrupted
    /// (exit 130) — "work done so far is kept" (issue 31).
    #[test]
    fn an_interrupted_search_writes_the_terrains_found_so_far() {
        let dir = tempfile::tempdir().expect("temp dir");
        let args = Args {
            width: 2.0,
            count: 50_000,
            seed: 1,
            out: dir.path().to_path_buf(),
            max_candidates: 2_000_000,
            force: false,
        };
        let stop = AtomicBool::new(false);
        let code = generate(&args, &stop, |found, _| {
            if found >= 3 {
                stop.store(true, Ordering::SeqCst);
            }
        })
        .expect("an interrupted search is no error");
        assert_eq!(code, exit::INTERRUPTED);
        let files: Vec<String> = std::fs::read_dir(dir.path())
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".txt"))
            .collect();
        assert!(files.len() >= 3 && files.len() < 50_000, "{} terrains kept", files.len());
        let index = std::fs::read_to_string(dir.path().join("terrains.csv")).expect("the index");
        assert_eq!(index.lines().count(), files.len() + 1, "one row per file, after the header");
        assert!(files.iter().all(|f| index.contains(f.as_str())), "{index}");
    }
}
