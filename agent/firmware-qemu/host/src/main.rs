//! The host side of the firmware-under-QEMU check (issue 16):
//!
//! ```text
//! bycoms-fw-host record INPUT LIVE [SECONDS]   # exp-short in the emulated lab → inputs + the live run's output
//! bycoms-fw-host replay INPUT OUTPUT           # the inputs through the host build of the core
//! bycoms-fw-host compare INPUT LIVE QEMU       # host replay = live run = QEMU's output, byte for byte
//! bycoms-fw-host sizes ELF...                  # sections and code by crate of firmware images
//! bycoms-fw-host sizes ELF --minus BASELINE     # … and what ELF adds to BASELINE
//! ```
//!
//! Exit codes: 0 done (for `compare`: all equal), 1 a mismatch or a failed
//! replay, 2 usage or IO errors.
//!
//! A member of the bycoms workspace: `.ci/esp32` runs the binary that the
//! workspace's test build links for `tests/cli.rs`, a debug build (the core
//! and the lab at opt-level 2). Its floats are the same as a release
//! build's: Rust neither fuses `a*b+c` nor reorders float operations at any
//! opt-level, so the replay's text does not depend on the profile.

mod record;
mod sizes;

use bycoms_fw_replay::{NoMeter, Shell, MIC_BYTES};
use core::time::Duration;
use std::process::ExitCode;
use std::time::Instant;

const USAGE: &str = "usage: bycoms-fw-host record INPUT LIVE [SECONDS] | replay INPUT OUTPUT | compare INPUT LIVE QEMU | sizes ELF... | sizes ELF --minus BASELINE";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let result = match args.as_slice() {
        ["record", input, live] => record(input, live, 90.0),
        ["record", input, live, secs] => match secs.parse::<f64>() {
            Ok(s) if s > 0.0 && s.is_finite() => record(input, live, s),
            _ => Err((2, format!("bad SECONDS '{secs}'"))),
        },
        ["replay", input, output] => replay_file(input).and_then(|text| write(output, text.as_bytes())),
        ["compare", input, live, qemu] => compare(input, live, qemu),
        ["sizes", elf, "--minus", baseline] => {
            sizes(elf).and_then(|a| sizes(baseline).map(|b| (a, b))).map(|(a, b)| {
                println!(
                    "{elf} minus {baseline}: {} B of flash, {} B of static RAM",
                    a.0 as i64 - b.0 as i64,
                    a.1 as i64 - b.1 as i64
                );
            })
        }
        ["sizes", elves @ ..] if !elves.is_empty() => elves.iter().try_for_each(|e| sizes(e).map(|_| ())),
        _ => Err((2, USAGE.to_owned())),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err((code, why)) => {
            eprintln!("bycoms-fw-host: {why}");
            ExitCode::from(code)
        }
    }
}

type Result<T> = std::result::Result<T, (u8, String)>;

/// Largest input, output or ELF file read, bytes (a run's inputs are a few
/// megabytes): through the one capped reader, so `/dev/zero` is refused.
const MAX_READ_BYTES: u64 = 1 << 30;

fn read(path: &str) -> Result<Vec<u8>> {
    bycoms_protocol::capped::read_capped_file_bytes(std::path::Path::new(path), MAX_READ_BYTES)
        .map_err(|e| (2, format!("cannot read {path}: {e}")))
}

fn write(path: &str, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).map_err(|e| (2, format!("cannot write {path}: {e}")))
}

fn record(input: &str, live: &str, seconds: f64) -> Result<()> {
    let t = Instant::now();
    let rec = record::record(Duration::from_secs_f64(seconds), 16);
    write(input, &rec.input)?;
    write(live, rec.live.as_bytes())?;
    println!(
        "recorded {} ({} kB, {} control periods) and {} ({} lines) in {:.1} s: {}",
        input,
        rec.input.len() / 1000,
        rec.live.lines().filter(|l| l.contains(" mics ")).count(),
        live,
        rec.live.lines().count(),
        t.elapsed().as_secs_f64(),
        rec.summary
    );
    Ok(())
}

/// The input through the host build of the core, as text.
fn replay_file(input: &str) -> Result<String> {
    let bytes = read(input)?;
    let mut shell = Shell::new();
    let mut out = String::new();
    let mut mics = [0u8; MIC_BYTES];
    shell
        .play(&mut bytes.as_slice(), &mut mics, &mut NoMeter, &mut out)
        .map_err(|e| (1, format!("replaying {input} failed: {e} (after {} tracks)", shell.tracks)))?;
    Ok(out)
}

/// The first line where `a` and `b` differ, if any.
fn first_difference<'t>(a: &'t str, b: &'t str) -> Option<(usize, &'t str, &'t str)> {
    let (mut la, mut lb) = (a.lines(), b.lines());
    for n in 1.. {
        match (la.next(), lb.next()) {
            (None, None) => return None,
            (x, y) if x == y => {}
            (x, y) => return Some((n, x.unwrap_or("<end>"), y.unwrap_or("<end>"))),
        }
    }
    None
}

fn compare(input: &str, live: &str, qemu: &str) -> Result<()> {
    let host = replay_file(input)?;
    let live_text = String::from_utf8(read(live)?).map_err(|_| (1, format!("{live} is not text")))?;
    let qemu_text = String::from_utf8(read(qemu)?).map_err(|_| (1, format!("{qemu} is not text")))?;
    let mut failed = false;
    for (what, other) in [("the live run", &live_text), ("QEMU (riscv32imc)", &qemu_text)] {
        match first_difference(&host, other) {
            None => println!(
                "host replay = {what}: {} lines, {} bytes, {} control periods, equal byte for byte",
                host.lines().count(),
                host.len(),
                host.lines().filter(|l| l.contains(" mics ")).count()
            ),
            Some((n, h, o)) => {
                failed = true;
                println!("host replay != {what} at line {n}:\n  host: {h}\n  {what}: {o}");
            }
        }
    }
    if failed {
        Err((1, "outputs differ".to_owned()))
    } else {
        Ok(())
    }
}

/// Prints an ELF's sizes; returns its (flash, static RAM) bytes.
fn sizes(elf: &str) -> Result<(u64, u64)> {
    let bytes = read(elf)?;
    let s = sizes::sizes(&bytes).map_err(|e| (2, format!("{elf}: not an ELF file: {e}")))?;
    print!("{}", sizes::report(elf, &s));
    Ok(s.totals())
}
