//! The paper's simulation study (§V, `fig:result_width` and
//! `fig:result_width_noise`) as a resumable, shardable batch job.
//!
//! * [`plan`] — the axes (ε × width bin × terrains × noise) and the canonical
//!   order of runs, split into shards for a cluster's array job;
//! * [`terrains`] — the terrains: generated per width bin from one seed, or
//!   read from a directory;
//! * [`rows`] — one CSV row per run, written in canonical order, so a CSV is
//!   always a prefix of the full one: resuming is "skip what is there";
//! * [`execute`] — runs a plan on all cores with a progress bar and Ctrl-C;
//! * [`table`] — success-rate tables and heatmaps from rows (also what
//!   `merge` uses, so sharded and single runs give the same tables);
//! * [`budget`] — the robot-budget study (success within N robots), from
//!   the same rows;
//! * [`verify`] — whether a row belongs to a sweep and agrees with itself
//!   (what `merge` checks of every row).

pub mod budget;
pub mod execute;
pub mod plan;
pub mod rows;
pub mod table;
pub mod terrains;
pub mod verify;

/// Largest file of a sweep directory read back (its runs CSVs, terrain
/// list and description), bytes: every one goes through the one capped
/// reader ([`bycoms_runtime::capped`]), so a file linked to `/dev/zero`
/// is refused one byte past it. A million runs' rows are under 100 MB.
pub const MAX_READ_BYTES: u64 = 1 << 30;

/// The text of the sweep file `path`, capped at [`MAX_READ_BYTES`]; the
/// error names the file.
pub fn read_text(path: &std::path::Path) -> anyhow::Result<String> {
    use anyhow::Context as _;
    bycoms_runtime::capped::read_capped_file(path, MAX_READ_BYTES)
        .with_context(|| format!("cannot read {}", path.display()))
}

/// Seeds of terrains and runs are derived from the sweep seed with the
/// one mixing function of bycoms, so every run is reproducible on its own.
pub use bycoms_sim::seed::mix;
