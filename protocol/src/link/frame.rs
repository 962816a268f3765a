//! Link frames and their stateless encode/decode (layout: `protocol/LINK.md`).
//!
//! A frame is `[header 18][payload, fixed size per kind][tag 16]`; the tag
//! is HMAC-SHA256 over header and payload with the robot's key, truncated.
//! [`decode`] checks, in order: length, version, kind, exact length, robot
//! id, direction, tag, then field ranges — so the cheap checks come first
//! and nothing unauthenticated is ever parsed beyond its header.

use super::DropReason;
use crate::RobotId;
use hmac::digest::{generic_array::GenericArray, KeyInit};
use hmac::{Hmac, Mac};
use sha2::Sha256;

/// The link's version byte. Bump it when any layout below changes (the
/// golden-byte tests will tell).
pub const LINK_VERSION: u8 = 1;
/// Pre-shared key length, bytes.
pub const KEY_LEN: usize = 32;
/// Hello nonce length, bytes.
pub const NONCE_LEN: usize = 16;
/// Authentication tag length, bytes (HMAC-SHA256 truncated).
pub const TAG_LEN: usize = 16;
/// Header: version 1, kind 1, robot 4, session 8, seq 4.
pub const HEADER_LEN: usize = 18;
/// Telemetry payload length, bytes.
pub const TELEMETRY_LEN: usize = 54;
/// Longest frame (a telemetry frame), bytes.
pub const MAX_FRAME_LEN: usize = HEADER_LEN + TELEMETRY_LEN + TAG_LEN;

/// A robot's pre-shared key, kept as the keyed HMAC state (computed once,
/// cloned per frame). Its `Debug` never shows the key.
#[derive(Clone)]
pub struct LinkKey {
    mac: Hmac<Sha256>,
}

impl LinkKey {
    /// The keyed state for `key`. HMAC zero-pads keys shorter than the
    /// SHA-256 block (64 bytes), so padding here is the same HMAC as keying
    /// with the 32 bytes directly — and infallible.
    pub fn new(key: &[u8; KEY_LEN]) -> Self {
        let mut block = [0u8; 64];
        block[..KEY_LEN].copy_from_slice(key);
        Self { mac: <Hmac<Sha256> as KeyInit>::new(GenericArray::from_slice(&block)) }
    }

    /// Parses 64 hexadecimal digits (surrounding whitespace allowed), the
    /// key file format.
    pub fn from_hex(text: &str) -> Option<Self> {
        let text = text.trim();
        if text.len() != 2 * KEY_LEN || !text.is_ascii() {
            return None;
        }
        let mut key = [0u8; KEY_LEN];
        for (k, pair) in key.iter_mut().zip(text.as_bytes().chunks_exact(2)) {
            let digit = |c: u8| (c as char).to_digit(16);
            *k = (digit(pair[0])? * 16 + digit(pair[1])?) as u8;
        }
        Some(Self::new(&key))
    }

    fn tag(&self, bytes: &[u8]) -> [u8; TAG_LEN] {
        let mut mac = self.mac.clone();
        mac.update(bytes);
        let full = mac.finalize().into_bytes();
        let mut tag = [0u8; TAG_LEN];
        tag.copy_from_slice(&full[..TAG_LEN]);
        tag
    }

    fn verify(&self, bytes: &[u8], tag: &[u8]) -> bool {
        let mut mac = self.mac.clone();
        mac.update(bytes);
        mac.verify_truncated_left(tag).is_ok()
    }
}

impl core::fmt::Debug for LinkKey {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("LinkKey(..)")
    }
}

/// A session id, chosen at random by the gateway in its welcome. 0 means
/// "no session" (hello frames).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SessionId(pub u64);

/// Which way a frame travels; every kind belongs to exactly one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Robot → gateway (hello, telemetry, robot heartbeat).
    ToGateway,
    /// Gateway → robot (welcome, enable, goal, stop, gateway heartbeat).
    ToRobot,
}

/// The authenticated header every frame starts with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// The robot this frame is from or for.
    pub robot: RobotId,
    /// The session ([`SessionId`] 0 in a hello).
    pub session: SessionId,
    /// Sender's sequence number within the session, strictly increasing.
    pub seq: u32,
}

/// What the firmware is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum RobotState {
    /// Motors off: not enabled (speaker off until the first Enable), or
    /// enabled and waiting for its first goal bearing.
    Idle = 0,
    /// Enabled and commanded: the controller drives the motors.
    Driving = 1,
    /// Enabled, but no valid command for the failsafe time: motors off.
    Failsafe = 2,
    /// Stopped by command: motors off, speaker on (a beacon).
    Stopped = 3,
}

impl RobotState {
    fn from_byte(b: u8) -> Option<Self> {
        Some(match b {
            0 => Self::Idle,
            1 => Self::Driving,
            2 => Self::Failsafe,
            3 => Self::Stopped,
            _ => return None,
        })
    }
}

/// Health flags of the robot (bit set = problem).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Health(pub u8);

impl Health {
    /// Battery below its warning level.
    pub const LOW_BATTERY: u8 = 0x01;
    /// A microphone frame reached the ADC's limits.
    pub const MIC_CLIPPING: u8 = 0x02;
    /// All defined bits; others must be zero.
    pub const DEFINED: u8 = Self::LOW_BATTERY | Self::MIC_CLIPPING;
}

/// One control period's measurements and decision, robot → gateway.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Telemetry {
    /// Control period counter since boot.
    pub step: u32,
    /// What the firmware is doing.
    pub state: RobotState,
    /// Controller mode, 1 (goal) or 2 (bypass) as in the paper.
    pub mode: u8,
    /// V_1..V_6: the other robots' summed tone amplitude per microphone.
    pub mics: [f32; 6],
    /// V_ave, the mean of `mics`.
    pub v_ave: f32,
    /// Gradient direction in the robot frame, rad; `None` if undefined.
    pub gradient: Option<f32>,
    /// Left motor command.
    pub left: f32,
    /// Right motor command.
    pub right: f32,
    /// Battery voltage, mV.
    pub battery_mv: u16,
    /// Health flags.
    pub health: Health,
    /// Frames the robot has dropped since boot (all reasons).
    pub link_drops: u32,
}

/// A frame's body; the kind byte follows from the variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Payload {
    /// Robot → gateway: start a session; `nonce` is fresh per attempt.
    Hello {
        /// Random bytes the welcome must echo.
        nonce: [u8; NONCE_LEN],
    },
    /// Robot → gateway: one control period's telemetry.
    Telemetry(Telemetry),
    /// Robot → gateway: liveness when there is nothing else to send.
    RobotHeartbeat {
        /// Robot uptime, ms (wrapping).
        uptime_ms: u32,
    },
    /// Gateway → robot: session accepted; the header carries the new
    /// session id, `nonce` echoes the hello's.
    Welcome {
        /// The hello nonce being answered.
        nonce: [u8; NONCE_LEN],
    },
    /// Gateway → robot: the robot may drive (deployment).
    Enable,
    /// Gateway → robot: the goal bearing in the robot frame, rad,
    /// counter-clockwise from the robot's heading.
    Goal {
        /// Bearing, rad; finite.
        bearing: f32,
    },
    /// Gateway → robot: motors off for good; keep playing the tone.
    Stop,
    /// Gateway → robot: liveness when there is nothing else to send.
    GatewayHeartbeat {
        /// Gateway uptime, ms (wrapping).
        uptime_ms: u32,
    },
}

impl Payload {
    /// The kind byte.
    pub fn kind(&self) -> u8 {
        match self {
            Self::Hello { .. } => 0x01,
            Self::Telemetry(_) => 0x02,
            Self::RobotHeartbeat { .. } => 0x03,
            Self::Welcome { .. } => 0x81,
            Self::Enable => 0x82,
            Self::Goal { .. } => 0x83,
            Self::Stop => 0x84,
            Self::GatewayHeartbeat { .. } => 0x85,
        }
    }

    /// The direction this kind travels in.
    pub fn direction(&self) -> Direction {
        direction_of(self.kind())
    }
}

fn direction_of(kind: u8) -> Direction {
    if kind & 0x80 == 0 {
        Direction::ToGateway
    } else {
        Direction::ToRobot
    }
}

/// Payload length of a kind byte, `None` for unknown kinds.
fn payload_len(kind: u8) -> Option<usize> {
    Some(match kind {
        0x01 | 0x81 => NONCE_LEN,
        0x02 => TELEMETRY_LEN,
        0x03 | 0x83 | 0x85 => 4,
        0x82 | 0x84 => 0,
        _ => return None,
    })
}

/// One decoded (or to-be-encoded) frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// The header.
    pub header: Header,
    /// The body.
    pub payload: Payload,
}

/// Why a frame could not be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodeError {
    /// The output buffer is shorter than the frame.
    BufferTooSmall {
        /// Bytes needed.
        needed: usize,
    },
    /// A field is out of range (non-finite float, mode not 1 or 2, reserved
    /// health bits): the peer would drop the frame as malformed.
    InvalidField,
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::BufferTooSmall { needed } => write!(f, "link frame needs a {needed}-byte buffer"),
            Self::InvalidField => write!(f, "link frame has an out-of-range field"),
        }
    }
}

impl core::error::Error for EncodeError {}

/// Encodes and tags `frame` into `buf`; returns the frame's bytes.
pub fn encode<'b>(frame: &Frame, key: &LinkKey, buf: &'b mut [u8]) -> Result<&'b [u8], EncodeError> {
    if !valid(&frame.payload) {
        return Err(EncodeError::InvalidField);
    }
    let kind = frame.payload.kind();
    let body_len = HEADER_LEN + payload_len(kind).unwrap_or(0);
    let needed = body_len + TAG_LEN;
    let out = buf.get_mut(..needed).ok_or(EncodeError::BufferTooSmall { needed })?;
    let h = &frame.header;
    out[0] = LINK_VERSION;
    out[1] = kind;
    out[2..6].copy_from_slice(&h.robot.0.to_le_bytes());
    out[6..14].copy_from_slice(&h.session.0.to_le_bytes());
    out[14..18].copy_from_slice(&h.seq.to_le_bytes());
    write_payload(&frame.payload, &mut out[HEADER_LEN..body_len]);
    let tag = key.tag(&out[..body_len]);
    out[body_len..].copy_from_slice(&tag);
    Ok(out)
}

/// Decodes one datagram received by the `to` side for `robot`: every
/// stateless check (see the module doc). Session and sequence checks are
/// the session state machines' ([`super::session`]). This is also the
/// fuzzing entry point: it never panics on any input.
pub fn decode(bytes: &[u8], key: &LinkKey, robot: RobotId, to: Direction) -> Result<Frame, DropReason> {
    if bytes.len() < HEADER_LEN + TAG_LEN {
        return Err(DropReason::Truncated);
    }
    if bytes[0] != LINK_VERSION {
        return Err(DropReason::WrongVersion);
    }
    let kind = bytes[1];
    let len = payload_len(kind).ok_or(DropReason::UnknownKind)?;
    if bytes.len() != HEADER_LEN + len + TAG_LEN {
        return Err(DropReason::BadLength);
    }
    let header = Header {
        robot: RobotId(u32::from_le_bytes(array(&bytes[2..6]))),
        session: SessionId(u64::from_le_bytes(array(&bytes[6..14]))),
        seq: u32::from_le_bytes(array(&bytes[14..18])),
    };
    if header.robot != robot {
        return Err(DropReason::ForeignRobot);
    }
    if direction_of(kind) != to {
        return Err(DropReason::WrongDirection);
    }
    let (body, tag) = bytes.split_at(HEADER_LEN + len);
    if !key.verify(body, tag) {
        return Err(DropReason::BadTag);
    }
    let payload = read_payload(kind, &body[HEADER_LEN..]).ok_or(DropReason::Malformed)?;
    if !valid(&payload) {
        return Err(DropReason::Malformed);
    }
    Ok(Frame { header, payload })
}

/// Copies a slice of known length into an array (lengths are checked by
/// the callers, so the fallback is never taken).
fn array<const N: usize>(bytes: &[u8]) -> [u8; N] {
    let mut a = [0u8; N];
    if bytes.len() == N {
        a.copy_from_slice(bytes);
    }
    a
}

fn f32_at(bytes: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(array(&bytes[at..at + 4]))
}

/// Field ranges shared by encode (refuse) and decode (drop as malformed).
fn valid(payload: &Payload) -> bool {
    match payload {
        Payload::Goal { bearing } => bearing.is_finite(),
        Payload::Telemetry(t) => {
            let mut floats = t.mics.iter().chain([&t.v_ave, &t.left, &t.right]).chain(t.gradient.as_ref());
            matches!(t.mode, 1 | 2) && t.health.0 & !Health::DEFINED == 0 && floats.all(|v| v.is_finite())
        }
        _ => true,
    }
}

fn write_payload(payload: &Payload, out: &mut [u8]) {
    match payload {
        Payload::Hello { nonce } | Payload::Welcome { nonce } => out.copy_from_slice(nonce),
        Payload::RobotHeartbeat { uptime_ms } | Payload::GatewayHeartbeat { uptime_ms } => {
            out.copy_from_slice(&uptime_ms.to_le_bytes());
        }
        Payload::Goal { bearing } => out.copy_from_slice(&bearing.to_le_bytes()),
        Payload::Enable | Payload::Stop => {}
        Payload::Telemetry(t) => {
            out[0..4].copy_from_slice(&t.step.to_le_bytes());
            out[4] = t.state as u8;
            out[5] = t.mode;
            out[6] = u8::from(t.gradient.is_some());
            out[7] = t.health.0;
            for (i, m) in t.mics.iter().enumerate() {
                out[8 + 4 * i..12 + 4 * i].copy_from_slice(&m.to_le_bytes());
            }
            out[32..36].copy_from_slice(&t.v_ave.to_le_bytes());
            out[36..40].copy_from_slice(&t.gradient.unwrap_or(0.0).to_le_bytes());
            out[40..44].copy_from_slice(&t.left.to_le_bytes());
            out[44..48].copy_from_slice(&t.right.to_le_bytes());
            out[48..50].copy_from_slice(&t.battery_mv.to_le_bytes());
            out[50..54].copy_from_slice(&t.link_drops.to_le_bytes());
        }
    }
}

/// Parses a payload of the right length for `kind`; `None` for a value no
/// encoder produces (unknown state, flag bits, a set gradient slot without
/// its flag).
fn read_payload(kind: u8, p: &[u8]) -> Option<Payload> {
    Some(match kind {
        0x01 => Payload::Hello { nonce: array(p) },
        0x81 => Payload::Welcome { nonce: array(p) },
        0x03 => Payload::RobotHeartbeat { uptime_ms: u32::from_le_bytes(array(p)) },
        0x85 => Payload::GatewayHeartbeat { uptime_ms: u32::from_le_bytes(array(p)) },
        0x83 => Payload::Goal { bearing: f32_at(p, 0) },
        0x82 => Payload::Enable,
        0x84 => Payload::Stop,
        0x02 => {
            let gradient = match p[6] {
                0 if p[36..40] == [0; 4] => None,
                1 => Some(f32_at(p, 36)),
                _ => return None,
            };
            Payload::Telemetry(Telemetry {
                step: u32::from_le_bytes(array(&p[0..4])),
                state: RobotState::from_byte(p[4])?,
                mode: p[5],
                health: Health(p[7]),
                mics: core::array::from_fn(|i| f32_at(p, 8 + 4 * i)),
                v_ave: f32_at(p, 32),
                gradient,
                left: f32_at(p, 40),
                right: f32_at(p, 44),
                battery_mv: u16::from_le_bytes(array(&p[48..50])),
                link_drops: u32::from_le_bytes(array(&p[50..54])),
            })
        }
        _ => return None,
    })
}
