//! Prints the emulated lab's sensing characterisation: V_ave and the
//! gradient direction error and the tone's SNR (from a whole spectrum) against
//! distance to a speaker, with the default
//! noise (echo, vibration, ADC noise) and without.
//!
//! Run: `cargo bench -p bycoms-lab --bench lab_sensing`
//! (`BYCOMS_LAB_TRIALS=n` sets the placements per distance, default 200;
//! `--profile dev` reuses the debug build when a release build is too costly;
//! `BYCOMS_LAB_PLOT=FILE.svg` also writes the plot).

use bycoms_lab::characterise::{characterise, table, SensingRow};
use bycoms_lab::sensing_plot::plot;
use bycoms_lab::sound::SoundConfig;

fn main() {
    let trials = std::env::var("BYCOMS_LAB_TRIALS").ok().and_then(|t| t.parse().ok()).unwrap_or(200);
    let distances = [0.3, 0.4, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5];
    let mut runs: Vec<(&str, Vec<SensingRow>)> = Vec::new();
    for (name, config) in [("default noise", SoundConfig::default()), ("quiet", SoundConfig::quiet())] {
        println!("# {name}: {config:?}, {trials} placements per distance, seed 1");
        let rows = characterise(&config, &distances, trials, 1);
        print!("{}", table(&rows));
        runs.push((name, rows));
    }
    if let Some(path) = std::env::var_os("BYCOMS_LAB_PLOT") {
        let runs: Vec<(&str, &[SensingRow])> = runs.iter().map(|(n, r)| (*n, r.as_slice())).collect();
        match std::fs::write(&path, plot(&runs)) {
            Ok(()) => println!("plot: {}", std::path::Path::new(&path).display()),
            Err(e) => eprintln!("cannot write the plot to {}: {e}", std::path::Path::new(&path).display()),
        }
    }
}
