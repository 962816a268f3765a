//! The minimum-path-width histogram of the default terrain generator over
//! the first 2000 seeds, quoted in `terrain::generate`'s module doc, and
//! the time per seed of generating and measuring.
//!
//! A measurement, not a check (it asserts nothing), so a bench and not a
//! test. Run: `cargo bench -p bycoms-sim --bench width_histogram`.

use bycoms_sim::terrain::{generate, min_path_width, GenParams};
use std::time::Instant;

fn main() {
    const SEEDS: u64 = 2000;
    let params = GenParams::default();
    let t0 = Instant::now();
    let gens: Vec<_> = (0..SEEDS).map(|s| generate(s, &params)).collect();
    let t_gen = t0.elapsed();
    let t1 = Instant::now();
    let widths: Vec<f64> = gens.iter().filter(|g| g.feasible).map(|g| min_path_width(&g.terrain)).collect();
    let t_width = t1.elapsed();
    let n = widths.len();
    println!("scale {}: {n} feasible of {SEEDS} seeds", params.scale);
    // Bins [0.5·i, 0.5·i + 0.5); the last one also holds the capped 8.0.
    let mut bins = [0usize; 16];
    for &w in &widths {
        bins[((w / 0.5) as usize).min(bins.len() - 1)] += 1;
    }
    for (i, &c) in bins.iter().enumerate().skip(2) {
        let pct = 100.0 * c as f64 / n.max(1) as f64;
        let close = if i + 1 == bins.len() { ']' } else { ')' };
        let (lo, hi) = (i as f64 * 0.5, i as f64 * 0.5 + 0.5);
        let bar = "#".repeat((pct + 0.5) as usize);
        println!("[{lo:.1}, {hi:.1}{close} {c:>5} {pct:>5.1}% {bar}");
    }
    println!(
        "generate + feasibility: {:.1} µs per seed; width: {:.1} µs per feasible terrain",
        t_gen.as_secs_f64() * 1e6 / SEEDS as f64,
        t_width.as_secs_f64() * 1e6 / n.max(1) as f64
    );
}
