//! Where a control period's instructions go: the pieces of `handle` (mics)
//! measured alone on one recorded-like frame, and the price of single
//! soft-float operations (riscv32imc has no FPU: every `f32`/`f64`
//! operation is a call into compiler_builtins; tone isolation is integer
//! arithmetic but for its last square roots).

use bycoms_agent::acoustic::{Frame, MicRing, ToneConfig, ToneIsolator};
use core::hint::black_box;
use riscv::register::minstret;
use semihosting::println;

/// Instructions `f` takes (median of 5 runs: the first warms nothing on
/// QEMU, but keeps the figure robust).
fn count(mut f: impl FnMut()) -> u64 {
    let mut runs = [0u64; 5];
    for r in runs.iter_mut() {
        let t0 = minstret::read64();
        f();
        *r = minstret::read64() - t0;
    }
    runs.sort_unstable();
    runs[2]
}

fn frame() -> Frame {
    // ADC mid-scale, a loud own tone and a quieter other one, as integers.
    core::array::from_fn(|i| {
        let t = i as f32 / 4096.0;
        let s =
            2048.0 + 400.0 * libm::sinf(6.283_185_5 * 320.0 * t) + 90.0 * libm::sinf(6.283_185_5 * 224.0 * t);
        libm::roundf(s) as u16
    })
}

/// Prints the breakdown.
pub fn report() {
    let config = ToneConfig { sample_rate: 4096.0, gain: 256.0 };
    let input = frame();
    // The firmware's isolator (the own tone and two others: 9 bins), and
    // one listening for no other tone (3 bins): the difference is the price
    // of six bins' DFT sums, the rest the mean, the window and the square
    // roots.
    let (Ok(iso2), Ok(iso0)) =
        (ToneIsolator::new(config, 320.0, [224.0, 512.0]), ToneIsolator::new(config, 320.0, []))
    else {
        return;
    };
    let tones = count(|| {
        black_box(iso2.tones(black_box(&input)));
    });
    let own_only = count(|| {
        black_box(iso0.tones(black_box(&input)));
    });
    let per_bin = tones.saturating_sub(own_only) / 6;
    let rest = own_only.saturating_sub(3 * per_bin);
    let frames = [input; 6];
    let clip = count(|| {
        let f = black_box(&frames);
        black_box(f.iter().flatten().any(|&s| s == 0 || s >= 4095));
    });
    let ring = MicRing::paper();
    let v = [22000.0, 21000.0, 20500.0, 21500.0, 23000.0, 24000.0];
    let estimate = count(|| {
        black_box(ring.estimate(black_box(&v)));
    });
    let (a, b) = (black_box(1.2345f32), black_box(0.987f32));
    let mul32 = count(|| {
        for _ in 0..100 {
            black_box(black_box(a) * black_box(b));
        }
    });
    let add32 = count(|| {
        for _ in 0..100 {
            black_box(black_box(a) + black_box(b));
        }
    });
    let (c, d) = (black_box(1.2345f64), black_box(0.987f64));
    let mul64 = count(|| {
        for _ in 0..100 {
            black_box(black_box(c) * black_box(d));
        }
    });
    let add64 = count(|| {
        for _ in 0..100 {
            black_box(black_box(c) + black_box(d));
        }
    });
    let empty = count(|| {
        for _ in 0..100 {
            black_box(black_box(a));
        }
    });
    let per = |n: u64| n.saturating_sub(empty) as f64 / 100.0;
    println!(
        "parts: one microphone frame's tone isolation (3 tones, 9 bins) {tones} instructions: one bin's DFT sum {per_bin}, the mean, the window and the amplitudes' square roots {rest}"
    );
    println!(
        "parts: six frames' tone isolation = {} instructions; the clipping check of the six frames {clip}; the ring estimate (V_ave, gradient) {estimate}",
        6 * tones
    );
    println!(
        "parts: one soft-float operation, call included: f32 mul {:.0}, f32 add {:.0}, f64 mul {:.0}, f64 add {:.0} instructions",
        per(mul32),
        per(add32),
        per(mul64),
        per(add64)
    );
}
