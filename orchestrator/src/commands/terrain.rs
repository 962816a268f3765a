//! `orchestrator terrain`: generate terrains of one width bin, as text files
//! named with their measured minimum path width, plus an index CSV.

use crate::exit;
use crate::sweep::terrains::{file_name, generate_bins};
use anyhow::{Context, Result};
use bycoms_sim::terrain::to_text;
use std::path::PathBuf;

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
    /// Give up after this many candidates.
    #[arg(long, default_value_t = 2_000_000)]
    pub max_candidates: u64,
}

pub fn run(args: Args) -> Result<i32> {
    let top = 2.0 * bycoms_sim::terrain::width::MAX_CLEARANCE - crate::sweep::terrains::BIN_SIZE;
    if !(args.width.is_finite() && (1.0..=top).contains(&args.width)) {
        return Err(exit::usage(format!(
            "--width must lie in [1, {top}] cells (feasible terrains measure at least 1), got {}",
            args.width
        )));
    }
    if args.count == 0 {
        return Err(exit::usage("--count must be at least 1"));
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let bins = generate_bins(
        args.seed,
        &[args.width],
        args.count,
        args.max_candidates,
        &std::sync::atomic::AtomicBool::new(false),
        |_, _| {},
    )?;
    let mut index = String::from("file,terrain,width,threshold\n");
    for t in &bins[0] {
        let name = file_name(t, args.width);
        let path = args.out.join(&name);
        std::fs::write(&path, to_text(&t.terrain))
            .with_context(|| format!("cannot write {}", path.display()))?;
        let threshold = t.threshold.map(|a| a.to_string()).unwrap_or_default();
        index.push_str(&format!("{name},{},{},{threshold}\n", crate::sweep::rows::csv_field(&t.id), t.width));
    }
    let index_path = args.out.join("terrains.csv");
    std::fs::write(&index_path, index).with_context(|| format!("cannot write {}", index_path.display()))?;
    crate::outln!("wrote {} terrains of width bin {} to {}", bins[0].len(), args.width, args.out.display())?;
    Ok(exit::SUCCESS)
}
