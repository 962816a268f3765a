//! Size probe: the same start-up as `core-size` without the core (the
//! baseline `bycoms-fw-host sizes` subtracts). Never run.
#![no_std]
#![no_main]

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}

#[riscv_rt::entry]
fn main() -> ! {
    loop {
        core::hint::black_box(0u32);
    }
}
