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
}

mod udp;
