//! Host cost of the firmware core's work per control period: one
//! `handle_mics` (six frames' integer tone isolation, the ring estimate, the drive law,
//! telemetry) and one telemetry `poll_transmit` (HMAC-SHA256 tag). The
//! ESP32 must fit this in its 125 ms period; measure there before trusting
//! it (see deploy/esp32/README.md).
//!
//! Run: `cargo bench -p bycoms-agent --bench firmware`.

use bycoms_agent::firmware::{Firmware, FirmwareConfig, MicFrames};
use bycoms_protocol::link::{LinkKey, MAX_FRAME_LEN};
use bycoms_protocol::RobotId;
use core::time::Duration;
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
        t += 125;
        fw.handle_mics(black_box(&input), Duration::from_millis(t));
    });
}

#[divan::bench]
fn hello_poll_transmit(bencher: divan::Bencher) {
    let mut fw = firmware();
    let mut buf = [0u8; MAX_FRAME_LEN];
    let mut t = 0u64;
    bencher.bench_local(|| {
        t += 250;
        fw.poll_transmit(Duration::from_millis(t), &mut buf).map(|f| f.len())
    });
}
