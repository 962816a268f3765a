//! Host cost of the firmware core's work per control period: one
//! `handle` of the microphone frames (six frames' integer tone isolation, the ring estimate, the drive law,
//! telemetry) and one `poll` of a frame (HMAC-SHA256 tag). The
//! ESP32 must fit this in its 125 ms period; measure there before trusting
//! it (see deploy/esp32/README.md).
//!
//! Run: `cargo bench -p bycoms-agent --bench firmware`.

use bycoms_agent::firmware::{Firmware, FirmwareConfig, FirmwareInput, MicFrames};
use bycoms_protocol::link::LinkKey;
use bycoms_protocol::{RobotId, SansIo};
use divan::black_box;

fn main() {
    divan::main();
}

fn firmware() -> Firmware<2> {
    let config = FirmwareConfig::paper(RobotId(1), 320.0, [224.0, 512.0]);
    match Firmware::new(config, LinkKey::new(&[1; 32]), [2; 32]) {
        Ok(f) => f,
        Err(e) => panic!("paper config: {e}"),
    }
}

fn frames() -> MicFrames {
    core::array::from_fn(|n| {
        core::array::from_fn(|i| {
            let t = i as f64 / 4096.0;
            let a = 90.0 + 10.0 * (n as f64).cos();
            (2048.0 + 400.0 * (1407.4 * t).sin() + a * (1407.4 * 0.7 * t).sin()).round() as u16
        })
    })
}

#[divan::bench]
fn handle_mics(bencher: divan::Bencher) {
    let mut fw = firmware();
    let input = frames();
    let mut t = 0u64;
    bencher.bench_local(|| {
        t += 125_000;
        fw.handle(t, FirmwareInput::Mics(black_box(&input)))
    });
}

#[divan::bench]
fn hello_poll(bencher: divan::Bencher) {
    let mut fw = firmware();
    let mut t = 0u64;
    bencher.bench_local(|| {
        t += 250_000;
        fw.advance(t);
        fw.poll().map(|f| f.len())
    });
}
