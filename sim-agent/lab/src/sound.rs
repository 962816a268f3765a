//! The lab's sound: what each microphone's ADC reads.
//!
//! Why a waveform model rather than ready-made V_n values: the firmware
//! under test isolates tones with a DFT, so the emulator must hand it
//! samples, exactly as the ADC would, for the DFT, the window and the
//! noise to matter as they do on the robot. Per sample, a microphone at
//! distance d from a speaker hears
//!
//!   A(d) · sin(2π f (t − d/c) + φ),  A(d) = A_cal · d_cal / max(d, d_near)
//!
//! (spherical spreading: pressure ∝ 1/d), summed over every playing speaker
//! — its own robot's included — plus, per configured echo, the same for the
//! speaker's mirror images in the arena's four walls times `echo_gain`,
//! plus motor vibration (a sum of sines at `vibration_hz` with amplitude
//! `vibration` × |motor command| / 255, the same at all six microphones of
//! the robot) and Gaussian sensor noise; then the 12-bit ADC: mid-scale
//! offset, rounding to whole counts, clamping to 0..=4095, as the `u16`
//! samples the firmware core takes.
//!
//! Calibration: A_cal = V_target / gain, so a robot whose centre is
//! `cal_distance` from a lone speaker reads V_ave ≈ V_target (22000 with the
//! firmware's gain of 256: A_cal ≈ 85.9 ADC counts). The default
//! `cal_distance` is 0.5 m: mode 2 then holds a contour about half a metre
//! around a stuck robot, which clears the robot's own 0.128 m radius.

use bycoms_agent::acoustic::{ADC_MAX as ADC_MAX_COUNTS, FRAME_LEN};
use bycoms_agent::firmware::{MicFrames, MICS};
use core::f64::consts::TAU;
use rand::Rng;
use rand_xoshiro::Xoshiro256PlusPlus;
use serde::{Deserialize, Serialize};

/// Speed of sound, m/s.
pub const SPEED_OF_SOUND: f64 = 343.0;
/// ADC mid-scale (12 bit).
pub const ADC_MID: f64 = 2048.0;
/// ADC full scale (12 bit).
pub const ADC_MAX: f64 = ADC_MAX_COUNTS as f64;

/// The sound model's parameters (scenario files: `[sound]`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SoundConfig {
    /// Distance (m) from a lone speaker at which V_ave = `v_target`.
    pub cal_distance: f64,
    /// The V_target the calibration aims at (the firmware's).
    pub v_target: f64,
    /// The firmware's amplitude → V_n gain.
    pub gain: f64,
    /// Distances below this (m) count as this (the speaker is not a point).
    pub near_limit: f64,
    /// Standard deviation of the ADC noise, counts.
    pub sensor_noise: f64,
    /// Vibration amplitude at full motor command, counts.
    pub vibration: f64,
    /// Frequencies of the vibration, Hz (gear and track rattle).
    pub vibration_hz: [f64; 2],
    /// Reflection factor of the arena's walls (0 = no echo).
    pub echo_gain: f64,
    /// Microphone sample rate, Hz.
    pub sample_rate: f64,
}

impl Default for SoundConfig {
    fn default() -> Self {
        Self {
            cal_distance: 0.5,
            v_target: 22_000.0,
            gain: FRAME_LEN as f64 / 2.0,
            near_limit: 0.05,
            sensor_noise: 4.0,
            vibration: 30.0,
            vibration_hz: [97.0, 151.0],
            echo_gain: 0.3,
            sample_rate: 4096.0,
        }
    }
}

impl SoundConfig {
    /// No noise, no echo, no vibration: the ideal field.
    pub fn quiet() -> Self {
        Self { sensor_noise: 0.0, vibration: 0.0, echo_gain: 0.0, ..Self::default() }
    }

    /// Amplitude at `cal_distance`, ADC counts.
    pub fn calibrated_amplitude(&self) -> f64 {
        self.v_target / self.gain
    }

    /// Amplitude of a direct path of length `d`, counts.
    pub fn amplitude(&self, d: f64) -> f64 {
        self.calibrated_amplitude() * self.cal_distance / d.max(self.near_limit)
    }
}

/// A playing speaker.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Speaker {
    /// Position, m.
    pub x: f64,
    /// Position, m.
    pub y: f64,
    /// Tone, Hz.
    pub freq: f64,
    /// Phase offset, rad (robots' oscillators are not synchronised).
    pub phase: f64,
}

/// The room the sound lives in: walls at x = 0, x = width, y = 0, y = height.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Room {
    /// Arena width, m.
    pub width: f64,
    /// Arena height, m.
    pub height: f64,
}

/// One robot's microphone frames for the control period starting at `t0`
/// (s): `mics` are the six microphone positions (world, m), `motor` the
/// larger |motor command| (0..=255).
pub fn sample_frames(
    config: &SoundConfig,
    room: &Room,
    speakers: &[Speaker],
    mics: &[(f64, f64); MICS],
    motor: f64,
    t0: f64,
    rng: &mut Xoshiro256PlusPlus,
) -> MicFrames {
    // Every path as (amplitude, delay, freq, phase): direct + 4 wall images.
    let mut paths: Vec<[(f64, f64, f64, f64); 5]> = Vec::with_capacity(speakers.len());
    let mut frames = [[0u16; FRAME_LEN]; MICS];
    let vib = config.vibration * (motor / 255.0).clamp(0.0, 1.0);
    for (m, frame) in mics.iter().zip(frames.iter_mut()) {
        paths.clear();
        for s in speakers {
            let images = [
                (s.x, s.y, 1.0),
                (-s.x, s.y, config.echo_gain),
                (2.0 * room.width - s.x, s.y, config.echo_gain),
                (s.x, -s.y, config.echo_gain),
                (s.x, 2.0 * room.height - s.y, config.echo_gain),
            ];
            paths.push(images.map(|(ix, iy, g)| {
                let d = (ix - m.0).hypot(iy - m.1);
                (g * config.amplitude(d), d / SPEED_OF_SOUND, s.freq, s.phase)
            }));
        }
        for (i, out) in frame.iter_mut().enumerate() {
            let t = t0 + i as f64 / config.sample_rate;
            let mut v = ADC_MID;
            for &(a, delay, f, phase) in paths.iter().flatten() {
                if a != 0.0 {
                    v += a * (TAU * f * (t - delay) + phase).sin();
                }
            }
            if vib != 0.0 {
                v += vib * config.vibration_hz.iter().map(|f| (TAU * f * t).sin()).sum::<f64>();
            }
            if config.sensor_noise != 0.0 {
                v += config.sensor_noise * gaussian(rng);
            }
            // Exact: an integer in 0..=4095.
            *out = v.round().clamp(0.0, ADC_MAX) as u16;
        }
    }
    frames
}

/// One standard normal draw (Box–Muller; the workspace has no rand_distr).
fn gaussian(rng: &mut Xoshiro256PlusPlus) -> f64 {
    let u1: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.gen();
    (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos()
}

/// Microphone positions (world, m) of a robot at (x, y) with `heading`:
/// the paper's ring, M1 on the robot's x axis, counter-clockwise.
pub fn mic_positions(x: f64, y: f64, heading: f64, radius: f64) -> [(f64, f64); MICS] {
    core::array::from_fn(|n| {
        let a = heading + TAU * n as f64 / MICS as f64;
        (x + radius * a.cos(), y + radius * a.sin())
    })
}
