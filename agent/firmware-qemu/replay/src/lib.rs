//! A recorded input sequence for the firmware core, and the one shell that
//! plays it: the same code feeds `bycoms_agent::firmware::Firmware` on the
//! host (`bycoms-fw-host`) and on an emulated RV32 core under QEMU
//! (`bycoms-fw-qemu`), and writes what the core did as text lines. The two
//! texts must be equal byte for byte (see `deploy/esp32/README.md`).
//!
//! The input file is a sequence of records, little-endian, after an 8-byte
//! magic ([`MAGIC`]):
//!
//! | tag | record | body |
//! |---|---|---|
//! | 1 | boot | robot u32, own tone f64, 2 other tones f64, sample rate f64, gain f64, key 32 B, entropy 32 B |
//! | 2 | datagram | now µs u64, length u16, bytes |
//! | 3 | microphones | now µs u64, 6 × 512 ADC samples u16 |
//! | 4 | timeout | now µs u64 |
//! | 5 | transmit | now µs u64 (poll until nothing is due) |
//! | 6 | battery | mV u16 |
//! | 0 | end | — |
//!
//! A boot record starts a new firmware (a track); a file holds any number of
//! tracks. The samples are the ADC's 12-bit integers, so u16 holds them
//! exactly; the shell hands them to the core as they are (the core's
//! frames are the ADC's integers), as the ESP32's shell does.
//!
//! Output lines (one per call, plus a `status` line whenever the state, the
//! motors, the tone, the session or the next deadline changed) print every
//! float with `{:?}`, the shortest text that reads back to the same bits:
//! two outputs are equal as text exactly when every value is equal as bits.
//!
//! A member of the bycoms workspace, so `cargo test --workspace` runs these
//! tests; the bare-metal harness (`agent/firmware-qemu/harness`, a
//! workspace of its own) uses it by path.
#![no_std]

use bycoms_agent::acoustic::FRAME_LEN;
use bycoms_agent::firmware::{Firmware, FirmwareConfig, FirmwareInput, MicFrames, Motors, MICS};
use bycoms_protocol::link::{LinkKey, RobotState};
use bycoms_protocol::{Micros, RobotId, SansIo};
use core::fmt::{self, Write};

/// First bytes of an input file (format version 1).
pub const MAGIC: [u8; 8] = *b"BYCFWIN1";

/// Other tones each robot listens for (the emulated lab's value).
pub const LISTENED: usize = 2;

/// The firmware the shell runs.
pub type Core = Firmware<LISTENED>;

/// The longest datagram a record may hold (the emulated lab's receive
/// buffer; longer than any link frame, so oversized junk can be replayed).
pub const MAX_DATAGRAM: usize = 512;

/// Bytes of one microphone record's samples.
pub const MIC_BYTES: usize = MICS * FRAME_LEN * 2;

/// Record tags.
pub mod tag {
    /// End of the file.
    pub const END: u8 = 0;
    /// A new firmware boots.
    pub const BOOT: u8 = 1;
    /// A received datagram.
    pub const DATAGRAM: u8 = 2;
    /// One control period's microphone frames.
    pub const MICS: u8 = 3;
    /// `advance`.
    pub const TIMEOUT: u8 = 4;
    /// `advance`, then `poll` until it returns `None`.
    pub const TRANSMIT: u8 = 5;
    /// `set_battery`.
    pub const BATTERY: u8 = 6;
}

/// How a firmware boots: everything `Firmware::new` is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Boot {
    /// Robot id.
    pub robot: u32,
    /// Own tone, Hz.
    pub own_tone: f64,
    /// The other tones, Hz.
    pub other_tones: [f64; LISTENED],
    /// Microphone sample rate, Hz.
    pub sample_rate: f64,
    /// Amplitude → V_n gain.
    pub gain: f64,
    /// The link key.
    pub key: [u8; 32],
    /// Boot entropy.
    pub entropy: [u8; 32],
}

/// Bytes of a boot record's body.
pub const BOOT_BYTES: usize = 4 + 8 * 5 + 32 + 32;

impl Boot {
    /// The firmware configuration: the paper robot with this sampling.
    pub fn config(&self) -> FirmwareConfig<LISTENED> {
        let mut config = FirmwareConfig::paper(RobotId(self.robot), self.own_tone, self.other_tones);
        config.tones.sample_rate = self.sample_rate;
        config.tones.gain = self.gain;
        config
    }

    /// The body of a boot record.
    pub fn encode(&self) -> [u8; BOOT_BYTES] {
        let mut out = [0u8; BOOT_BYTES];
        out[..4].copy_from_slice(&self.robot.to_le_bytes());
        let floats = [self.own_tone, self.other_tones[0], self.other_tones[1], self.sample_rate, self.gain];
        for (i, f) in floats.iter().enumerate() {
            out[4 + 8 * i..12 + 8 * i].copy_from_slice(&f.to_le_bytes());
        }
        out[44..76].copy_from_slice(&self.key);
        out[76..108].copy_from_slice(&self.entropy);
        out
    }

    /// Reads a boot record's body.
    pub fn decode(b: &[u8; BOOT_BYTES]) -> Self {
        let f = |i: usize| f64::from_le_bytes(b[4 + 8 * i..12 + 8 * i].try_into().unwrap_or([0; 8]));
        let mut key = [0u8; 32];
        key.copy_from_slice(&b[44..76]);
        let mut entropy = [0u8; 32];
        entropy.copy_from_slice(&b[76..108]);
        Self {
            robot: u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            own_tone: f(0),
            other_tones: [f(1), f(2)],
            sample_rate: f(3),
            gain: f(4),
            key,
            entropy,
        }
    }
}

/// What went wrong while replaying.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error {
    /// The input does not start with [`MAGIC`].
    BadMagic,
    /// The input ended inside a record, or without an end record.
    Truncated,
    /// An unknown record tag.
    BadTag(u8),
    /// A record other than boot before the first boot.
    NoFirmware,
    /// The boot record's tones were refused by the core.
    BadConfig,
    /// A datagram longer than [`MAX_DATAGRAM`].
    TooLong(u16),
    /// Reading the input or writing the output failed.
    Io,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self, f)
    }
}

impl From<fmt::Error> for Error {
    fn from(_: fmt::Error) -> Self {
        Error::Io
    }
}

/// A byte source: a slice on the host, a semihosting file under QEMU.
pub trait Source {
    /// Fills `buf` completely, or fails.
    fn read_exact(&mut self, buf: &mut [u8]) -> Result<(), Error>;
}

impl Source for &[u8] {
    fn read_exact(&mut self, buf: &mut [u8]) -> Result<(), Error> {
        if self.len() < buf.len() {
            return Err(Error::Truncated);
        }
        let (head, tail) = self.split_at(buf.len());
        buf.copy_from_slice(head);
        *self = tail;
        Ok(())
    }
}

/// Which core call a measurement is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Call {
    /// `handle` of a datagram.
    Datagram,
    /// `handle` of microphone frames: one control period (six frames' tone isolation, the gradient, the drive law).
    Mics,
    /// `advance` (a timeout record).
    Timeout,
    /// One `poll` (a frame with its HMAC-SHA256 tag, or nothing due; the
    /// transmit record's `advance` before the first is not measured: each
    /// `poll` runs the timers again).
    Transmit,
}

/// Measures the core's calls (the QEMU harness reads the RISC-V counters
/// and the stack; the host measures nothing). `start` is called right
/// before a core call, `stop` right after it.
pub trait Meter {
    /// A core call is about to start.
    fn start(&mut self, call: Call);
    /// The call started last has returned.
    fn stop(&mut self, call: Call);
}

/// Measures nothing.
pub struct NoMeter;

impl Meter for NoMeter {
    fn start(&mut self, _: Call) {}
    fn stop(&mut self, _: Call) {}
}

/// What the shell prints as a `status` line when it changes.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Status {
    state: RobotState,
    motors: Motors,
    tone: Option<f64>,
    connected: bool,
    next: Option<Micros>,
    drops: u32,
}

/// The shell: owns the firmware and plays records into it, printing what it
/// does. The live recorder (`bycoms-fw-host record`) drives the same calls
/// directly, so a recording's own output is this shell's output too.
pub struct Shell {
    fw: Option<Core>,
    frames: MicFrames,
    status: Option<Status>,
    /// Tracks booted so far.
    pub tracks: u32,
}

impl Default for Shell {
    fn default() -> Self {
        Self::new()
    }
}

impl Shell {
    /// No firmware yet: the first record must be a boot.
    pub const fn new() -> Self {
        Self { fw: None, frames: [[0; FRAME_LEN]; MICS], status: None, tracks: 0 }
    }

    /// The running firmware.
    pub fn firmware(&self) -> Option<&Core> {
        self.fw.as_ref()
    }

    fn core(&mut self) -> Result<&mut Core, Error> {
        self.fw.as_mut().ok_or(Error::NoFirmware)
    }

    /// Boots a new firmware (a new track).
    pub fn boot(&mut self, boot: &Boot, out: &mut impl Write) -> Result<(), Error> {
        let fw = Firmware::new(boot.config(), LinkKey::new(&boot.key), boot.entropy)
            .map_err(|_| Error::BadConfig)?;
        self.fw = Some(fw);
        self.status = None;
        self.tracks += 1;
        writeln!(
            out,
            "boot robot={} tone={:?} others={:?} rate={:?} gain={:?}",
            boot.robot, boot.own_tone, boot.other_tones, boot.sample_rate, boot.gain
        )?;
        self.print_status(0, out)
    }

    /// One received datagram.
    pub fn datagram(
        &mut self,
        bytes: &[u8],
        now: Micros,
        meter: &mut impl Meter,
        out: &mut impl Write,
    ) -> Result<(), Error> {
        let fw = self.core()?;
        meter.start(Call::Datagram);
        let result = fw.handle(now, FirmwareInput::Datagram(bytes));
        meter.stop(Call::Datagram);
        write!(out, "t={now} rx {}B -> ", bytes.len())?;
        match result {
            Ok(Some(event)) => writeln!(out, "{event:?}")?,
            // A datagram always has an event or a reason.
            Ok(None) => writeln!(out, "no event")?,
            Err(reason) => writeln!(out, "drop {reason:?}")?,
        }
        self.print_status(now, out)
    }

    /// One control period: ADC samples → the core's frames → `handle`.
    pub fn mics(
        &mut self,
        samples: &[u8; MIC_BYTES],
        now: Micros,
        meter: &mut impl Meter,
        out: &mut impl Write,
    ) -> Result<(), Error> {
        for (n, frame) in self.frames.iter_mut().enumerate() {
            for (i, s) in frame.iter_mut().enumerate() {
                let at = 2 * (n * FRAME_LEN + i);
                *s = u16::from_le_bytes([samples[at], samples[at + 1]]);
            }
        }
        let fw = self.fw.as_mut().ok_or(Error::NoFirmware)?;
        meter.start(Call::Mics);
        // Microphone frames are never refused: nothing to say at once.
        let _ = fw.handle(now, FirmwareInput::Mics(&self.frames));
        meter.stop(Call::Mics);
        let m = fw.motors();
        write!(out, "t={now} mics motors={:?},{:?} ", m.left, m.right)?;
        match fw.last_telemetry() {
            Some(t) => writeln!(out, "{t:?}")?,
            None => writeln!(out, "no telemetry")?,
        }
        self.print_status(now, out)
    }

    /// `advance`.
    pub fn timeout(
        &mut self,
        now: Micros,
        meter: &mut impl Meter,
        out: &mut impl Write,
    ) -> Result<(), Error> {
        let fw = self.core()?;
        meter.start(Call::Timeout);
        fw.advance(now);
        meter.stop(Call::Timeout);
        self.print_status(now, out)
    }

    /// `advance`, then `poll` until nothing is due; `sent` gets every frame.
    pub fn transmit(
        &mut self,
        now: Micros,
        meter: &mut impl Meter,
        out: &mut impl Write,
        mut sent: impl FnMut(&[u8]),
    ) -> Result<(), Error> {
        let fw = self.fw.as_mut().ok_or(Error::NoFirmware)?;
        fw.advance(now);
        loop {
            meter.start(Call::Transmit);
            let frame = fw.poll();
            meter.stop(Call::Transmit);
            let Some(frame) = frame else { break };
            write!(out, "t={now} tx ")?;
            for b in frame.iter() {
                write!(out, "{b:02x}")?;
            }
            writeln!(out)?;
            sent(frame);
        }
        self.print_status(now, out)
    }

    /// `set_battery`.
    pub fn battery(&mut self, mv: u16, out: &mut impl Write) -> Result<(), Error> {
        self.core()?.set_battery(mv);
        writeln!(out, "battery {mv}")?;
        Ok(())
    }

    fn print_status(&mut self, now: Micros, out: &mut impl Write) -> Result<(), Error> {
        let Some(fw) = self.fw.as_ref() else { return Ok(()) };
        let status = Status {
            state: fw.state(),
            motors: fw.motors(),
            tone: fw.tone(),
            connected: fw.connected(),
            next: fw.deadline(),
            drops: fw.drops().total(),
        };
        if self.status != Some(status) {
            self.status = Some(status);
            writeln!(
                out,
                "t={now} status {:?} motors={:?},{:?} tone={:?} connected={} next={:?} drops={}",
                status.state,
                status.motors.left,
                status.motors.right,
                status.tone,
                status.connected,
                status.next,
                status.drops
            )?;
        }
        Ok(())
    }

    /// Plays a whole input (after its magic) into fresh firmwares, printing
    /// to `out`, measuring with `meter`. `mics` is the caller's buffer for
    /// one microphone record (6 KiB).
    pub fn play(
        &mut self,
        input: &mut impl Source,
        mics: &mut [u8; MIC_BYTES],
        meter: &mut impl Meter,
        out: &mut impl Write,
    ) -> Result<(), Error> {
        let mut magic = [0u8; 8];
        input.read_exact(&mut magic)?;
        if magic != MAGIC {
            return Err(Error::BadMagic);
        }
        loop {
            let mut t = [0u8; 1];
            input.read_exact(&mut t)?;
            match t[0] {
                tag::END => return Ok(()),
                tag::BOOT => {
                    let mut b = [0u8; BOOT_BYTES];
                    input.read_exact(&mut b)?;
                    self.boot(&Boot::decode(&b), out)?;
                }
                tag::BATTERY => {
                    let mut b = [0u8; 2];
                    input.read_exact(&mut b)?;
                    self.battery(u16::from_le_bytes(b), out)?;
                }
                tag @ (tag::DATAGRAM | tag::MICS | tag::TIMEOUT | tag::TRANSMIT) => {
                    let mut b = [0u8; 8];
                    input.read_exact(&mut b)?;
                    let now: Micros = u64::from_le_bytes(b);
                    match tag {
                        tag::DATAGRAM => {
                            let mut len = [0u8; 2];
                            input.read_exact(&mut len)?;
                            let len = u16::from_le_bytes(len);
                            if usize::from(len) > MAX_DATAGRAM {
                                return Err(Error::TooLong(len));
                            }
                            let mut bytes = [0u8; MAX_DATAGRAM];
                            let bytes = &mut bytes[..usize::from(len)];
                            input.read_exact(bytes)?;
                            self.datagram(bytes, now, meter, out)?;
                        }
                        tag::MICS => {
                            input.read_exact(mics)?;
                            self.mics(mics, now, meter, out)?;
                        }
                        tag::TIMEOUT => self.timeout(now, meter, out)?,
                        _ => self.transmit(now, meter, out, |_| {})?,
                    }
                }
                other => return Err(Error::BadTag(other)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::String;
    use std::vec::Vec;

    fn boot() -> Boot {
        Boot {
            robot: 2,
            own_tone: 320.0,
            other_tones: [224.0, 512.0],
            sample_rate: 4096.0,
            gain: 256.0,
            key: [0x22; 32],
            entropy: [9; 32],
        }
    }

    fn play(input: &[u8]) -> (Result<(), Error>, String) {
        let mut out = String::new();
        let mut mics = [0u8; MIC_BYTES];
        let r = Shell::new().play(&mut &input[..], &mut mics, &mut NoMeter, &mut out);
        (r, out)
    }

    #[test]
    fn a_boot_record_reads_back_as_written() {
        assert_eq!(Boot::decode(&boot().encode()), boot());
    }

    #[test]
    fn a_track_plays_and_prints_its_hello_and_a_control_period() {
        let mut input = MAGIC.to_vec();
        input.push(tag::BOOT);
        input.extend_from_slice(&boot().encode());
        input.push(tag::TRANSMIT);
        input.extend_from_slice(&0u64.to_le_bytes());
        input.push(tag::MICS);
        input.extend_from_slice(&125_000u64.to_le_bytes());
        let samples: Vec<u8> =
            (0..MICS * FRAME_LEN).flat_map(|i| (2048 + (i % 7) as u16).to_le_bytes()).collect();
        input.extend_from_slice(&samples);
        input.push(tag::END);
        let (r, out) = play(&input);
        assert_eq!(r, Ok(()));
        let lines: Vec<&str> = out.lines().collect();
        assert!(lines[0].starts_with("boot robot=2 tone=320.0"), "{out}");
        assert!(lines.iter().any(|l| l.starts_with("t=0 tx 01")), "a hello frame: {out}");
        assert!(
            lines.iter().any(|l| l.starts_with("t=125000 mics motors=0.0,0.0 Telemetry { step: 0")),
            "{out}"
        );
    }

    #[test]
    fn broken_inputs_are_refused_with_a_reason() {
        assert_eq!(play(b"BYCFWIN0").0, Err(Error::BadMagic));
        assert_eq!(play(&MAGIC).0, Err(Error::Truncated), "no end record");
        let mut no_boot = MAGIC.to_vec();
        no_boot.push(tag::TIMEOUT);
        no_boot.extend_from_slice(&0u64.to_le_bytes());
        assert_eq!(play(&no_boot).0, Err(Error::NoFirmware));
        let mut bad = MAGIC.to_vec();
        bad.push(9);
        assert_eq!(play(&bad).0, Err(Error::BadTag(9)));
        let mut long = MAGIC.to_vec();
        long.push(tag::BOOT);
        long.extend_from_slice(&boot().encode());
        long.push(tag::DATAGRAM);
        long.extend_from_slice(&0u64.to_le_bytes());
        long.extend_from_slice(&600u16.to_le_bytes());
        assert_eq!(play(&long).0, Err(Error::TooLong(600)));
    }
}
