//! Tone isolation on synthesized frames with known amplitudes.

use super::*;
use core::f64::consts::TAU;

/// Deterministic pseudo-noise: Knuth's MMIX LCG, uniform in [−1, 1).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// ADC mid-scale (12 bit).
const MID: f64 = 2048.0;

/// A 12-bit ADC's frame of `dc` plus sines (Hz, amplitude, phase) plus
/// uniform noise of peak `noise`, sampled at `rate`, rounded to counts.
fn frame(rate: f64, dc: f64, tones: &[(f64, f64, f64)], noise: f64, seed: u64) -> Frame {
    let mut lcg = Lcg(seed);
    core::array::from_fn(|i| {
        let t = i as f64 / rate;
        let s: f64 = tones.iter().map(|&(f, a, p)| a * libm::sin(TAU * f * t + p)).sum();
        let v = libm::round(dc + s + noise * lcg.next());
        assert!((0.0..=f64::from(ADC_MAX)).contains(&v), "the test frame clips: {v}");
        v as u16
    })
}

/// The 320 Hz robot of the paper: hears 224 and 512 Hz.
fn isolator() -> ToneIsolator<2> {
    ToneIsolator::new(ToneConfig::default(), 320.0, [224.0, 512.0]).unwrap()
}

fn rel(got: f64, want: f64) -> f64 {
    libm::fabs(got - want) / want
}

#[test]
fn paper_tones_fall_on_bins() {
    let c = ToneConfig::default();
    assert_eq!(c.bin_width(), 8.0);
    assert_eq!(PAPER_TONES.map(|t| c.bin(t)), [28.0, 40.0, 64.0]);
}

#[test]
fn recovers_on_bin_amplitudes_and_excludes_own() {
    let iso = isolator();
    // Own tone 100× louder than the quieter of the others.
    let f = frame(4096.0, MID, &[(224.0, 10.0, 0.3), (320.0, 1000.0, 1.1), (512.0, 25.0, 2.0)], 0.0, 0);
    let a = iso.tones(&f);
    assert!(rel(a.others[0], 10.0) < 1e-3, "{a:?}");
    assert!(rel(a.others[1], 25.0) < 1e-3, "{a:?}");
    assert!(rel(a.own, 1000.0) < 1e-3, "{a:?}");
    assert!(rel(a.sum_others(), 35.0) < 1e-3);
    let f = frame(4096.0, MID, &[(224.0, 10.0, 0.3), (320.0, 1000.0, 1.1), (512.0, 25.0, 2.0)], 0.0, 0);
    assert!(rel(iso.amplitude(&f), 35.0) < 1e-3);
}

#[test]
fn own_tone_alone_reads_as_nothing() {
    let iso = isolator();
    let f = frame(4096.0, MID, &[(320.0, 2000.0, 0.7)], 0.0, 0);
    let a = iso.tones(&f);
    assert!(rel(a.own, 2000.0) < 1e-3);
    // f32 rounding floor: far below 1e-4 of the own tone.
    assert!(a.sum_others() < 2000.0 * 1e-4, "{a:?}");
}

#[test]
fn amplitude_does_not_depend_on_phase() {
    let iso = isolator();
    for i in 0..16 {
        let p = i as f64 * TAU / 16.0;
        // 12-bit samples: at 40 counts (as before integer frames) rounding
        // the samples alone moves an on-bin amplitude by up to 0.4 %.
        let f = frame(4096.0, MID, &[(224.0, 400.0, p), (512.0, 400.0, 2.0 * p)], 0.0, 0);
        assert!(rel(iso.amplitude(&f), 800.0) < 1e-3, "phase {p}");
    }
}

/// Measured worst scalloping error of the three-bin Hann estimate: 1.01 %
/// half a bin off (exactly on a bin: < 0.01 %).
#[test]
fn off_bin_tone_within_one_and_a_half_percent() {
    let mut worst: f64 = 0.0;
    for i in 0..=40 {
        let freq = 220.0 + i as f64 * 0.2; // bins 27.5 … 28.5
        let iso = ToneIsolator::new(ToneConfig::default(), 512.0, [freq]).unwrap();
        let f = frame(4096.0, MID, &[(freq, 50.0, 0.4)], 0.0, 0);
        worst = worst.max(rel(iso.tones(&f).others[0], 50.0));
    }
    assert!(worst < 0.015, "worst {worst}");
    assert!(worst > 0.005, "the estimate should show some scalloping, got {worst}");
}

/// A tone that drifted from its configured frequency: measured −1.0 % at
/// half a bin (4 Hz), −8.7 % at a whole bin (8 Hz), since part of its main
/// lobe then falls outside the three bins read.
#[test]
fn drifted_tone_loses_little_within_half_a_bin() {
    let iso = isolator();
    for (drift, bound) in [(2.0, 0.002), (4.0, 0.011), (8.0, 0.09)] {
        for sign in [-1.0, 1.0] {
            let f = frame(4096.0, MID, &[(224.0 + sign * drift, 50.0, 0.4)], 0.0, 0);
            let got = iso.tones(&f).others[0];
            assert!(got < 50.0 && rel(got, 50.0) < bound, "drift {}: {got}", sign * drift);
        }
    }
}

#[test]
fn loud_off_bin_own_tone_does_not_leak() {
    // The own tone half a bin off (324 Hz = bin 40.5), 100× louder: the
    // Hann window keeps its leakage out of bins 28 and 64.
    let iso = ToneIsolator::new(ToneConfig::default(), 324.0, [224.0, 512.0]).unwrap();
    let f = frame(4096.0, MID, &[(224.0, 10.0, 0.0), (324.0, 1000.0, 0.5), (512.0, 10.0, 1.0)], 0.0, 0);
    let a = iso.tones(&f);
    assert!(rel(a.others[0], 10.0) < 0.01, "{a:?}");
    assert!(rel(a.others[1], 10.0) < 0.01, "{a:?}");
    assert!(rel(a.own, 1000.0) < 0.015, "{a:?}");
}

#[test]
fn dc_offset_and_noise_do_not_break_it() {
    let iso = isolator();
    // A 12-bit ADC's mid-scale offset, noise at 10 % of the quietest tone's
    // peak: measured errors ≤ 0.4 %.
    for seed in [1, 2, 3, 42, 12345] {
        let tones = [(224.0, 20.0, 0.1), (320.0, 500.0, 0.2), (512.0, 60.0, 0.3)];
        let f = frame(4096.0, 2048.0, &tones, 2.0, seed);
        let a = iso.tones(&f);
        assert!(rel(a.others[0], 20.0) < 0.01, "seed {seed}: {a:?}");
        assert!(rel(a.others[1], 60.0) < 0.01, "seed {seed}: {a:?}");
    }
}

#[test]
fn silence_and_pure_dc_read_zero() {
    let iso = isolator();
    assert_eq!(iso.amplitude(&[0; FRAME_LEN]), 0.0);
    assert!(iso.amplitude(&[2048; FRAME_LEN]) < 1e-3);
    // Noise alone (peak 1) stays small: it reads 0.04–0.1 per tone.
    let f = frame(4096.0, 2048.0, &[], 1.0, 7);
    assert!(iso.amplitude(&f) < 0.3);
}

#[test]
fn gain_scales_the_output() {
    let config = ToneConfig { gain: (FRAME_LEN / 2) as f64, ..ToneConfig::default() };
    let iso = ToneIsolator::new(config, 512.0, [224.0, 320.0]).unwrap();
    // Amplitude 1000, not 1 (as before integer frames): a 1-count sine
    // rounded to whole counts is far from a sine.
    let f = frame(4096.0, MID, &[(224.0, 1000.0, 0.0), (320.0, 1000.0, 0.0)], 0.0, 0);
    assert!(rel(iso.amplitude(&f), 512_000.0) < 1e-3);
}

#[test]
fn other_sample_rates_put_tones_between_bins() {
    // At 8 kHz the bins are 15.625 Hz wide: 224/320/512 Hz are off-bin.
    let config = ToneConfig { sample_rate: 8000.0, gain: 1.0 };
    let iso = ToneIsolator::new(config, 224.0, [320.0, 512.0]).unwrap();
    let tones = [(224.0, 300.0, 0.0), (320.0, 30.0, 1.0), (512.0, 15.0, 2.0)];
    let f = frame(8000.0, MID + 100.0, &tones, 0.0, 0);
    let a = iso.tones(&f);
    assert!(rel(a.others[0], 30.0) < 0.015, "{a:?}");
    assert!(rel(a.others[1], 15.0) < 0.015, "{a:?}");
}

#[test]
fn rejects_unusable_tones() {
    let c = ToneConfig::default();
    assert_eq!(ToneIsolator::new(c, 320.0, [8.0]).unwrap_err(), ToneError::OutOfBand(8.0));
    assert_eq!(ToneIsolator::new(c, 2040.0, [224.0]).unwrap_err(), ToneError::OutOfBand(2040.0));
    assert_eq!(ToneIsolator::new(c, 320.0, [300.0]).unwrap_err(), ToneError::TooClose(300.0, 320.0));
    assert_eq!(ToneIsolator::new(c, 512.0, [224.0, 250.0]).unwrap_err(), ToneError::TooClose(224.0, 250.0));
    let bad = ToneConfig { sample_rate: 0.0, gain: 1.0 };
    assert_eq!(ToneIsolator::new(bad, 320.0, [224.0]).unwrap_err(), ToneError::BadSampleRate(0.0));
    // Exactly MIN_SEPARATION_BINS apart is allowed.
    assert!(ToneIsolator::new(c, 320.0, [352.0]).is_ok());
    let iso = ToneIsolator::new(c, 320.0, PAPER_TONES).unwrap_err();
    assert_eq!(iso, ToneError::TooClose(320.0, 320.0));
}

/// The exact amplitudes of the same integer frame: mean, periodic Hann
/// window and the DFT of the bins read, all in `f64`.
fn reference(iso: &ToneIsolator<2>, f: &Frame) -> ToneAmplitudes<2> {
    let n = FRAME_LEN as f64;
    let mean = f.iter().map(|&s| f64::from(s)).sum::<f64>() / n;
    let y: Vec<f64> = f
        .iter()
        .enumerate()
        .map(|(i, &s)| (f64::from(s) - mean) * (0.5 - 0.5 * libm::cos(TAU * i as f64 / n)))
        .collect();
    let amp = |freq: f64| {
        let k = libm::round(iso.config().bin(freq)) as usize;
        let energy: f64 = (k - 1..=k + 1)
            .map(|j| {
                let (mut re, mut im) = (0.0, 0.0);
                for (i, v) in y.iter().enumerate() {
                    let phase = TAU * ((i * j) % FRAME_LEN) as f64 / n;
                    re += v * libm::cos(phase);
                    im -= v * libm::sin(phase);
                }
                re * re + im * im
            })
            .sum();
        libm::sqrt(energy * 32.0 / 3.0) / n * iso.config().gain
    };
    ToneAmplitudes { own: amp(iso.own()), others: iso.others().map(amp) }
}

/// The module docs' bound: the integer arithmetic is within 0.01 counts of
/// the exact DFT of the same samples, from quiet tones to a full-scale own
/// tone, on and off bin, with noise.
#[test]
fn integer_arithmetic_is_within_a_hundredth_of_a_count_of_the_exact_dft() {
    let iso = isolator();
    let mut worst: f64 = 0.0;
    for seed in 0..24u64 {
        let s = seed as f64;
        let tones = [
            (224.0 + (s % 5.0), 0.5 + 7.0 * s, 0.3 * s),
            (320.0 + (s % 3.0) * 1.5, 1990.0 - 60.0 * s, 1.0 + s),
            (512.0 - (s % 4.0), 3.0 + 2.0 * s, 2.0 * s),
        ];
        let total: f64 = tones.iter().map(|t| t.1).sum();
        let f = frame(4096.0, MID, &tones, (MID - total).min(4.0), seed);
        let (got, want) = (iso.tones(&f), reference(&iso, &f));
        for (g, w) in core::iter::once((got.own, want.own)).chain(got.others.into_iter().zip(want.others)) {
            worst = worst.max(libm::fabs(g - w));
        }
    }
    assert!(worst < 0.01, "worst {worst} counts");
    // And it is not exact: the bound is about the truncating arithmetic.
    assert!(worst > 1e-5, "worst {worst} counts");
}

/// Full-scale frames (square waves at the tones' bins, alternating 0 and
/// 4095, half 0 half 4095) make the largest sums the module docs bound; an
/// overflow panics in this (debug) build, and the results still match the
/// exact DFT.
#[test]
fn full_scale_frames_do_not_overflow() {
    let iso = isolator();
    let square = |k: usize| -> Frame {
        core::array::from_fn(
            |i| if libm::sin(TAU * (k * i) as f64 / 512.0 + 0.1) >= 0.0 { ADC_MAX } else { 0 },
        )
    };
    let frames = [
        square(28),
        square(40),
        square(64),
        core::array::from_fn(|i| if i % 2 == 0 { 0 } else { ADC_MAX }),
        core::array::from_fn(|i| if i < FRAME_LEN / 2 { 0 } else { ADC_MAX }),
        core::array::from_fn(|i| if (128..384).contains(&i) { ADC_MAX } else { 0 }),
    ];
    for f in &frames {
        let (got, want) = (iso.tones(f), reference(&iso, f));
        assert!(libm::fabs(got.own - want.own) < 0.01, "{got:?} vs {want:?}");
        for (g, w) in got.others.into_iter().zip(want.others) {
            assert!(libm::fabs(g - w) < 0.01, "{got:?} vs {want:?}");
        }
    }
    // A square wave of amplitude 2047.5 has a fundamental of 4/π of that.
    let a = iso.tones(&frames[1]).own;
    assert!(rel(a, 2047.5 * 4.0 / core::f64::consts::PI) < 0.01, "{a}");
}

#[test]
fn samples_above_twelve_bits_saturate() {
    let iso = isolator();
    let mut f = frame(4096.0, MID, &[(224.0, 2000.0, 0.0)], 0.0, 0);
    f[100..110].fill(ADC_MAX);
    let high = f.map(|s| if s == ADC_MAX { u16::MAX } else { s });
    assert_eq!(iso.tones(&high), iso.tones(&f));
}

#[test]
fn the_mean_is_removed_exactly() {
    // The same waveform at any offset: the same integers after step 1.
    let iso = isolator();
    let tones = [(224.0, 20.0, 0.1), (320.0, 500.0, 0.2), (512.0, 60.0, 0.3)];
    let base = frame(4096.0, 600.0, &tones, 3.0, 5);
    for offset in [1u16, 17, 2000, 2900] {
        assert_eq!(iso.tones(&base.map(|s| s + offset)), iso.tones(&base), "offset {offset}");
    }
}
