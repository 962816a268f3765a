//! The link's two session state machines, one per side, sans-IO.
//!
//! Why sessions: a tag alone proves who made a frame, not when. A sequence
//! number stops replays within a run, but a robot that reboots starts
//! counting again, and a capture of yesterday's run would then be "new".
//! So each connection gets a fresh session:
//!
//! 1. the robot sends `Hello { nonce }` with a fresh random nonce
//!    (session 0); it repeats the same hello until answered;
//! 2. the gateway answers `Welcome { nonce }` echoing it, in a header that
//!    carries a new random [`SessionId`] (seq 0). The session is only
//!    *pending*: a replayed hello makes the gateway answer, but the
//!    attacker cannot use the answer, and the current session stays;
//! 3. the robot accepts only a welcome echoing its *current* nonce (a
//!    replayed welcome answers an old nonce), then sends in that session
//!    from seq 1; the gateway makes the pending session current on the
//!    first authentic frame of it.
//!
//! Within a session each direction's seq must strictly increase (gaps are
//! fine: UDP loses datagrams; reordered ones are dropped as replays). A
//! frame of another session is dropped as [`DropReason::WrongSession`]. A
//! repeated hello with the pending nonce gets the same welcome again, so a
//! lost welcome cannot split the two sides into different sessions.
//!
//! Randomness and time stay outside: the caller supplies nonces and session
//! ids (hardware RNG on the ESP32, the OS on the gateway) and decides when
//! to send heartbeats or give a silent link up.

use super::frame::{decode, encode, Direction, EncodeError, Frame, Header, LinkKey, Payload, SessionId};
use super::frame::{Telemetry, NONCE_LEN};
use super::{DropCounters, DropReason};
use crate::RobotId;

/// Why a frame could not be sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SendError {
    /// No session yet (or the sequence space of the last one ran out).
    NoSession,
    /// This side never sends that kind of frame.
    WrongDirection,
    /// The frame could not be encoded.
    Encode(EncodeError),
}

impl core::fmt::Display for SendError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoSession => write!(f, "no link session"),
            Self::WrongDirection => write!(f, "this side does not send that frame kind"),
            Self::Encode(e) => write!(f, "{e}"),
        }
    }
}

impl core::error::Error for SendError {}

impl From<EncodeError> for SendError {
    fn from(e: EncodeError) -> Self {
        Self::Encode(e)
    }
}

/// One direction's sequence state within a session.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Session {
    id: SessionId,
    /// Last sequence number sent.
    tx: u32,
    /// Last sequence number accepted.
    rx: u32,
}

impl Session {
    fn accept(&mut self, header: &Header) -> Result<(), DropReason> {
        if header.session != self.id {
            return Err(DropReason::WrongSession);
        }
        if header.seq <= self.rx {
            return Err(DropReason::Replayed);
        }
        self.rx = header.seq;
        Ok(())
    }

    fn next_tx(&mut self) -> Option<u32> {
        self.tx = self.tx.checked_add(1)?;
        Some(self.tx)
    }
}

fn send<'b>(
    robot: RobotId,
    key: &LinkKey,
    session: &mut Option<Session>,
    incoming: Direction,
    payload: Payload,
    buf: &'b mut [u8],
) -> Result<&'b [u8], SendError> {
    if payload.direction() == incoming || matches!(payload, Payload::Hello { .. } | Payload::Welcome { .. }) {
        return Err(SendError::WrongDirection);
    }
    let s = session.as_mut().ok_or(SendError::NoSession)?;
    let Some(seq) = s.next_tx() else {
        *session = None;
        return Err(SendError::NoSession);
    };
    let header = Header { robot, session: s.id, seq };
    Ok(encode(&Frame { header, payload }, key, buf)?)
}

/// What an accepted frame means to the robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RobotEvent {
    /// The gateway welcomed the current hello: the session is up.
    Connected(SessionId),
    /// Deploy: the robot may drive.
    Enable,
    /// A new goal bearing, robot frame, rad.
    Goal(f32),
    /// Motors off for good.
    Stop,
    /// Gateway liveness.
    Heartbeat,
}

/// The robot's side of the link.
#[derive(Clone, Debug)]
pub struct RobotLink {
    robot: RobotId,
    key: LinkKey,
    hello: Option<[u8; NONCE_LEN]>,
    session: Option<Session>,
    drops: DropCounters,
}

impl RobotLink {
    /// A robot with no session.
    pub fn new(robot: RobotId, key: LinkKey) -> Self {
        Self { robot, key, hello: None, session: None, drops: DropCounters::default() }
    }

    /// Starts (or, with the same nonce, repeats) a handshake: leaves any
    /// session and encodes the hello. Use a fresh nonce per new attempt.
    pub fn hello<'b>(&mut self, nonce: [u8; NONCE_LEN], buf: &'b mut [u8]) -> Result<&'b [u8], SendError> {
        self.session = None;
        self.hello = Some(nonce);
        let header = Header { robot: self.robot, session: SessionId(0), seq: 0 };
        Ok(encode(&Frame { header, payload: Payload::Hello { nonce } }, &self.key, buf)?)
    }

    /// The current session, if connected.
    pub fn session(&self) -> Option<SessionId> {
        self.session.map(|s| s.id)
    }

    /// Leaves the session and any handshake (e.g. after a silent link);
    /// frames of the old session are refused from now on.
    pub fn leave(&mut self) {
        self.session = None;
        self.hello = None;
    }

    /// Whether a handshake is in progress (hello sent, no welcome yet).
    pub fn handshaking(&self) -> bool {
        self.hello.is_some()
    }

    /// Drops counted so far.
    pub fn drops(&self) -> &DropCounters {
        &self.drops
    }

    /// Checks one datagram; a refused one is counted and its reason returned.
    pub fn receive(&mut self, bytes: &[u8]) -> Result<RobotEvent, DropReason> {
        let r = self.accept(bytes);
        if let Err(reason) = r {
            self.drops.record(reason);
        }
        r
    }

    fn accept(&mut self, bytes: &[u8]) -> Result<RobotEvent, DropReason> {
        let frame = decode(bytes, &self.key, self.robot, Direction::ToRobot)?;
        if let Payload::Welcome { nonce } = frame.payload {
            if self.hello != Some(nonce) || frame.header.session.0 == 0 {
                return Err(DropReason::UnexpectedWelcome);
            }
            let id = frame.header.session;
            self.hello = None;
            self.session = Some(Session { id, tx: 0, rx: frame.header.seq });
            return Ok(RobotEvent::Connected(id));
        }
        self.session.as_mut().ok_or(DropReason::NoSession)?.accept(&frame.header)?;
        Ok(match frame.payload {
            Payload::Enable => RobotEvent::Enable,
            Payload::Goal { bearing } => RobotEvent::Goal(bearing),
            Payload::Stop => RobotEvent::Stop,
            // Only gateway → robot kinds pass `decode` here.
            _ => RobotEvent::Heartbeat,
        })
    }

    /// Encodes a telemetry or heartbeat frame in the current session.
    pub fn send<'b>(&mut self, payload: Payload, buf: &'b mut [u8]) -> Result<&'b [u8], SendError> {
        send(self.robot, &self.key, &mut self.session, Direction::ToRobot, payload, buf)
    }
}

/// What an accepted frame means to the gateway.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GatewayEvent {
    /// A hello: answer it with [`GatewayLink::welcome`].
    Hello([u8; NONCE_LEN]),
    /// One control period's telemetry.
    Telemetry(Telemetry),
    /// Robot liveness.
    Heartbeat {
        /// Robot uptime, ms.
        uptime_ms: u32,
    },
}

/// An accepted frame at the gateway.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Accepted {
    /// What it says.
    pub event: GatewayEvent,
    /// Set when this frame made a pending session current (the robot has
    /// (re)connected: it may have rebooted, so resend its state).
    pub session_started: Option<SessionId>,
}

/// The gateway's side of the link.
#[derive(Clone, Debug)]
pub struct GatewayLink {
    robot: RobotId,
    key: LinkKey,
    current: Option<Session>,
    pending: Option<(SessionId, [u8; NONCE_LEN])>,
    drops: DropCounters,
}

impl GatewayLink {
    /// A gateway for `robot`, with no session.
    pub fn new(robot: RobotId, key: LinkKey) -> Self {
        Self { robot, key, current: None, pending: None, drops: DropCounters::default() }
    }

    /// The robot served.
    pub fn robot(&self) -> RobotId {
        self.robot
    }

    /// The current (confirmed) session.
    pub fn session(&self) -> Option<SessionId> {
        self.current.map(|s| s.id)
    }

    /// Drops counted so far.
    pub fn drops(&self) -> &DropCounters {
        &self.drops
    }

    /// Checks one datagram; a refused one is counted and its reason returned.
    pub fn receive(&mut self, bytes: &[u8]) -> Result<Accepted, DropReason> {
        let r = self.accept(bytes);
        if let Err(reason) = r {
            self.drops.record(reason);
        }
        r
    }

    fn accept(&mut self, bytes: &[u8]) -> Result<Accepted, DropReason> {
        let frame = decode(bytes, &self.key, self.robot, Direction::ToGateway)?;
        let h = frame.header;
        if let Payload::Hello { nonce } = frame.payload {
            if h.session.0 != 0 || h.seq != 0 {
                return Err(DropReason::Malformed);
            }
            return Ok(Accepted { event: GatewayEvent::Hello(nonce), session_started: None });
        }
        let mut session_started = None;
        match (&mut self.current, self.pending) {
            (_, Some((id, _))) if h.session == id && h.session.0 != 0 => {
                // First authentic frame of the pending session: it is current.
                let mut s = Session { id, tx: 0, rx: 0 };
                s.accept(&h)?;
                self.current = Some(s);
                self.pending = None;
                session_started = Some(id);
            }
            (Some(s), _) => s.accept(&h)?,
            (None, _) => return Err(DropReason::NoSession),
        }
        let event = match frame.payload {
            Payload::Telemetry(t) => GatewayEvent::Telemetry(t),
            Payload::RobotHeartbeat { uptime_ms } => GatewayEvent::Heartbeat { uptime_ms },
            // Only robot → gateway kinds pass `decode` here; hello is above.
            _ => GatewayEvent::Heartbeat { uptime_ms: 0 },
        };
        Ok(Accepted { event, session_started })
    }

    /// Encodes the welcome for a hello's `nonce`. `fresh` must be a new
    /// random non-zero session id; it is ignored when `nonce` repeats the
    /// pending hello's (the same welcome is sent again).
    pub fn welcome<'b>(
        &mut self,
        nonce: [u8; NONCE_LEN],
        fresh: SessionId,
        buf: &'b mut [u8],
    ) -> Result<&'b [u8], SendError> {
        let id = match self.pending {
            Some((id, pending)) if pending == nonce => id,
            _ => SessionId(fresh.0.max(1)),
        };
        self.pending = Some((id, nonce));
        let header = Header { robot: self.robot, session: id, seq: 0 };
        Ok(encode(&Frame { header, payload: Payload::Welcome { nonce } }, &self.key, buf)?)
    }

    /// Encodes a command or heartbeat in the current session.
    pub fn send<'b>(&mut self, payload: Payload, buf: &'b mut [u8]) -> Result<&'b [u8], SendError> {
        send(self.robot, &self.key, &mut self.current, Direction::ToGateway, payload, buf)
    }
}
