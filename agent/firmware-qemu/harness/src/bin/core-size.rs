//! Size probe: the firmware core and nothing else, every entry point called
//! with inputs the optimiser cannot see. `bycoms-fw-host sizes` on this ELF
//! minus `empty` is what the core adds to a firmware image (code,
//! constants, soft-float and libm routines it pulls in). Never run.
#![no_std]
#![no_main]

use bycoms_agent::firmware::{Firmware, FirmwareConfig, FirmwareInput};
use bycoms_protocol::link::LinkKey;
use bycoms_protocol::{RobotId, SansIo};
use core::hint::black_box;

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
    let rx = [0u8; 128];
    loop {
        let now = black_box(0);
        let _ = black_box(fw.handle(now, FirmwareInput::Datagram(&rx[..black_box(40)])));
        let _ = black_box(fw.handle(now, FirmwareInput::Mics(black_box(&frames))));
        fw.advance(black_box(now));
        if let Some(frame) = fw.poll() {
            black_box(frame);
        }
        fw.set_battery(black_box(4000));
        black_box((fw.motors(), fw.tone(), fw.deadline(), fw.state(), fw.last_telemetry(), fw.drops()));
    }
}
