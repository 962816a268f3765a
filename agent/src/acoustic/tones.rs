//! Isolating the other robots' tones from one microphone frame (paper §VI-C).
//!
//! Every robot plays its own sine (paper: 224, 320 and 512 Hz), and its own
//! speaker sits a few centimetres from its microphones: its own tone is by far
//! the loudest thing it hears, and being equal at all microphones only in
//! theory, it would swamp the gradient. So each microphone's V_n is the sum of
//! the amplitudes of the *other* robots' tones, read off the frame's discrete
//! Fourier transform.
//!
//! A frame is [`FRAME_LEN`] = 512 raw samples of a 12-bit ADC ([`Frame`]:
//! `u16`, 0..=[`ADC_MAX`]; a larger value, which a 12-bit ADC cannot give, is
//! saturated to `ADC_MAX`). Processing, all of it in integers but the last
//! square root:
//!
//! 1. the frame's mean is subtracted exactly: d = 512·x − Σx, in 1/512 counts;
//! 2. a periodic Hann window is applied (a Q28 table), giving the windowed
//!    sample in Q11 counts (1/2048 count, rounded) — without a window an own
//!    tone that is not exactly on a bin leaks ~1/(πΔ) of its amplitude Δ bins
//!    away, which for a loud own tone is as much as the others' tones
//!    themselves; with it the leakage falls as 1/Δ³;
//! 3. only the bins that are read are computed: for each tone the nearest bin
//!    k of its *configured* frequency and k ± 1, i.e. 3·(K + 1) bins (9 for
//!    the paper's three robots), each as a direct DFT sum over the 512
//!    windowed samples with a Q31 cosine table: per sample and bin two
//!    32×32 → high-32 multiplies (`mulh`, one instruction each on RV32IMC)
//!    and two 32-bit additions;
//! 4. a tone's amplitude is the root-sum-square of its three bins, scaled so
//!    that a sine of amplitude A reads A (times [`ToneConfig::gain`]), in `f64`.
//!    The Hann main lobe puts (nearly) all of a tone's energy in those three
//!    bins wherever the tone falls between bins: the worst-case scalloping
//!    error is 1.0 % (on-bin: exact), against 36 % for a single bin of an
//!    unwindowed DFT. A speaker that drifts off its configured frequency
//!    loses 1.0 % at half a bin (4 Hz at the default rate) and 8.7 % at a
//!    whole bin.
//!
//! Why integers: the ESP32-C3 (RV32IMC) has no FPU but multiplies integers in
//! hardware. The `f32` path this replaces (mean in `f64`, window in `f32`,
//! microfft's `rfft_512`, 3 bins per tone read) cost 856 k instructions per
//! frame there, 5.14 M per control period (six frames), 93 % of the period;
//! this one costs 68 k per frame: 6.1 k per bin (11.9 instructions per
//! sample), 13 k for the mean, the window and the square roots
//! (`agent/firmware-qemu`, the `parts:` lines of its bench). Why a direct
//! DFT of the 9 bins rather than a 512-point FFT of all 256: an integer
//! real FFT (1 024 butterflies of some 25–30 instructions, the real-FFT
//! post-processing, scaling per stage; estimated, not built) might cost
//! half as much, but rounds at every one of its 9 stages where the
//! direct sum rounds once per term, and would be several hundred lines to
//! write or a crate to find and vet (microfft, used before, has `f32`
//! transforms only; no integer FFT crate was evaluated here); the
//! direct sums are the 20 lines of `ToneIsolator::bins` and already far
//! under the budget. (A Goertzel recursion would be cheaper still per bin,
//! but in fixed point its state grows with the frame and its coefficient's
//! rounding detunes the resonator: harder to bound.) Integer arithmetic
//! also gives the same bits on every target, so the firmware's outputs on
//! the chip equal the host's (the square root and the scaling are IEEE 754
//! `f64`, exact on both, through `libm`).
//!
//! **Range, no overflow** (for every input: samples are saturated to 12 bits
//! first). |d| ≤ 4095·511 < 2²¹ and the Q28 window ≤ 2²⁸, so d·w < 2⁴⁹ is
//! an `i64` product; the windowed sample |y| = |x − mean|·w·2¹¹ < 2²³. The
//! window's table sums to 256·2²⁸ (± 2⁸), so Σ|y| ≤ 4095·256·2¹¹ + 512 <
//! 2³¹. A DFT term is ⌊y·c / 2³²⌋ with |c| ≤ 2³¹, at most |y|/2 + 1, so an
//! accumulator (Q10 counts) stays within 2³⁰ + 512 whatever the samples: an
//! `i32` holds it with a factor 2 to spare. A bin's energy re² + im² is
//! about 2⁶¹ at most, three bins' sum < 2⁶³: a `u64`. The tests feed full-scale square waves and
//! alternating 0/4095 frames in debug builds, where an overflow panics.
//!
//! **Precision.** Against the exact DFT of the same 12-bit samples (exact
//! mean, exact Hann window, real arithmetic), each bin's real and imaginary
//! parts are off by at most 0.5 counts from the truncating multiplies (each
//! of the 512 terms is floored: an error in (−1, 0] LSB of Q10; no rounding
//! constant is added, so that silence reads exactly 0), 0.125 counts from
//! rounding y to Q11, 0.004 from the Q28 window and 0.0005 from the Q31
//! cosines: < 0.63 counts, where an on-bin tone of amplitude A has
//! |X_k| = 128·A counts. So the arithmetic moves a tone's amplitude by at
//! most √6·0.63·√(32/3)/512 < 0.01 counts (times the gain; a test checks it
//! against an `f64` DFT) — a fourth of the noise that the ADC's own
//! rounding to whole counts adds (0.044 counts rms per tone: a uniform ±½
//! count per sample). **Dynamic range**: from a full-scale own tone (2047
//! counts) down to that noise floor, 93 dB; the arithmetic's worst case is
//! 106 dB down.
//!
//! The paper's 224/320/512 Hz fall exactly on bins 28/40/64 at the default
//! 4096 Hz sample rate (8 Hz bins, a 125 ms frame). Tones must be at least
//! [`MIN_SEPARATION_BINS`] bins apart so that their three-bin windows and
//! main lobes do not overlap.

/// Samples per frame: the DFT's length.
pub const FRAME_LEN: usize = 512;

/// The largest sample of the 12-bit ADC; larger values are saturated to it.
pub const ADC_MAX: u16 = 4095;

/// One microphone frame: raw 12-bit ADC samples.
pub type Frame = [u16; FRAME_LEN];

/// Smallest allowed distance between two tones, in bins.
pub const MIN_SEPARATION_BINS: f64 = 4.0;

/// The paper's tones, Hz.
pub const PAPER_TONES: [f64; 3] = [224.0, 320.0, 512.0];

/// Fractional bits of the window table.
const WINDOW_BITS: u32 = 28;
/// Fractional bits of a windowed sample (Q11 counts).
const SAMPLE_BITS: u32 = 11;
/// log2(FRAME_LEN): the mean-free sample 512·x − Σx is in Q9 counts.
const LEN_BITS: u32 = FRAME_LEN.trailing_zeros();
/// Q9 × Q28 → Q11.
const WINDOW_SHIFT: u32 = LEN_BITS + WINDOW_BITS - SAMPLE_BITS;
/// Fractional bits of a bin's real and imaginary parts: Q11 × Q31 / 2³².
const BIN_BITS: u32 = SAMPLE_BITS - 1;
/// Entries of the cosine table: one period plus a quarter, so that the sine
/// (the cosine a quarter period on) needs no wrap-around.
const COS_LEN: usize = FRAME_LEN + FRAME_LEN / 4;

// The overflow argument of the module docs assumes exactly these.
const _: () = assert!(FRAME_LEN.is_power_of_two() && LEN_BITS == 9 && ADC_MAX == 4095);
const _: () = assert!(WINDOW_BITS == 28 && SAMPLE_BITS == 11);

/// Sampling parameters shared by every microphone of a robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneConfig {
    /// Sample rate of the microphone frames, Hz. Bin width = rate / 512.
    pub sample_rate: f64,
    /// Factor from a tone's amplitude in ADC counts to the units of V_n (and
    /// so of the drive thresholds). 1 gives the sine amplitude itself;
    /// `FRAME_LEN / 2` gives the magnitude an unwindowed DFT shows for an
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
    /// Width of one DFT bin, Hz.
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
    /// The nearest bin of each tone.
    own_bin: usize,
    other_bins: [usize; K],
    /// The periodic Hann window, Q28.
    window: [i32; FRAME_LEN],
    /// cos(2π·m/512) for m in 0..640, Q31 (1 saturates to `i32::MAX`).
    cos: [i32; COS_LEN],
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
        // In band: 2 ≤ k ≤ 254, so k ± 1 never touches DC or Nyquist.
        let bin = |t: f64| libm::round(config.bin(t)) as usize;
        let phase = |m: usize| core::f64::consts::TAU * m as f64 / FRAME_LEN as f64;
        // Both tables through `libm` (the same Rust code on every target) and
        // IEEE 754 `f64`: the same integers everywhere.
        let window = core::array::from_fn(|i| {
            libm::round((0.5 - 0.5 * libm::cos(phase(i))) * f64::from(1u32 << WINDOW_BITS)) as i32
        });
        let cos = core::array::from_fn(|m| {
            // `as` saturates: cos 0 = 1 becomes i32::MAX.
            libm::round(libm::cos(phase(m)) * 2_147_483_648.0) as i32
        });
        Ok(Self { config, own, others, own_bin: bin(own), other_bins: others.map(bin), window, cos })
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

    /// Amplitudes of the own and the other tones.
    pub fn tones(&self, frame: &Frame) -> ToneAmplitudes<K> {
        let y = self.windowed(frame);
        let amp = |k: usize| self.tone_amplitude(&y, k);
        ToneAmplitudes { own: amp(self.own_bin), others: self.other_bins.map(amp) }
    }

    /// V_n: the summed amplitude of the other robots' tones in this frame
    /// (own tone excluded).
    pub fn amplitude(&self, frame: &Frame) -> f64 {
        self.tones(frame).sum_others()
    }

    /// Steps 1 and 2: the mean-free, windowed samples, Q11 counts.
    fn windowed(&self, frame: &Frame) -> [i32; FRAME_LEN] {
        let sample = |s: u16| i32::from(s.min(ADC_MAX));
        // ≤ 512 · 4095 < 2²¹.
        let sum: i32 = frame.iter().map(|&s| sample(s)).sum();
        let mut y = [0i32; FRAME_LEN];
        for ((y, &s), &w) in y.iter_mut().zip(frame).zip(&self.window) {
            let d = sample(s) * FRAME_LEN as i32 - sum;
            let rounded = (i64::from(d) * i64::from(w) + (1 << (WINDOW_SHIFT - 1))) >> WINDOW_SHIFT;
            // |rounded| < 2²³ (module docs).
            *y = rounded as i32;
        }
        y
    }

    /// Step 3: bins k − 1, k and k + 1 of the windowed frame, real and
    /// imaginary parts in Q10 counts. One pass for the three: each sample
    /// is loaded once (a 33-instruction loop for the three on RV32IMC: 11.9
    /// per sample and bin with the set-up, 13.6 one bin at a time); integer
    /// sums, so the order changes no bit.
    fn bins(&self, y: &[i32; FRAME_LEN], k: usize) -> [(i32, i32); 3] {
        // Three named accumulators, not arrays: registers at any opt-level.
        let (mut below, mut at, mut above) = ((0, 0), (0, 0), (0, 0));
        let (mut m_below, mut m_at, mut m_above) = (0, 0, 0);
        for &v in y {
            self.term(&mut below, &mut m_below, v, k - 1);
            self.term(&mut at, &mut m_at, v, k);
            self.term(&mut above, &mut m_above, v, k + 1);
        }
        [below, at, above]
    }

    /// One term of bin `step`'s sum: X += v·(cos − i·sin) at phase `m`,
    /// then the phase advances by `step` (mod 512); cos(θ + π/2) = −sin θ.
    #[inline(always)]
    fn term(&self, x: &mut (i32, i32), m: &mut usize, v: i32, step: usize) {
        x.0 += mulh(v, self.cos[*m]);
        x.1 += mulh(v, self.cos[*m + FRAME_LEN / 4]);
        *m = (*m + step) % FRAME_LEN;
    }

    /// Step 4: root-sum-square of the tone's bin `k` and its neighbours,
    /// scaled so an on-bin sine of amplitude A reads A · gain: a
    /// Hann-windowed on-bin sine gives |X| = A·N/4 at its bin and A·N/8 at
    /// each neighbour, so the sum of squares is A²N²·3/32.
    fn tone_amplitude(&self, y: &[i32; FRAME_LEN], k: usize) -> f64 {
        let energy: u64 = self
            .bins(y, k)
            .iter()
            .map(|&(re, im)| u64::from(re.unsigned_abs()).pow(2) + u64::from(im.unsigned_abs()).pow(2))
            .sum();
        let scale = f64::from(1u32 << BIN_BITS) * FRAME_LEN as f64;
        libm::sqrt(energy as f64 * 32.0 / 3.0) / scale * self.config.gain
    }
}

/// ⌊a·b / 2³²⌋: RV32IMC's `mulh`.
#[inline(always)]
fn mulh(a: i32, b: i32) -> i32 {
    ((i64::from(a) * i64::from(b)) >> 32) as i32
}

#[cfg(test)]
mod tests;
