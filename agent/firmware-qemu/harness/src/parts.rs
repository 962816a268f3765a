//! Where a control period's instructions go: the pieces of `handle_mics`
//! measured alone on one recorded-like frame, and the price of single
//! soft-float operations (riscv32imc has no FPU: every `f32`/`f64`
//! operation is a call into compiler_builtins).

use bycoms_agent::acoustic::{MicRing, ToneConfig, ToneIsolator, FRAME_LEN};
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

fn frame() -> [f32; FRAME_LEN] {
    // ADC mid-scale, a loud own tone and a quieter other one, as integers.
    core::array::from_fn(|i| {
        let t = i as f32 / 4096.0;
        let s =
            2048.0 + 400.0 * libm::sinf(6.283_185_5 * 320.0 * t) + 90.0 * libm::sinf(6.283_185_5 * 224.0 * t);
        libm::roundf(s)
    })
}

/// Prints the breakdown.
pub fn report() {
    let config = ToneConfig { sample_rate: 4096.0, gain: 256.0 };
    let Ok(isolator) = ToneIsolator::new(config, 320.0, [224.0, 512.0]) else { return };
    let input = frame();
    let tones = count(|| {
        let mut f = black_box(input);
        black_box(isolator.tones(&mut f));
    });
    // The pieces of `ToneIsolator::tones` and `Firmware::handle_mics`
    // around the FFT, written as they are there (agent/src/acoustic/tones.rs,
    // agent/src/firmware/mod.rs).
    let window: [f32; FRAME_LEN] = core::array::from_fn(|i| {
        let phase = core::f64::consts::TAU * i as f64 / FRAME_LEN as f64;
        (0.5 - 0.5 * libm::cos(phase)) as f32
    });
    let mean = count(|| {
        let f = black_box(&input);
        black_box(f.iter().map(|&s| f64::from(s)).sum::<f64>() / FRAME_LEN as f64);
    });
    let windowing = count(|| {
        let mut f = black_box(input);
        let m = black_box(2048.0f32);
        for (s, w) in f.iter_mut().zip(&window) {
            *s = (*s - m) * w;
        }
        black_box(f);
    });
    // The FFT of the frame as `tones` hands it over (mean removed, windowed):
    // soft-float costs depend on the operands.
    let mut windowed = input;
    let m = input.iter().map(|&s| f64::from(s)).sum::<f64>() as f32 / FRAME_LEN as f32;
    for (s, w) in windowed.iter_mut().zip(&window) {
        *s = (*s - m) * w;
    }
    let fft = count(|| {
        let mut f = black_box(windowed);
        black_box(microfft::real::rfft_512(&mut f));
    });
    let clip = count(|| {
        let f = black_box(&input);
        black_box(f.iter().any(|&s| s <= 0.0 || s >= 4095.0));
    });
    let copy = count(|| {
        black_box(black_box(input));
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
    println!("parts: one microphone frame: rfft_512 {} instructions; tone isolation (mean, Hann window, rfft_512, 3 tones) {} (frame copy {} not subtracted)", fft, tones, copy);
    println!(
        "parts: of which, per frame: the f64 mean {mean}, subtracting it and the Hann window {windowing}; the clipping check (handle_mics) {clip} per frame"
    );
    println!(
        "parts: six frames' tone isolation = {} instructions; the ring estimate (V_ave, gradient) {}",
        6 * tones,
        estimate
    );
    println!(
        "parts: one soft-float operation, call included: f32 mul {:.0}, f32 add {:.0}, f64 mul {:.0}, f64 add {:.0} instructions",
        per(mul32),
        per(add32),
        per(mul64),
        per(add64)
    );
}
