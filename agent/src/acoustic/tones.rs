//! Isolating the other robots' tones from one microphone frame (paper §VI-C).
//!
//! Every robot plays its own sine (paper: 224, 320 and 512 Hz), and its own
//! speaker sits a few centimetres from its microphones: its own tone is by far
//! the loudest thing it hears, and being equal at all microphones only in
//! theory, it would swamp the gradient. So each microphone's V_n is the sum of
//! the amplitudes of the *other* robots' tones, read off an FFT (microfft:
//! no_std, no allocation).
//!
//! Processing of one frame of [`FRAME_LEN`] = 512 samples:
//!
//! 1. the frame's mean is subtracted (ADC offsets are large and only cost
//!    f32 precision);
//! 2. a periodic Hann window is applied — without it an own tone that is not
//!    exactly on a bin leaks ~1/(πΔ) of its amplitude Δ bins away, which for
//!    a loud own tone is as much as the others' tones themselves; with it the
//!    leakage falls as 1/Δ³;
//! 3. `rfft_512`;
//! 4. a tone's amplitude is the root-sum-square of the nearest bin and its two
//!    neighbours, scaled so that a sine of amplitude A reads A (times
//!    [`ToneConfig::gain`]). The Hann main lobe puts (nearly) all of a tone's
//!    energy in those three bins wherever the tone falls between bins: the
//!    worst-case scalloping error is 1.0 % (on-bin: exact), against 36 %
//!    for a single bin of an unwindowed FFT. The nearest bin is taken from
//!    the *configured* frequency: a speaker that drifts off it loses 1.0 %
//!    at half a bin (4 Hz at the default rate) and 8.7 % at a whole bin.
//!
//! The paper's 224/320/512 Hz fall exactly on bins 28/40/64 at the default
//! 4096 Hz sample rate (8 Hz bins, a 125 ms frame). Tones must be at least
//! [`MIN_SEPARATION_BINS`] bins apart so that their three-bin windows and
//! main lobes do not overlap.

use microfft::Complex32;

/// Samples per frame: the FFT size.
pub const FRAME_LEN: usize = 512;

/// Smallest allowed distance between two tones, in bins.
pub const MIN_SEPARATION_BINS: f64 = 4.0;

/// The paper's tones, Hz.
pub const PAPER_TONES: [f64; 3] = [224.0, 320.0, 512.0];

/// Sampling parameters shared by every microphone of a robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneConfig {
    /// Sample rate of the microphone frames, Hz. Bin width = rate / 512.
    pub sample_rate: f64,
    /// Factor from a tone's amplitude in input sample units to the units of
    /// V_n (and so of the drive thresholds). 1 gives the sine amplitude itself;
    /// `FRAME_LEN / 2` gives the magnitude an unwindowed FFT shows for an
    /// on-bin tone.
    pub gain: f64,
}

impl Default for ToneConfig {
    /// 4096 Hz, gain 1: 8 Hz bins, the paper's tones on bins 28/40/64.
    fn default() -> Self {
        Self { sample_rate: 4096.0, gain: 1.0 }
    }
}

impl ToneConfig {
    /// Width of one FFT bin, Hz.
    pub fn bin_width(&self) -> f64 {
        self.sample_rate / FRAME_LEN as f64
    }

    /// Fractional bin of `freq` Hz.
    pub fn bin(&self, freq: f64) -> f64 {
        freq / self.bin_width()
    }
}

/// Why a set of tones cannot be isolated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToneError {
    /// The sample rate is not a positive finite number.
    BadSampleRate(f64),
    /// The tone's nearest bin is outside 2..=254 (too close to DC or Nyquist).
    OutOfBand(f64),
    /// Two tones (Hz) are closer than [`MIN_SEPARATION_BINS`].
    TooClose(f64, f64),
}

impl core::fmt::Display for ToneError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::BadSampleRate(r) => write!(f, "sample rate {r} Hz is not positive"),
            Self::OutOfBand(t) => write!(f, "tone {t} Hz is too close to DC or Nyquist"),
            Self::TooClose(a, b) => {
                write!(f, "tones {a} Hz and {b} Hz are closer than {MIN_SEPARATION_BINS} bins")
            }
        }
    }
}

impl core::error::Error for ToneError {}

/// Amplitudes of every tone in one frame, in V_n units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneAmplitudes<const K: usize> {
    /// The robot's own tone (diagnostics only; never part of V_n).
    pub own: f64,
    /// The other robots' tones, in the order given to [`ToneIsolator::new`].
    pub others: [f64; K],
}

impl<const K: usize> ToneAmplitudes<K> {
    /// V_n: the sum of the other robots' amplitudes.
    pub fn sum_others(&self) -> f64 {
        self.others.iter().sum()
    }
}

/// Turns one microphone frame into V_n: the summed amplitude of the other
/// robots' tones (K of them), excluding the robot's own.
#[derive(Clone, Debug, PartialEq)]
pub struct ToneIsolator<const K: usize> {
    config: ToneConfig,
    own: f64,
    others: [f64; K],
    window: [f32; FRAME_LEN],
}

impl<const K: usize> ToneIsolator<K> {
    /// An isolator for a robot playing `own` Hz that listens for `others` Hz.
    pub fn new(config: ToneConfig, own: f64, others: [f64; K]) -> Result<Self, ToneError> {
        if !(config.sample_rate > 0.0 && config.sample_rate.is_finite()) {
            return Err(ToneError::BadSampleRate(config.sample_rate));
        }
        let in_band = |t: f64| {
            let k = libm::round(config.bin(t));
            (2.0..=(FRAME_LEN / 2 - 2) as f64).contains(&k)
        };
        for &t in core::iter::once(&own).chain(&others) {
            if !in_band(t) {
                return Err(ToneError::OutOfBand(t));
            }
        }
        for (i, &a) in others.iter().enumerate() {
            for &b in core::iter::once(&own).chain(&others[i + 1..]) {
                if libm::fabs(config.bin(a) - config.bin(b)) < MIN_SEPARATION_BINS {
                    return Err(ToneError::TooClose(a, b));
                }
            }
        }
        let window = core::array::from_fn(|i| {
            let phase = core::f64::consts::TAU * i as f64 / FRAME_LEN as f64;
            (0.5 - 0.5 * libm::cos(phase)) as f32
        });
        Ok(Self { config, own, others, window })
    }

    /// The sampling parameters.
    pub fn config(&self) -> &ToneConfig {
        &self.config
    }

    /// The robot's own tone, Hz.
    pub fn own(&self) -> f64 {
        self.own
    }

    /// The other robots' tones, Hz.
    pub fn others(&self) -> &[f64; K] {
        &self.others
    }

    /// Amplitudes of the own and the other tones. The frame is used as the
    /// FFT's work buffer and is overwritten.
    pub fn tones(&self, frame: &mut [f32; FRAME_LEN]) -> ToneAmplitudes<K> {
        let mean = frame.iter().map(|&s| f64::from(s)).sum::<f64>() / FRAME_LEN as f64;
        let mean = mean as f32;
        for (s, w) in frame.iter_mut().zip(&self.window) {
            *s = (*s - mean) * w;
        }
        let spectrum = microfft::real::rfft_512(frame);
        let amp = |freq: f64| self.tone_amplitude(spectrum, freq);
        ToneAmplitudes { own: amp(self.own), others: self.others.map(amp) }
    }

    /// V_n: the summed amplitude of the other robots' tones in this frame
    /// (own tone excluded). The frame is overwritten.
    pub fn amplitude(&self, frame: &mut [f32; FRAME_LEN]) -> f64 {
        self.tones(frame).sum_others()
    }

    /// Root-sum-square of the nearest bin and its neighbours, scaled so an
    /// on-bin sine of amplitude A reads A · gain: a Hann-windowed on-bin sine
    /// gives |X| = A·N/4 at its bin and A·N/8 at each neighbour, so the sum of
    /// squares is A²N²·3/32.
    fn tone_amplitude(&self, spectrum: &[Complex32; FRAME_LEN / 2], freq: f64) -> f64 {
        // `new` guarantees 2 ≤ k ≤ N/2 − 2, so k ± 1 is in bounds and never
        // touches bin 0 (whose imaginary part holds the Nyquist term).
        let k = libm::round(self.config.bin(freq)) as usize;
        let energy: f64 = spectrum[k - 1..=k + 1]
            .iter()
            .map(|c| {
                let (re, im) = (f64::from(c.re), f64::from(c.im));
                re * re + im * im
            })
            .sum();
        let n = FRAME_LEN as f64;
        libm::sqrt(energy * 32.0 / 3.0) / n * self.config.gain
    }
}

#[cfg(test)]
mod tests;
