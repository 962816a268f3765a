//! `orchestrator merge`: combine the runs CSVs of a sharded sweep into the
//! same runs.csv, tables and heatmaps a single `sweep` would have written.
//!
//! Every row is checked against its directory's sweep (`sweep.json`,
//! `terrains.csv`; see `bycoms_study::sweep::verify`) before anything is written:
//! a shard file of another sweep, or a row that contradicts itself, is
//! refused with the file and row named (exit 1), so the tables are never
//! computed from foreign rows.

use super::sweep::{report, Meta, META_FILE};
use anyhow::{bail, Context, Result};
use bycoms_runtime::exit;
use bycoms_study::sweep::rows::{read_rows, write_all, Row};
use bycoms_study::sweep::verify::{read_terrain_list, Expected, ListedTerrain, TERRAIN_LIST};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Combine shard outputs.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Shard output directories (each with sweep.json and runs-shard-*.csv).
    #[arg(required = true, value_name = "DIR")]
    pub inputs: Vec<PathBuf>,
    /// Where to write the merged runs.csv, tables and heatmaps.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Write tables even if some runs are missing.
    #[arg(long)]
    pub allow_partial: bool,
}

pub fn run(args: Args) -> Result<i32> {
    let mut meta: Option<Meta> = None;
    let mut terrains: Option<(Vec<Vec<ListedTerrain>>, &Path)> = None;
    let mut rows: BTreeMap<usize, Row> = BTreeMap::new();
    for dir in &args.inputs {
        let m = read_meta(dir)?;
        match &meta {
            None => meta = Some(m.clone()),
            Some(first) if *first != m => {
                bail!("{} belongs to a different sweep than {}", dir.display(), args.inputs[0].display())
            }
            Some(_) => {}
        }
        if let Some(list) = read_terrain_list(dir, &m.axes)? {
            if let Some((first, from)) = &terrains {
                if *first != list {
                    bail!(
                        "{} lists other terrains than {}: they belong to different sweeps",
                        dir.join(TERRAIN_LIST).display(),
                        from.join(TERRAIN_LIST).display()
                    );
                }
            } else {
                terrains = Some((list, dir));
            }
        }
        let expected = Expected {
            axes: &m.axes,
            seed: m.seed,
            time_limit: m.time_limit,
            max_robots: m.max_robots,
            terrains: terrains.as_ref().map(|(t, _)| t.as_slice()),
        };
        for file in runs_files(dir)? {
            for (k, row) in read_rows(&file)?.into_iter().enumerate() {
                let line = k + 2;
                if let Some(why) = expected.foreign(&row) {
                    bail!(
                        "{} does not belong to the sweep of {} (row {line}, run {}: {why}); \
                         is it a shard of another sweep? Remove it or merge it with its own sweep",
                        file.display(),
                        dir.join(META_FILE).display(),
                        row.index
                    );
                }
                if let Some(why) = expected.inconsistent(&row) {
                    bail!("{}: row {line} (run {}) contradicts itself: {why}", file.display(), row.index);
                }
                if let Some(old) = rows.get(&row.index) {
                    if *old != row {
                        bail!("run {} differs between shards (seen again in {})", row.index, file.display());
                    }
                }
                rows.insert(row.index, row);
            }
        }
    }
    let Some(meta) = meta else { bail!("no input directories") };
    let total = meta.axes.total_runs();
    let missing = total - rows.len();
    if missing > 0 && !args.allow_partial {
        let first = (0..total).find(|i| !rows.contains_key(i)).unwrap_or(0);
        bail!("{missing} of {total} runs are missing (first: run {first}); finish the shards or pass --allow-partial");
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    if args.out.join(META_FILE).exists() && read_meta(&args.out)? != meta {
        bail!("{} holds a different sweep; merge into another --out", args.out.display());
    }
    let rows: Vec<Row> = rows.into_values().collect();
    write_all(&args.out.join("runs.csv"), &rows)?;
    let meta_text = serde_json::to_string_pretty(&meta)? + "\n";
    bycoms_study::sweep::rows::write_atomic(&args.out.join(META_FILE), meta_text.as_bytes())?;
    let files = report(&args.out, &meta.axes, &rows, meta.max_robots)?;
    bycoms_runtime::outln!("merged {} runs into {}", rows.len(), args.out.join("runs.csv").display())?;
    for f in files {
        bycoms_runtime::outln!("wrote {}", f.display())?;
    }
    Ok(exit::SUCCESS)
}

fn read_meta(dir: &Path) -> Result<Meta> {
    let path = dir.join(META_FILE);
    let text = bycoms_runtime::capped::read_capped_file(&path, bycoms_study::sweep::MAX_READ_BYTES)
        .with_context(|| {
            format!("cannot read {} (is {} a sweep output directory?)", path.display(), dir.display())
        })?;
    serde_json::from_str(&text).with_context(|| format!("{} is not a sweep description", path.display()))
}

/// The shard CSVs of a directory, sorted; falls back to runs.csv.
fn runs_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("runs-shard-") && n.ends_with(".csv"))
        })
        .collect();
    files.sort();
    if files.is_empty() && dir.join("runs.csv").exists() {
        files.push(dir.join("runs.csv"));
    }
    if files.is_empty() {
        bail!("{} has no runs-shard-*.csv or runs.csv", dir.display());
    }
    Ok(files)
}
