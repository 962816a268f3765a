//! Size probe: the firmware core and nothing else, every entry point called
//! with inputs the optimiser cannot see. `bycoms-fw-host sizes` on this ELF
//! minus `empty` is what the core adds to a firmware image (code,
//! constants, soft-float and libm routines it pulls in). Never run.
#![no_std]
#![no_main]

use bycoms_agent::firmware::{Firmware, FirmwareConfig};
use bycoms_protocol::link::{LinkKey, MAX_FRAME_LEN};
use bycoms_protocol::RobotId;
use core::hint::black_box;
use core::time::Duration;

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}

#[riscv_rt::entry]
fn main() -> ! {
    let key: [u8; 32] = black_box([7; 32]);
    let config = FirmwareConfig::paper(RobotId(black_box(1)), black_box(320.0), black_box([224.0, 512.0]));
    let Ok(mut fw) = Firmware::new(config, LinkKey::new(&key), key) else { loop {} };
    let frames = [[0u16; 512]; 6];
    let mut buf = [0u8; MAX_FRAME_LEN];
    let rx = [0u8; 128];
    loop {
        let now = Duration::from_micros(black_box(0));
        let _ = black_box(fw.handle_datagram(&rx[..black_box(40)], now));
        fw.handle_mics(black_box(&frames), now);
        fw.handle_timeout(black_box(now));
        if let Some(frame) = fw.poll_transmit(now, &mut buf) {
            black_box(frame);
        }
        fw.set_battery(black_box(4000));
        black_box((fw.motors(), fw.tone(), fw.poll_timeout(), fw.state(), fw.last_telemetry(), fw.drops()));
    }
}
