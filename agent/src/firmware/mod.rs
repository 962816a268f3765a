//! The robot's firmware core: one sans-IO state machine for the ESP32.
//!
//! Why sans-IO: the same code must run on the ESP32 (esp-hal timers, I2S
//! microphones, a WiFi UDP socket), in the emulated lab (a thread per robot
//! with a UDP socket on localhost) and in unit tests (no sockets, virtual
//! time). So this type owns no clock, socket or RNG. It has the one shape
//! of every bycoms core, [`SansIo`], with time as [`Micros`] since boot
//! (the shell's clock; the core never reads one). The shell feeds it
//!
//! * link datagrams and one frame of samples per microphone (each frame
//!   set is one control period) with [`SansIo::handle`]
//!   ([`FirmwareInput`]); a datagram's event or refusal comes back at once,
//! * the time with every call, and [`SansIo::advance`] when
//!   [`SansIo::deadline`] is due (the failsafe, the relink timer, a hello
//!   or heartbeat to send),
//!
//! and reads back the motor commands ([`Firmware::motors`]), its own tone
//! ([`Firmware::tone`]) and the link frames to send ([`SansIo::poll`],
//! until `None`; each frame is built, when polled, in a buffer the core
//! owns, for the time of the latest `handle` or `advance`: no allocator).
//! Entropy comes in once, at boot, as 32 bytes from the hardware RNG;
//! hello nonces are SHA-256(entropy ‖ counter).
//!
//! Why the frames are built in `poll` and not in `advance`: a frame's
//! bytes (its heartbeat's uptime) and the link's timers depend on when it
//! is sent, and a shell may run the timers at one time and send at a later
//! one (the replay's separate timeout and transmit records); built when
//! polled, it carries the time it leaves at, as it always has.
//!
//! Per control period: tone isolation (the other robots' tones per
//! microphone, [`crate::acoustic::tones`]) → V_ave and the gradient
//! direction ([`crate::acoustic::gradient`]) → the two-mode
//! differential-drive law ([`crate::acoustic::drive`]) with the paper's
//! Kp, α, V_target, V_min. Angles are in the robot frame (heading 0): the
//! gateway sends the goal bearing as seen from the robot, as in the paper.
//!
//! Safety rules, each unit-tested:
//!
//! * the motors run only while enabled, with a goal, and with a valid
//!   (authentic, in-session, fresh) Enable or Goal less than
//!   [`FirmwareConfig::failsafe`] (500 ms) old; otherwise they are off
//!   ([`RobotState::Failsafe`] when the commands went stale; `Idle` while
//!   an enabled robot waits for its first goal) until the next valid
//!   command;
//! * Stop turns the motors off until the next Enable; the speaker keeps
//!   playing (a stuck robot is a beacon);
//! * a new session (gateway restart, relink) starts disabled: the gateway
//!   must enable again;
//! * any refused frame is counted (and reported in telemetry), never acted on.

use crate::acoustic::{
    DriveConfig, DriveController, DriveInput, MicRing, ToneConfig, ToneError, ToneIsolator, ADC_MAX,
};
use crate::acoustic::{Frame, FRAME_LEN};
use crate::point::Mode;
use bycoms_protocol::link::{
    DropCounters, DropReason, Health, LinkKey, Payload, RobotEvent, RobotLink, RobotState, Telemetry,
    MAX_FRAME_LEN, NONCE_LEN,
};
use bycoms_protocol::{Micros, RobotId, SansIo};
use sha2::{Digest, Sha256};

/// Microphones on the robot (the paper's ring).
pub const MICS: usize = 6;

/// One control period's samples: one frame per microphone, raw 12-bit ADC
/// counts (the ADC's own integers: no conversion in the shell).
pub type MicFrames = [Frame; MICS];

/// Everything the firmware is configured with; [`FirmwareConfig::paper`]
/// gives the paper robot's values. Its spans are [`Micros`], the core's
/// one time unit (plain `u64` sums on a chip without 64-bit division).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirmwareConfig<const K: usize> {
    /// This robot's id.
    pub robot: RobotId,
    /// The tone this robot plays, Hz.
    pub own_tone: f64,
    /// The other robots' tones it listens for, Hz.
    pub other_tones: [f64; K],
    /// Sample rate and the amplitude → V_n gain.
    pub tones: ToneConfig,
    /// The microphone ring.
    pub ring: MicRing<MICS>,
    /// The drive law's parameters.
    pub drive: DriveConfig,
    /// ADC full scale: a sample of 0 or ≥ this is clipped.
    pub adc_full_scale: u16,
    /// Below this battery voltage (mV) the low-battery flag is set.
    pub low_battery_mv: u16,
    /// No valid Enable/Goal for this long (µs) → motors off.
    pub failsafe_us: Micros,
    /// Send a heartbeat when nothing was sent for this long (µs).
    pub heartbeat_us: Micros,
    /// Repeat an unanswered hello after this long (µs).
    pub hello_retry_us: Micros,
    /// Start a new session after this long (µs) without a valid gateway frame.
    pub relink_after_us: Micros,
}

impl<const K: usize> FirmwareConfig<K> {
    /// The paper robot: six microphones on 0.1 m, 512-sample frames at
    /// 4096 Hz (125 ms control period), V_n in unwindowed-FFT magnitude
    /// units (gain 256, so the paper's V_target = 22000 is a tone of about
    /// 86 ADC counts), Kp = 100, α = 1e-4, V_target = 22000, V_min = 15000,
    /// v_m = 120 and the commands clamped to ±255 (8-bit PWM duty);
    /// a 12-bit ADC; the failsafe at 500 ms.
    pub fn paper(robot: RobotId, own_tone: f64, other_tones: [f64; K]) -> Self {
        Self {
            robot,
            own_tone,
            other_tones,
            tones: ToneConfig { sample_rate: 4096.0, gain: FRAME_LEN as f64 / 2.0 },
            ring: MicRing::paper(),
            drive: DriveConfig { voltage_limit: Some(255.0), ..DriveConfig::paper(120.0) },
            adc_full_scale: ADC_MAX,
            low_battery_mv: 4700,
            failsafe_us: 500_000,
            heartbeat_us: 100_000,
            hello_retry_us: 250_000,
            relink_after_us: 1_000_000,
        }
    }
}

/// The two track commands (v_m ± u, clamped), 0 when the motors are off.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Motors {
    /// Left track.
    pub left: f64,
    /// Right track.
    pub right: f64,
}

/// What the firmware core takes in ([`SansIo::handle`]), borrowed from the
/// shell's buffers.
#[derive(Clone, Copy, Debug)]
pub enum FirmwareInput<'a> {
    /// One received datagram, from any sender: a refused one changes
    /// nothing but a counter.
    Datagram(&'a [u8]),
    /// One control period: a frame of samples per microphone.
    Mics(&'a MicFrames),
}

/// What [`SansIo::handle`] says at once: an accepted datagram's event
/// (`Ok(Some(_))`), a refused one's reason (`Err`, counted, never acted
/// on; the shells log it), or `Ok(None)` for a microphone frame set.
pub type Handled = Result<Option<RobotEvent>, DropReason>;

/// The robot's firmware core. `K` is the number of other tones it listens for.
#[derive(Clone, Debug)]
pub struct Firmware<const K: usize> {
    config: FirmwareConfig<K>,
    link: RobotLink,
    isolator: ToneIsolator<K>,
    drive: DriveController,
    entropy: [u8; 32],
    nonces: u64,
    enabled: bool,
    deployed: bool,
    stopped: bool,
    goal: Option<f32>,
    last_command: Option<Micros>,
    last_rx: Option<Micros>,
    last_tx: Option<Micros>,
    hello: Option<([u8; NONCE_LEN], Micros)>,
    /// The latest `now` seen (time never runs backwards here).
    now: Micros,
    /// The `now` of the latest `handle` or `advance`: what `poll` sends at.
    at: Micros,
    /// The frame `poll` hands out.
    tx: [u8; MAX_FRAME_LEN],
    motors: Motors,
    step: u32,
    telemetry: Option<Telemetry>,
    battery_mv: u16,
    clipping: bool,
}

impl<const K: usize> Firmware<K> {
    /// Boots the core. `boot_entropy` must come from a hardware RNG: it
    /// makes this boot's hello nonces unlike any earlier boot's.
    pub fn new(config: FirmwareConfig<K>, key: LinkKey, boot_entropy: [u8; 32]) -> Result<Self, ToneError> {
        let isolator = ToneIsolator::new(config.tones, config.own_tone, config.other_tones)?;
        Ok(Self {
            link: RobotLink::new(config.robot, key),
            isolator,
            drive: DriveController::new(config.drive),
            config,
            entropy: boot_entropy,
            nonces: 0,
            enabled: false,
            deployed: false,
            stopped: false,
            goal: None,
            last_command: None,
            last_rx: None,
            last_tx: None,
            hello: None,
            now: 0,
            at: 0,
            tx: [0; MAX_FRAME_LEN],
            motors: Motors::default(),
            step: 0,
            telemetry: None,
            battery_mv: u16::MAX,
            clipping: false,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &FirmwareConfig<K> {
        &self.config
    }

    /// What the robot is doing, as of the latest `now` it was given.
    /// Enabled but still waiting for its first goal (the gateway sends it
    /// right after Enable) is `Idle`, motors off: `Failsafe` is only for
    /// commands gone stale, so an enable reads Idle → Driving.
    pub fn state(&self) -> RobotState {
        match (self.enabled, self.stopped) {
            (true, _) if !self.command_fresh() => RobotState::Failsafe,
            (true, _) if self.goal.is_some() => RobotState::Driving,
            (true, _) => RobotState::Idle,
            (false, true) => RobotState::Stopped,
            (false, false) => RobotState::Idle,
        }
    }

    /// A valid Enable/Goal arrived less than the failsafe time ago.
    fn command_fresh(&self) -> bool {
        self.last_command.is_some_and(|at| self.now.saturating_sub(at) < self.config.failsafe_us)
    }

    /// The motor commands to apply now.
    pub fn motors(&self) -> Motors {
        self.motors
    }

    /// The tone the speaker should play, Hz; `None` = silent (not yet
    /// deployed since boot).
    pub fn tone(&self) -> Option<f64> {
        self.deployed.then_some(self.config.own_tone)
    }

    /// Frames refused so far, by reason.
    pub fn drops(&self) -> &DropCounters {
        self.link.drops()
    }

    /// The last telemetry built (sent or not).
    pub fn last_telemetry(&self) -> Option<&Telemetry> {
        self.telemetry.as_ref()
    }

    /// Whether a link session is up.
    pub fn connected(&self) -> bool {
        self.link.session().is_some()
    }

    /// The battery voltage, mV, from the shell's ADC.
    pub fn set_battery(&mut self, mv: u16) {
        self.battery_mv = mv;
    }

    /// One received datagram. A refused one changes nothing but a counter.
    fn datagram(&mut self, bytes: &[u8], now: Micros) -> Result<RobotEvent, DropReason> {
        self.timers(now);
        let event = self.link.receive(bytes)?;
        self.last_rx = Some(now);
        match event {
            RobotEvent::Connected(_) => {
                self.hello = None;
                self.enabled = false;
                self.goal = None;
                self.last_command = None;
            }
            RobotEvent::Enable => {
                self.enabled = true;
                self.deployed = true;
                self.stopped = false;
                self.last_command = Some(now);
            }
            RobotEvent::Goal(bearing) => {
                self.goal = Some(bearing);
                self.last_command = Some(now);
            }
            RobotEvent::Stop => {
                self.enabled = false;
                self.stopped = true;
            }
            RobotEvent::Heartbeat => {}
        }
        self.apply_failsafe();
        Ok(event)
    }

    /// Applies the failsafe and the relink timer at `now` (calling more
    /// often than [`SansIo::deadline`] asks is harmless).
    fn timers(&mut self, now: Micros) {
        self.now = self.now.max(now);
        self.apply_failsafe();
        let silent = match self.last_rx {
            Some(at) => now.saturating_sub(at) >= self.config.relink_after_us,
            None => false,
        };
        if self.connected() && silent {
            // Forget the session; `poll` starts a new hello.
            self.hello = None;
            self.link.leave();
        }
    }

    /// Motors off unless driving.
    fn apply_failsafe(&mut self) {
        if self.state() != RobotState::Driving {
            self.motors = Motors::default();
        }
    }

    /// One control period: isolates the tones in each microphone's frame,
    /// estimates V_ave and the gradient, runs the drive law if allowed and
    /// queues telemetry.
    fn mics(&mut self, frames: &MicFrames, now: Micros) {
        self.timers(now);
        let full = self.config.adc_full_scale;
        self.clipping = frames.iter().flatten().any(|&s| s == 0 || s >= full);
        let v: [f64; MICS] = core::array::from_fn(|n| self.isolator.amplitude(&frames[n]));
        let estimate = self.config.ring.estimate(&v);
        if let (RobotState::Driving, Some(goal)) = (self.state(), self.goal) {
            let input = DriveInput {
                goal_bearing: f64::from(goal),
                heading: 0.0,
                gradient: estimate.direction,
                v_ave: estimate.mean,
            };
            let out = self.drive.step(&input);
            self.motors = Motors { left: out.left, right: out.right };
        }
        let mut health = 0;
        if self.battery_mv < self.config.low_battery_mv {
            health |= Health::LOW_BATTERY;
        }
        if self.clipping {
            health |= Health::MIC_CLIPPING;
        }
        let finite = |x: f64| if x.is_finite() { x as f32 } else { 0.0 };
        self.telemetry = Some(Telemetry {
            step: self.step,
            state: self.state(),
            mode: match self.drive.mode() {
                Mode::Goal => 1,
                Mode::Bypass => 2,
            },
            mics: v.map(finite),
            v_ave: finite(estimate.mean),
            gradient: estimate.direction.map(finite),
            left: finite(self.motors.left),
            right: finite(self.motors.right),
            battery_mv: self.battery_mv,
            health: Health(health),
            link_drops: self.link.drops().total(),
        });
        self.step = self.step.wrapping_add(1);
    }

    /// The next link frame to send at `now`, if any: a hello while
    /// unconnected (every [`FirmwareConfig::hello_retry`]), queued
    /// telemetry, or a heartbeat when nothing was sent for
    /// [`FirmwareConfig::heartbeat`]. Built in the core's own buffer.
    fn transmit(&mut self, now: Micros) -> Option<&[u8]> {
        self.timers(now);
        if !self.connected() {
            let nonce = match self.hello {
                Some((_, at)) if now < at + self.config.hello_retry_us => return None,
                Some((nonce, _)) => nonce,
                None => self.fresh_nonce(),
            };
            self.hello = Some((nonce, now));
            self.telemetry = None;
            self.last_tx = Some(now);
            return self.link.hello(nonce, &mut self.tx).ok();
        }
        let payload = if let Some(t) = self.telemetry.take() {
            Payload::Telemetry(t)
        } else if self.last_tx.is_none_or(|t| now >= t + self.config.heartbeat_us) {
            Payload::RobotHeartbeat { uptime_ms: (now / 1000) as u32 }
        } else {
            return None;
        };
        self.last_tx = Some(now);
        self.link.send(payload, &mut self.tx).ok()
    }

    fn fresh_nonce(&mut self) -> [u8; NONCE_LEN] {
        let digest =
            Sha256::new().chain_update(self.entropy).chain_update(self.nonces.to_le_bytes()).finalize();
        self.nonces += 1;
        let mut nonce = [0u8; NONCE_LEN];
        nonce.copy_from_slice(&digest[..NONCE_LEN]);
        nonce
    }
}

/// The firmware's shape: see the module docs.
impl<const K: usize> SansIo for Firmware<K> {
    type Input<'a> = FirmwareInput<'a>;
    type Handled = Handled;
    type Output<'a>
        = &'a [u8]
    where
        Self: 'a;

    /// A datagram or a control period's microphone frames at `now`; the
    /// frames it makes due (telemetry) go out by [`SansIo::poll`].
    fn handle(&mut self, now: Micros, input: FirmwareInput<'_>) -> Handled {
        self.at = now;
        match input {
            FirmwareInput::Datagram(bytes) => self.datagram(bytes, now).map(Some),
            FirmwareInput::Mics(frames) => {
                self.mics(frames, now);
                Ok(None)
            }
        }
    }

    /// The failsafe and the relink timer at `now`, which becomes the time
    /// the frames polled next are sent at.
    fn advance(&mut self, now: Micros) {
        self.at = now;
        self.timers(now);
    }

    /// The next frame due at the time of the latest `handle` or `advance`
    /// (a hello, telemetry, a heartbeat), in the core's own buffer; call
    /// until `None`.
    fn poll(&mut self) -> Option<&[u8]> {
        self.transmit(self.at)
    }

    /// The earliest time at which [`SansIo::advance`] (the failsafe, the
    /// relink timer) or [`SansIo::poll`] (a hello or heartbeat) has
    /// something to do.
    fn deadline(&self) -> Option<Micros> {
        let failsafe = match self.last_command {
            Some(at) if self.state() == RobotState::Driving => Some(at + self.config.failsafe_us),
            _ => None,
        };
        let link = if self.connected() {
            let heartbeat = self.last_tx.map(|t| t + self.config.heartbeat_us);
            let relink = self.last_rx.map(|t| t + self.config.relink_after_us);
            min(heartbeat, relink)
        } else {
            Some(self.hello.map_or(0, |(_, at)| at + self.config.hello_retry_us))
        };
        min(failsafe, link)
    }
}

fn min(a: Option<Micros>, b: Option<Micros>) -> Option<Micros> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

#[cfg(test)]
mod tests;
