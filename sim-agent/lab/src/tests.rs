//! The sound model's calibration and the paper's near/far observation.

use super::characterise::characterise;
use super::sound::SoundConfig;

#[test]
fn calibrated_speaker_reads_v_target_at_the_documented_distance() {
    let config = SoundConfig::quiet();
    let rows = characterise(&config, &[config.cal_distance], 16, 1);
    let v = rows[0].v_ave;
    assert!((v - config.v_target).abs() < 0.03 * config.v_target, "V_ave {v} at {} m", config.cal_distance);
    assert!(rows[0].median_error_deg < 2.0, "ideal field, near: {:?}", rows[0]);
}

#[test]
fn gradient_is_measured_well_near_a_robot_and_poorly_farther_away() {
    let config = SoundConfig::default();
    let rows = characterise(&config, &[0.4, 2.5], 64, 7);
    let (near, far) = (rows[0], rows[1]);
    assert!(near.median_error_deg < 10.0, "near: {near:?}");
    assert!(far.median_error_deg > 2.0 * near.median_error_deg, "near {near:?} far {far:?}");
    assert!(far.v_ave < near.v_ave);
    assert!(near.snr_db > far.snr_db, "the tone stands less above the noise farther away: {near:?} {far:?}");
}

#[test]
fn a_tone_s_snr_falls_by_the_noise_added() {
    use super::characterise::tone_snr_db;
    use bycoms_agent::acoustic::{ToneConfig, FRAME_LEN};
    use rand::{Rng, SeedableRng};
    let tones = ToneConfig::default();
    let frame = |noise: f64, seed: u64| {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        core::array::from_fn::<u16, FRAME_LEN, _>(|i| {
            let t = i as f64 / tones.sample_rate;
            let s =
                2048.0 + 1000.0 * (core::f64::consts::TAU * 224.0 * t).sin() + rng.gen_range(-noise..=noise);
            s.round() as u16
        })
    };
    let all = [224.0, 320.0, 512.0];
    let (clean, noisy) =
        (tone_snr_db(&frame(4.0, 1), &tones, 224.0, &all), tone_snr_db(&frame(40.0, 1), &tones, 224.0, &all));
    assert!(clean > 50.0, "a loud tone over ±4 counts: {clean} dB");
    // Ten times the noise: 20 dB less (within a few dB: a median of noise bins).
    assert!((clean - noisy - 20.0).abs() < 4.0, "clean {clean} dB, noisy {noisy} dB");
}

mod ros2;
#[cfg(feature = "process")]
mod ros2_process;
mod udp;
