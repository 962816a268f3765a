//! The firmware core on a bare-metal RV32IMC core (the ESP32-C3's ISA) under
//! `qemu-system-riscv32 -machine virt`: plays a recorded input sequence
//! (`bycoms-fw-host record`) into `bycoms_agent::firmware::Firmware`
//! through the shared shell (`bycoms-fw-replay`), writes the shell's output
//! lines to a file on the host (semihosting), and prints a bench: RISC-V
//! instructions (`minstret`) and cycles (`mcycle`) per core call, and the
//! stack the core's calls need.
//!
//! ```text
//! qemu-system-riscv32 -machine virt -nographic -bios none -icount shift=0 \
//!   -semihosting-config enable=on,target=native,arg=bycoms-fw-qemu,arg=INPUT,arg=OUTPUT \
//!   -kernel bycoms-fw-qemu
//! ```
//!
//! `-icount shift=0` matters: without it QEMU's `minstret` and `mcycle`
//! read the host's clock; with it both count retired guest instructions
//! (so "cycles" here are instructions at one instruction per cycle, see
//! deploy/esp32/README.md for the CPI of the real chip).
#![no_std]
#![no_main]

mod bench;
mod io;
mod parts;

use bycoms_fw_replay::{Shell, MIC_BYTES};
use semihosting::{print, println};

/// Exit codes: 0 played to the end, 1 a replay error, 2 usage or IO, 101 a panic.
#[riscv_rt::entry]
fn main() -> ! {
    // First: paint the stack below us, before anything else runs deep.
    bench::paint_whole_stack();
    let args = match semihosting::experimental::env::args::<256>() {
        Ok(a) => a,
        Err(e) => fail(2, format_args!("no semihosting arguments: {e:?}")),
    };
    let mut it = (&args).skip(1).filter_map(Result::ok);
    let (Some(input), Some(output)) = (it.next(), it.next()) else {
        fail(2, format_args!("usage: bycoms-fw-qemu INPUT OUTPUT (semihosting arguments)"))
    };
    let mut reader = match io::Reader::open(input) {
        Ok(r) => r,
        Err(e) => fail(2, format_args!("cannot open {input}: {e:?}")),
    };
    let mut writer = match io::Writer::create(output) {
        Ok(w) => w,
        Err(e) => fail(2, format_args!("cannot create {output}: {e:?}")),
    };
    let mut shell = Shell::new();
    let mut mics = [0u8; MIC_BYTES];
    let mut meter = bench::CsrMeter::new();
    let played = shell.play(&mut reader, &mut mics, &mut meter, &mut writer);
    let flushed = writer.flush();
    if let Err(e) = played {
        fail(1, format_args!("replay failed: {e} (after {} tracks)", shell.tracks));
    }
    if flushed.is_err() {
        fail(2, format_args!("cannot write {output}"));
    }
    meter.report(shell.tracks);
    parts::report();
    semihosting::process::exit(0)
}

/// A panic ends QEMU with exit code 101 after printing where.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    fail(101, format_args!("panicked: {info}"))
}

/// Prints the reason and ends QEMU with `code`.
fn fail(code: i32, why: core::fmt::Arguments<'_>) -> ! {
    print!("bycoms-fw-qemu: ");
    println!("{why}");
    semihosting::process::exit(code)
}
