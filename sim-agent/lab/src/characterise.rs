//! How well the emulated robot senses a speaker, against distance.
//!
//! Why: the paper observes that robots measure each other's gradient well
//! when close and poorly a little farther away (echoes, motor vibration).
//! The emulator must reproduce that, and users of the lab need to know at
//! which distances its gradient can be trusted. For each distance, a
//! listening robot (playing its own tone, motors at the firmware's base
//! command) is put at seeded random bearings and headings around one
//! speaker; its firmware chain (tone isolation → ring estimate, the very
//! code of `bycoms_agent::firmware`) measures V_ave and the gradient
//! direction, compared with the true direction to the speaker.
//!
//! It also reports how far the speaker's tone stands above everything else
//! a microphone hears (echoes, motor vibration, the ADC's noise): the
//! firmware computes only the nine bins it reads, so it cannot see its own
//! noise floor. Here a whole spectrum of one microphone's frame is taken
//! with microfft's `rfft_512` (the Hann-windowed, mean-free frame in f32),
//! and the tone's three-bin amplitude is compared with the median bin away
//! from the three tones: the SNR, in dB.

use super::sound::{mic_positions, sample_frames, Room, SoundConfig, Speaker};
use bycoms_agent::acoustic::{MicRing, ToneConfig, ToneIsolator, FRAME_LEN};
use bycoms_agent::angle::{between, wrap};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// One distance's statistics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensingRow {
    /// Distance from the robot's centre to the speaker, m.
    pub distance: f64,
    /// Mean V_ave.
    pub v_ave: f64,
    /// Median absolute gradient direction error, degrees.
    pub median_error_deg: f64,
    /// 90th percentile of the absolute error, degrees.
    pub p90_error_deg: f64,
    /// Fraction of trials without any direction.
    pub no_direction: f64,
    /// Median SNR of the speaker's tone at microphone 0, dB (see the
    /// module docs).
    pub snr_db: f64,
}

/// Measures `trials` placements at each distance, seeded.
pub fn characterise(config: &SoundConfig, distances: &[f64], trials: usize, seed: u64) -> Vec<SensingRow> {
    let room = Room { width: 6.0, height: 6.0 };
    let tones = ToneConfig { sample_rate: config.sample_rate, gain: config.gain };
    let Ok(isolator) = ToneIsolator::new(tones, 320.0, [224.0, 512.0]) else {
        return Vec::new();
    };
    let ring = MicRing::paper();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let source = Speaker { x: 3.0, y: 3.0, freq: 224.0, phase: 0.0 };
    distances
        .iter()
        .map(|&d| {
            let mut errors = Vec::with_capacity(trials);
            let (mut v_sum, mut none) = (0.0, 0);
            let mut snrs = Vec::with_capacity(trials);
            for _ in 0..trials {
                let bearing: f64 = rng.gen_range(-core::f64::consts::PI..core::f64::consts::PI);
                let heading: f64 = rng.gen_range(-core::f64::consts::PI..core::f64::consts::PI);
                let (x, y) = (source.x + d * bearing.cos(), source.y + d * bearing.sin());
                let own = Speaker { x, y, freq: 320.0, phase: rng.gen_range(0.0..core::f64::consts::TAU) };
                let other = Speaker { phase: rng.gen_range(0.0..core::f64::consts::TAU), ..source };
                let mics = mic_positions(x, y, heading, ring.radius);
                let t0 = rng.gen_range(0.0..10.0);
                let frames = sample_frames(config, &room, &[other, own], &mics, 120.0, t0, &mut rng);
                let v = frames.each_ref().map(|f| isolator.amplitude(f));
                snrs.push(tone_snr_db(&frames[0], &tones, source.freq, &[224.0, 320.0, 512.0]));
                let est = ring.estimate(&v);
                v_sum += est.mean;
                // True direction to the speaker, robot frame.
                let truth = wrap((source.y - y).atan2(source.x - x) - heading);
                match est.direction {
                    Some(dir) => errors.push(between(dir, truth).to_degrees()),
                    None => none += 1,
                }
            }
            let pick = |q: f64| bycoms_runtime::stats::quantile(&errors, q);
            SensingRow {
                distance: d,
                v_ave: v_sum / trials as f64,
                median_error_deg: pick(0.5).unwrap_or(f64::NAN),
                p90_error_deg: pick(0.9).unwrap_or(f64::NAN),
                no_direction: none as f64 / trials as f64,
                snr_db: bycoms_runtime::stats::median(&snrs).unwrap_or(f64::NAN),
            }
        })
        .collect()
}

/// The SNR of the tone at `freq` in one microphone frame, dB: its
/// three-bin root-sum-square amplitude over the median bin magnitude away
/// from (two bins or more) every tone of `all` (see the module docs).
pub fn tone_snr_db(frame: &[u16; FRAME_LEN], tones: &ToneConfig, freq: f64, all: &[f64]) -> f64 {
    let mean = frame.iter().map(|&s| f64::from(s)).sum::<f64>() / FRAME_LEN as f64;
    let mut x = [0f32; FRAME_LEN];
    for (i, (out, &s)) in x.iter_mut().zip(frame).enumerate() {
        let hann = 0.5 - 0.5 * (core::f64::consts::TAU * i as f64 / FRAME_LEN as f64).cos();
        *out = ((f64::from(s) - mean) * hann) as f32;
    }
    let spectrum = microfft::real::rfft_512(&mut x);
    let magnitude = |k: usize| f64::from(spectrum[k].norm_sqr()).sqrt();
    let bin = |f: f64| (f / tones.bin_width()).round() as usize;
    let k = bin(freq);
    let tone = (k - 1..=k + 1).map(|j| magnitude(j).powi(2)).sum::<f64>().sqrt();
    let near_tone = |j: usize| all.iter().any(|&f| bin(f).abs_diff(j) <= 2);
    // Bin 0 holds the DC and Nyquist terms: left out.
    let floor: Vec<f64> = (1..FRAME_LEN / 2).filter(|&j| !near_tone(j)).map(magnitude).collect();
    let noise = bycoms_runtime::stats::median(&floor).unwrap_or(f64::NAN);
    20.0 * (tone / noise).log10()
}

/// The table as text (one header line, one line per distance).
pub fn table(rows: &[SensingRow]) -> String {
    let mut out = String::from("distance_m  v_ave    median_err_deg  p90_err_deg  no_direction  snr_db\n");
    for r in rows {
        out += &format!(
            "{:>10.2}  {:>7.0}  {:>14.1}  {:>11.1}  {:>12.2}  {:>6.1}\n",
            r.distance, r.v_ave, r.median_error_deg, r.p90_error_deg, r.no_direction, r.snr_db
        );
    }
    out
}
