//! Prints the emulated lab's sensing characterisation: V_ave and the
//! gradient direction error against distance to a speaker, with the default
//! noise (echo, vibration, ADC noise) and without.
//!
//! Run: `cargo bench -p bycoms-sim --bench lab_sensing`
//! (`BYCOMS_LAB_TRIALS=n` sets the placements per distance, default 200;
//! `--profile dev` reuses the debug build when a release build is too costly).

use bycoms_sim::lab::characterise::{characterise, table};
use bycoms_sim::lab::sound::SoundConfig;

fn main() {
    let trials = std::env::var("BYCOMS_LAB_TRIALS").ok().and_then(|t| t.parse().ok()).unwrap_or(200);
    let distances = [0.3, 0.4, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5];
    for (name, config) in [("default noise", SoundConfig::default()), ("quiet", SoundConfig::quiet())] {
        println!("# {name}: {config:?}, {trials} placements per distance, seed 1");
        print!("{}", table(&characterise(&config, &distances, trials, 1)));
    }
}
