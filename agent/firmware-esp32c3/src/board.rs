//! The board: every pin, ADC channel, PWM channel and peripheral the robot
//! uses, in this one file. Everything chip-specific about the robot's
//! hardware is here; `main.rs` never names a pin. A board with other
//! wiring (or another chip of the family, see deploy/esp32/README.md)
//! changes this file only.
//!
//! | GPIO | signal | peripheral |
//! |---|---|---|
//! | 0 | microphone M1 (robot's x axis) | ADC1 channel 0 |
//! | 1 | microphone M2 (60° counter-clockwise) | ADC1 channel 1 |
//! | 2 | microphone M3 (120°) — strapping pin, see below | ADC1 channel 2 |
//! | 3 | microphone M4 (180°) | ADC1 channel 3 |
//! | 4 | microphone M5 (240°) | ADC1 channel 4 |
//! | 5 | microphone M6 (300°) | ADC2 channel 0, see below |
//! | 6 | TB6612 AIN1, left track | LEDC channel 0 (timer 0, 20 kHz, 8 bit) |
//! | 7 | TB6612 AIN2, left track | LEDC channel 1 |
//! | 8 | TB6612 BIN1, right track — strapping pin | LEDC channel 2 |
//! | 10 | TB6612 BIN2, right track | LEDC channel 3 |
//! | 20 | TB6612 STBY (driver enable; 10 kΩ pull-down on the board) | GPIO output |
//! | 21 | speaker amplifier input (BOB-11044) | LEDC channel 4 (timer 1, the own tone, 50 % duty) |
//! | 9 | BOOT button (download mode at reset) | unused |
//! | 18, 19 | USB-Serial-JTAG: console, `espflash` | — |
//! | 12–17 | SPI flash | — |
//!
//! * **Motors**: the TB6612FNG's PWMA and PWMB are tied high and the PWM
//!   goes to the IN pins (forward: IN1 = duty, IN2 = 0; reverse: the other
//!   way round), so two motors need four LEDC channels and no direction
//!   GPIOs — the C3 has too few pins for PWM + 4 direction + STBY. The core's
//!   commands are in ±255, the LEDC duty is 8 bit: |command| is the duty.
//!   STBY is driven high once the firmware runs; after any reset (the RTC
//!   watchdog's included) the pin floats and the board's pull-down puts the
//!   driver in standby.
//! * **Speaker**: the C3 has no DAC; the tone is a 50 % square wave at the
//!   tone's frequency. Its odd harmonics (3f, 5f …: 672, 960, 1120 Hz … for
//!   the paper's tones) fall on none of the paper's tone bins.
//! * **Microphones**: 4096 samples/s per microphone, 12 bit, 11 dB
//!   attenuation (about 0–2.5 V), read one after the other by the sampler
//!   (a timer-driven task at the highest executor priority; esp-hal 1.2 has
//!   no DMA/continuous ADC mode), so the six samples of one instant are up
//!   to a few tens of µs apart — a phase error far below the core's needs
//!   (it uses amplitudes only).
//! * **Limits of the C3 as this robot's chip** (to check on a board):
//!   the C3 has five ADC1 inputs; the sixth microphone is on ADC2, which
//!   the radio shares and which Espressif's ESP-IDF does not support for
//!   one-shot reads on the C3 by default (a documented hardware
//!   limitation): a failed read repeats the microphone's previous sample
//!   and is counted. A board for real use puts the microphones on an
//!   external SPI ADC or uses a chip with eight ADC1 inputs (the paper's
//!   ESP32). No ADC input is left for the battery divider: the firmware
//!   never calls `set_battery`, so telemetry reports 65535 mV (unknown).
//!   GPIO2 and GPIO8 are strapping pins: the microphone bias and the
//!   driver's inputs must not pull them low at reset.

use bycoms_agent::firmware::{MicFrames, MICS};
use esp_hal::analog::adc::{Adc, AdcConfig, AdcPin, Attenuation};
use esp_hal::gpio::interconnect::PeripheralOutput;
use esp_hal::gpio::{DriveMode, Level, Output, OutputConfig};
use esp_hal::ledc::channel::{self, Channel, ChannelHW, ChannelIFace};
use esp_hal::ledc::timer::{self, TimerIFace};
use esp_hal::ledc::{LSGlobalClkSource, Ledc, LowSpeed};
use esp_hal::peripherals::{
    Peripherals, ADC1, ADC2, FLASH, FROM_CPU_INTR0, FROM_CPU_INTR2, GPIO0, GPIO1, GPIO10, GPIO2, GPIO20,
    GPIO21, GPIO3, GPIO4, GPIO5, GPIO6, GPIO7, GPIO8, LEDC, RTC_TIMER, TIMG0, WIFI,
};
use esp_hal::time::Rate;
use esp_hal::Blocking;
use static_cell::StaticCell;

/// Samples per second per microphone.
pub const SAMPLE_RATE: u32 = 4096;

/// One control period's raw samples, microphone by microphone: the core's
/// frames, 12-bit ADC counts.
pub type Samples = MicFrames;

/// Motor PWM frequency (above hearing: no whine in the microphones).
const MOTOR_PWM: Rate = Rate::from_khz(20);

/// The six microphones on the ADCs.
pub struct Mics {
    adc1: Adc<'static, ADC1<'static>, Blocking>,
    adc2: Adc<'static, ADC2<'static>, Blocking>,
    m1: AdcPin<GPIO0<'static>, ADC1<'static>>,
    m2: AdcPin<GPIO1<'static>, ADC1<'static>>,
    m3: AdcPin<GPIO2<'static>, ADC1<'static>>,
    m4: AdcPin<GPIO3<'static>, ADC1<'static>>,
    m5: AdcPin<GPIO4<'static>, ADC1<'static>>,
    m6: AdcPin<GPIO5<'static>, ADC2<'static>>,
    last: [u16; MICS],
    /// Reads that failed (the previous sample was repeated).
    pub failed: u32,
}

impl Mics {
    /// One sample of every microphone, in ring order M1..M6.
    pub fn read(&mut self) -> [u16; MICS] {
        let r = [
            nb::block!(self.adc1.read_oneshot(&mut self.m1)).ok(),
            nb::block!(self.adc1.read_oneshot(&mut self.m2)).ok(),
            nb::block!(self.adc1.read_oneshot(&mut self.m3)).ok(),
            nb::block!(self.adc1.read_oneshot(&mut self.m4)).ok(),
            nb::block!(self.adc1.read_oneshot(&mut self.m5)).ok(),
            nb::block!(self.adc2.read_oneshot(&mut self.m6)).ok(),
        ];
        for (last, r) in self.last.iter_mut().zip(r) {
            match r {
                Some(v) => *last = v,
                None => self.failed = self.failed.wrapping_add(1),
            }
        }
        self.last
    }
}

/// The two tracks on the TB6612FNG.
pub struct Motors {
    left: [Channel<'static, LowSpeed>; 2],
    right: [Channel<'static, LowSpeed>; 2],
    standby: Output<'static>,
}

impl Motors {
    /// Applies the core's commands (±255; 0 = off).
    pub fn apply(&mut self, left: f64, right: f64) {
        drive(&self.left, left);
        drive(&self.right, right);
    }

    /// Enables the driver (STBY high): only once the firmware runs.
    pub fn enable(&mut self) {
        self.standby.set_high();
    }
}

fn drive(pair: &[Channel<'static, LowSpeed>; 2], command: f64) {
    let magnitude = if command < 0.0 { -command } else { command };
    // NaN and tiny commands are off; the duty is 8 bit.
    let duty = if magnitude >= 1.0 { magnitude.min(255.0) as u32 } else { 0 };
    let (on, off) = if command >= 0.0 { (&pair[0], &pair[1]) } else { (&pair[1], &pair[0]) };
    off.set_duty_hw(0);
    on.set_duty_hw(duty);
}

/// The speaker: a square wave at the robot's own tone.
pub struct Speaker {
    channel: Channel<'static, LowSpeed>,
    playing: bool,
}

impl Speaker {
    /// Plays (50 % duty) or silences the tone the speaker was set up with.
    pub fn play(&mut self, on: bool) {
        if on != self.playing {
            self.playing = on;
            let _ = self.channel.set_duty(if on { 50 } else { 0 });
        }
    }
}

/// The robot's hardware.
pub struct Board {
    /// Microphones (moved into the sampler task).
    pub mics: Mics,
    /// Motor driver.
    pub motors: Motors,
    /// Speaker.
    pub speaker: Speaker,
}

/// The peripherals `main` uses itself (not the robot's hardware).
pub struct System {
    /// Timer group 0: esp-rtos's scheduler timer.
    pub timg0: TIMG0<'static>,
    /// Software interrupt for the scheduler.
    pub int0: FROM_CPU_INTR0<'static>,
    /// Software interrupt for the high-priority (sampling) executor.
    pub int2: FROM_CPU_INTR2<'static>,
    /// The radio.
    pub wifi: WIFI<'static>,
    /// SPI flash (the flashed configuration).
    pub flash: FLASH<'static>,
    /// RTC timer: the RTC watchdog.
    pub rtc: RTC_TIMER<'static>,
}

/// Why the board could not be set up.
#[derive(Debug)]
pub enum BoardError {
    /// An LEDC timer refused its frequency.
    Timer(timer::Error),
    /// An LEDC channel refused its configuration.
    Channel(channel::Error),
}

/// The robot's peripherals, not yet set up (the speaker needs the tone
/// from the flashed configuration first).
pub struct Parts {
    adc1: ADC1<'static>,
    adc2: ADC2<'static>,
    ledc: LEDC<'static>,
    mics: (GPIO0<'static>, GPIO1<'static>, GPIO2<'static>, GPIO3<'static>, GPIO4<'static>, GPIO5<'static>),
    motors: (GPIO6<'static>, GPIO7<'static>, GPIO8<'static>, GPIO10<'static>, GPIO20<'static>),
    speaker: GPIO21<'static>,
}

impl core::fmt::Display for BoardError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Timer(e) => write!(f, "LEDC timer: {e:?}"),
            Self::Channel(e) => write!(f, "LEDC channel: {e:?}"),
        }
    }
}

/// Splits the chip's peripherals into the robot's hardware and the rest.
pub fn split(p: Peripherals) -> (Parts, System) {
    let parts = Parts {
        adc1: p.ADC1,
        adc2: p.ADC2,
        ledc: p.LEDC,
        mics: (p.GPIO0, p.GPIO1, p.GPIO2, p.GPIO3, p.GPIO4, p.GPIO5),
        motors: (p.GPIO6, p.GPIO7, p.GPIO8, p.GPIO10, p.GPIO20),
        speaker: p.GPIO21,
    };
    let system = System {
        timg0: p.TIMG0,
        int0: p.FROM_CPU_INTR0,
        int2: p.FROM_CPU_INTR2,
        wifi: p.WIFI,
        flash: p.FLASH,
        rtc: p.RTC_TIMER,
    };
    (parts, system)
}

fn pwm(
    ledc: &'static Ledc<'static>,
    number: channel::Number,
    pin: impl PeripheralOutput<'static>,
    timer: &'static timer::Timer<'static, LowSpeed>,
) -> Result<Channel<'static, LowSpeed>, BoardError> {
    let mut c: Channel<'static, LowSpeed> = ledc.channel(number, pin);
    c.configure(channel::config::Config { timer, duty_pct: 0, drive_mode: DriveMode::PushPull })
        .map_err(BoardError::Channel)?;
    Ok(c)
}

impl Board {
    /// Sets the robot's hardware up; `tone` is the robot's own tone (Hz),
    /// the speaker's frequency. Motors off, driver in standby, speaker silent.
    pub fn new(parts: Parts, tone: u32) -> Result<Self, BoardError> {
        // ADC: 12 bit (the core's adc_full_scale 4095), 11 dB attenuation.
        let (g0, g1, g2, g3, g4, g5) = parts.mics;
        let mut c1 = AdcConfig::new();
        let m1 = c1.enable_pin(g0, Attenuation::_11dB);
        let m2 = c1.enable_pin(g1, Attenuation::_11dB);
        let m3 = c1.enable_pin(g2, Attenuation::_11dB);
        let m4 = c1.enable_pin(g3, Attenuation::_11dB);
        let m5 = c1.enable_pin(g4, Attenuation::_11dB);
        let mut c2 = AdcConfig::new();
        let m6 = c2.enable_pin(g5, Attenuation::_11dB);
        let mics = Mics {
            adc1: Adc::new(parts.adc1, c1),
            adc2: Adc::new(parts.adc2, c2),
            m1,
            m2,
            m3,
            m4,
            m5,
            m6,
            last: [2048; MICS],
            failed: 0,
        };

        // LEDC: the channels borrow their timers, so both live in statics.
        static LEDC_CELL: StaticCell<Ledc<'static>> = StaticCell::new();
        static MOTOR_TIMER: StaticCell<timer::Timer<'static, LowSpeed>> = StaticCell::new();
        static TONE_TIMER: StaticCell<timer::Timer<'static, LowSpeed>> = StaticCell::new();
        let ledc = LEDC_CELL.init(Ledc::new(parts.ledc));
        ledc.set_global_slow_clock(LSGlobalClkSource::APBClk);
        let ledc: &'static Ledc<'static> = ledc;
        let mut motor_timer = ledc.timer::<LowSpeed>(timer::Number::Timer0);
        motor_timer
            .configure(timer::config::Config {
                duty: timer::config::Duty::Duty8Bit,
                clock_source: timer::LSClockSource::APBClk,
                frequency: MOTOR_PWM,
            })
            .map_err(BoardError::Timer)?;
        let motor_timer: &'static timer::Timer<'static, LowSpeed> = MOTOR_TIMER.init(motor_timer);
        let mut tone_timer = ledc.timer::<LowSpeed>(timer::Number::Timer1);
        tone_timer
            .configure(timer::config::Config {
                duty: timer::config::Duty::Duty10Bit,
                clock_source: timer::LSClockSource::APBClk,
                frequency: Rate::from_hz(tone),
            })
            .map_err(BoardError::Timer)?;
        let tone_timer: &'static timer::Timer<'static, LowSpeed> = TONE_TIMER.init(tone_timer);
        let (ain1, ain2, bin1, bin2, stby) = parts.motors;
        let motors = Motors {
            left: [
                pwm(ledc, channel::Number::Channel0, ain1, motor_timer)?,
                pwm(ledc, channel::Number::Channel1, ain2, motor_timer)?,
            ],
            right: [
                pwm(ledc, channel::Number::Channel2, bin1, motor_timer)?,
                pwm(ledc, channel::Number::Channel3, bin2, motor_timer)?,
            ],
            standby: Output::new(stby, Level::Low, OutputConfig::default()),
        };
        let speaker = Speaker {
            channel: pwm(ledc, channel::Number::Channel4, parts.speaker, tone_timer)?,
            playing: false,
        };
        Ok(Board { mics, motors, speaker })
    }
}
