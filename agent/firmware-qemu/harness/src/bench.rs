//! The bench: RISC-V counters around each core call, and the stack the
//! core's calls use.
//!
//! * Instructions: `minstret` read right before and right after the call
//!   (the two reads and the call's own frame setup are counted too: a few
//!   instructions).
//! * Cycles: `mcycle` the same way. Under QEMU with `-icount shift=0` both
//!   counters advance by one per retired instruction, so the cycle figure
//!   equals the instruction figure; the real chip's cycles are
//!   instructions × its CPI (deploy/esp32/README.md).
//! * Stack: before each measured call the 32 KiB below the current stack
//!   pointer are painted with a pattern; after it, the lowest word that no
//!   longer holds the pattern says how deep the call went. At boot the
//!   whole stack area is painted once, and scanned at the end: the whole
//!   program's high-water mark.

use bycoms_fw_replay::{Call, Meter};
use core::arch::asm;
use core::ptr::{addr_of, read_volatile, write_volatile};
use riscv::register::{mcycle, minstret};
use semihosting::println;

const PATTERN: u32 = 0xC0FF_EE55;
/// How far below the caller's stack pointer each call's stack is watched.
const WINDOW: usize = 32 * 1024;
/// The paper's control period budget: 10 % of 100 ms at 160 MHz.
const BUDGET_CYCLES: u64 = 1_600_000;

extern "C" {
    // riscv-rt's linker script: the heap's end (= the lowest stack address,
    // `_heap_size` is 0) and the stack's top.
    static __eheap: u32;
    static _stack_start: u32;
}

#[inline(always)]
fn sp() -> usize {
    let sp: usize;
    // SAFETY: reads the stack pointer register, nothing else.
    unsafe { asm!("mv {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags)) };
    sp
}

fn stack_bottom() -> usize {
    addr_of!(__eheap) as usize
}

fn stack_top() -> usize {
    addr_of!(_stack_start) as usize
}

/// Paints [from, to) with the pattern.
#[inline(always)]
fn paint(from: usize, to: usize) {
    let mut a = from & !3;
    while a + 4 <= to {
        // SAFETY: [from, to) lies below the stack pointer and above the
        // heap's end (no heap): memory nothing else uses.
        unsafe { write_volatile(a as *mut u32, PATTERN) };
        a += 4;
    }
}

/// The lowest address in [from, to) that lost the pattern (`to` if none).
#[inline(always)]
fn lowest_used(from: usize, to: usize) -> usize {
    let mut a = from & !3;
    while a + 4 <= to {
        // SAFETY: as in `paint`; reading only.
        if unsafe { read_volatile(a as *const u32) } != PATTERN {
            return a;
        }
        a += 4;
    }
    to
}

/// Paints the whole stack area below the caller (at boot).
#[inline(always)]
pub fn paint_whole_stack() {
    paint(stack_bottom(), sp() - 64);
}

/// Count, sum and worst of one kind of call.
#[derive(Clone, Copy, Default)]
struct Stats {
    count: u64,
    instructions: u64,
    max_instructions: u64,
    max_cycles: u64,
    max_stack: usize,
}

impl Stats {
    fn add(&mut self, instructions: u64, cycles: u64, stack: usize) {
        self.count += 1;
        self.instructions += instructions;
        self.max_instructions = self.max_instructions.max(instructions);
        self.max_cycles = self.max_cycles.max(cycles);
        self.max_stack = self.max_stack.max(stack);
    }

    fn mean(&self) -> u64 {
        self.instructions.checked_div(self.count).unwrap_or(0)
    }
}

/// Reads the counters around every core call.
pub struct CsrMeter {
    calls: [Stats; 4],
    /// A control period's work: `handle` of the microphone frames and the
    /// `poll` calls right after it (its telemetry frame).
    periods: Stats,
    period: Option<(u64, u64)>,
    start: (u64, u64, usize),
    overflow: bool,
}

fn index(call: Call) -> usize {
    match call {
        Call::Datagram => 0,
        Call::Mics => 1,
        Call::Timeout => 2,
        Call::Transmit => 3,
    }
}

impl CsrMeter {
    /// Nothing measured yet.
    pub fn new() -> Self {
        Self {
            calls: [Stats::default(); 4],
            periods: Stats::default(),
            period: None,
            start: (0, 0, 0),
            overflow: false,
        }
    }

    fn close_period(&mut self) {
        if let Some((instructions, cycles)) = self.period.take() {
            self.periods.add(instructions, cycles, 0);
        }
    }

    /// Prints the figures.
    pub fn report(&mut self, tracks: u32) {
        self.close_period();
        let top = stack_top();
        let whole = top - lowest_used(stack_bottom(), top);
        let p = self.periods;
        println!("bench: {tracks} firmware tracks, {} control periods", p.count);
        println!("bench: counters: minstret (instructions) and mcycle; under QEMU -icount shift=0 mcycle = minstret (1 instruction per cycle)");
        for (name, call) in [
            ("handle mics    ", Call::Mics),
            ("poll           ", Call::Transmit),
            ("handle datagram", Call::Datagram),
            ("advance        ", Call::Timeout),
        ] {
            let s = self.calls[index(call)];
            let stack = (call != Call::Timeout).then_some(s.max_stack);
            println!(
                "bench: {name} calls={:<6} mean={:>9} max={:>9} instructions, max {:>9} cycles, {}",
                s.count,
                s.mean(),
                s.max_instructions,
                s.max_cycles,
                StackText(stack)
            );
        }
        println!(
            "bench: control period (handle mics + its telemetry frame): mean={} max={} instructions, max {} cycles",
            p.mean(),
            p.max_instructions,
            p.max_cycles
        );
        for cpi in [1.0f64, 1.5, 2.0] {
            let cycles = p.max_instructions as f64 * cpi;
            println!(
                "bench: worst period at CPI {cpi:.1}: {:.0} cycles = {:.2} % of 100 ms at 160 MHz (budget 10 %: {BUDGET_CYCLES} cycles) {}",
                cycles,
                cycles / 16_000_000.0 * 100.0,
                if cycles <= BUDGET_CYCLES as f64 { "OK" } else { "OVER" }
            );
        }
        println!(
            "bench: RAM: the core's state (Firmware<2>) {} B, the shell's six 12-bit frames (u16) {} B",
            core::mem::size_of::<bycoms_fw_replay::Core>(),
            core::mem::size_of::<bycoms_agent::firmware::MicFrames>()
        );
        println!(
            "bench: stack: core calls at most {} bytes below the shell's frame{}; whole program {} of {} bytes",
            self.calls.iter().map(|s| s.max_stack).max().unwrap_or(0),
            if self.overflow { " (HIT THE 32 KiB WINDOW: more)" } else { "" },
            whole,
            top - stack_bottom()
        );
    }
}

/// A stack figure as text (`None`: not watched).
struct StackText(Option<usize>);

impl core::fmt::Display for StackText {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.0 {
            Some(bytes) => write!(f, "stack {bytes} B"),
            None => f.write_str("stack not watched"),
        }
    }
}

impl Meter for CsrMeter {
    #[inline(always)]
    fn start(&mut self, call: Call) {
        if call != Call::Transmit {
            self.close_period();
        }
        let sp = sp();
        if call != Call::Timeout {
            paint(sp - WINDOW, sp - 16);
        }
        let cycles = mcycle::read64();
        let instructions = minstret::read64();
        self.start = (instructions, cycles, sp);
    }

    #[inline(always)]
    fn stop(&mut self, call: Call) {
        let instructions = minstret::read64();
        let cycles = mcycle::read64();
        let (i0, c0, sp) = self.start;
        let (di, dc) = (instructions - i0, cycles - c0);
        let stack = if call == Call::Timeout {
            0
        } else {
            let low = lowest_used(sp - WINDOW, sp);
            if low == sp - WINDOW {
                self.overflow = true;
            }
            sp - low
        };
        self.calls[index(call)].add(di, dc, stack);
        match call {
            Call::Mics => self.period = Some((di, dc)),
            Call::Transmit => {
                if let Some((i, c)) = self.period.as_mut() {
                    *i += di;
                    *c += dc;
                }
            }
            _ => {}
        }
    }
}
