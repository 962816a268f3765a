//! The transport interface: one small set of traits, several backends.
//!
//! Why traits and not one concrete transport: the same orchestrator and
//! agents run in one process (tests), across processes on one machine
//! (iceoryx2 shared memory) and across machines (zenoh). They are written
//! against [`Bus`], [`Publish`] and [`Subscribe`]; a conformance suite
//! (`tests/bus_conformance.rs`) runs unchanged against every backend, so
//! the backends agree on the semantics below.
//!
//! Contract every backend keeps:
//!
//! * payloads are opaque bytes of at most [`Limits::max_payload`]; a larger
//!   one is refused with [`BusError::PayloadTooLarge`];
//! * one publisher's messages arrive at each subscriber in publish order;
//!   messages of different publishers may interleave in any order;
//!   every subscriber of a topic gets every message;
//! * no history: a subscriber receives only what is published after it was
//!   created;
//! * each subscriber buffers up to [`Limits::buffer`] unread messages per
//!   publisher; past that the *oldest* are overwritten (a publisher never
//!   blocks on a slow subscriber);
//! * every wait has a timeout ([`Subscribe::recv_timeout_into`]);
//! * a subscriber created for a topic also keeps receiving from publishers
//!   created after it;
//! * a fan-in ([`Bus::fan_in`]) is a subscriber of several topics at once
//!   whose messages say which topic they came from.
//!
//! The typed layer ([`typed`]) encodes and decodes [`crate::Message`]s with
//! the one codec over these byte channels.

pub mod fault;
mod inbox;
pub mod memory;
pub mod typed;

#[cfg(feature = "ipc")]
pub mod ipc;
#[cfg(feature = "zenoh")]
pub mod zenoh;

use crate::naming::TopicName;
use crate::CodecError;
use core::time::Duration;

pub use typed::{BusExt, TypedFanIn, TypedPublisher, TypedSubscriber};

/// Default largest payload, bytes: four times [`crate::MAX_MESSAGE_LEN`].
pub const DEFAULT_MAX_PAYLOAD: usize = 256;
/// Default number of unread messages a subscriber holds per publisher.
pub const DEFAULT_BUFFER: usize = 64;

/// Sizes a bus was opened with. All processes on one topic must agree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Largest payload accepted by [`Publish::publish`], bytes.
    pub max_payload: usize,
    /// Unread messages a subscriber holds per publisher before the oldest
    /// is overwritten.
    pub buffer: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Self { max_payload: DEFAULT_MAX_PAYLOAD, buffer: DEFAULT_BUFFER }
    }
}

/// Why a bus operation failed.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum BusError {
    /// The payload exceeds the bus's [`Limits::max_payload`].
    PayloadTooLarge {
        /// Payload length, bytes.
        len: usize,
        /// The limit, bytes.
        max: usize,
    },
    /// The receive buffer cannot hold the message (it was consumed).
    BufferTooSmall {
        /// Message length, bytes.
        len: usize,
        /// Buffer capacity, bytes.
        capacity: usize,
    },
    /// A message could not be encoded or decoded.
    Codec(CodecError),
    /// A limit or configuration value is unusable.
    InvalidConfig(&'static str),
    /// The transport failed; `detail` is the backend's own error.
    Backend {
        /// What was being done ("open publisher", "receive", ...).
        op: &'static str,
        /// The topic, when there is one.
        topic: Option<String>,
        /// The backend's error, formatted.
        detail: String,
    },
}

impl BusError {
    #[cfg_attr(not(feature = "ipc"), allow(dead_code))]
    pub(crate) fn backend(op: &'static str, topic: Option<&TopicName>, e: impl core::fmt::Debug) -> Self {
        Self::Backend { op, topic: topic.map(|t| t.as_str().to_owned()), detail: format!("{e:?}") }
    }
}

impl core::fmt::Display for BusError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::PayloadTooLarge { len, max } => {
                write!(f, "payload of {len} bytes exceeds the bus limit of {max}")
            }
            Self::BufferTooSmall { len, capacity } => {
                write!(f, "received message of {len} bytes does not fit the {capacity}-byte buffer")
            }
            Self::Codec(e) => write!(f, "codec: {e}"),
            Self::InvalidConfig(why) => write!(f, "invalid bus configuration: {why}"),
            Self::Backend { op, topic, detail } => match topic {
                Some(t) => write!(f, "bus failed to {op} on '{t}': {detail}"),
                None => write!(f, "bus failed to {op}: {detail}"),
            },
        }
    }
}

impl core::error::Error for BusError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Self::Codec(e) => Some(e),
            _ => None,
        }
    }
}

impl From<CodecError> for BusError {
    fn from(e: CodecError) -> Self {
        Self::Codec(e)
    }
}

/// Bytes before each payload that a fan-in hands out: the index of its
/// topic in the list the fan-in was opened with, a `u32` little-endian.
pub const FAN_IN_TAG: usize = 4;

/// Splits a message of a fan-in ([`Bus::fan_in`]) into its topic's index
/// and its payload; `None` when it is shorter than the tag.
pub fn untag(message: &[u8]) -> Option<(usize, &[u8])> {
    let (tag, payload) = message.split_first_chunk::<FAN_IN_TAG>()?;
    Some((u32::from_le_bytes(*tag) as usize, payload))
}

/// Opens publishers and subscribers on topics.
pub trait Bus {
    /// The backend's publisher.
    type Publisher: Publish;
    /// The backend's subscriber.
    type Subscriber: Subscribe;
    /// The backend's receiver of many topics at once ([`Bus::fan_in`]).
    type FanIn: Subscribe;

    /// Opens a publisher on `topic`.
    fn publisher(&self, topic: &TopicName) -> Result<Self::Publisher, BusError>;
    /// Opens a subscriber on `topic`; it sees messages published from now on.
    fn subscriber(&self, topic: &TopicName) -> Result<Self::Subscriber, BusError>;
    /// Opens one receiver of every topic of `topics` (one wait for all:
    /// the orchestrator reads every robot's reports so). Each message comes
    /// as [`FAN_IN_TAG`] bytes naming its topic's index in `topics`, then
    /// the payload ([`untag`]); otherwise the contract of a subscriber of
    /// each topic holds (order per publisher, buffer per publisher, no
    /// history). The topics must share one [`TopicName::doorbell`].
    fn fan_in(&self, topics: &[TopicName]) -> Result<Self::FanIn, BusError>;
    /// The sizes this bus was opened with.
    fn limits(&self) -> Limits;
}

/// Sends byte payloads on one topic.
pub trait Publish {
    /// Publishes one payload to every current subscriber. Never blocks.
    fn publish(&self, payload: &[u8]) -> Result<(), BusError>;

    /// Publishes one payload without waking readers that sleep on the
    /// topic: the caller publishes another on the same topic at once, and
    /// the reader it wakes finds both, in order. Why: a wake-up is a system
    /// call each (a datagram over iceoryx2), and an agent that runs several
    /// lockstep periods at once publishes 32 poses together. Default: as
    /// [`Publish::publish`] (backends whose readers wake without a ring).
    fn publish_quietly(&self, payload: &[u8]) -> Result<(), BusError> {
        self.publish(payload)
    }
}

/// Receives byte payloads from one topic.
pub trait Subscribe {
    /// Largest payload this subscriber can receive, bytes.
    fn max_payload(&self) -> usize;

    /// Takes the next message into `buf` without waiting; returns its
    /// length, or `None` when nothing is pending.
    fn try_recv_into(&self, buf: &mut [u8]) -> Result<Option<usize>, BusError>;

    /// Like [`Subscribe::try_recv_into`] but waits up to `timeout` for a
    /// message; `None` means the timeout passed — or, with backends that
    /// sleep in the kernel, that a signal interrupted the wait early (so a
    /// Ctrl-C flag gets looked at promptly); callers loop on their deadline.
    fn recv_timeout_into(&self, buf: &mut [u8], timeout: Duration) -> Result<Option<usize>, BusError>;

    /// [`Subscribe::recv_timeout_into`] for a reader that expects nothing
    /// soon (a parked robot's agent, which only waits for `Shutdown`): no
    /// busy-wait first, and on a backend that sleeps until notified, one
    /// sleep up to `timeout` instead of short slices. A thousand idle
    /// readers then cost the machine almost nothing; a message from a
    /// publisher that does not notify is seen by the timeout. The default
    /// is `recv_timeout_into`.
    fn recv_idle_into(&self, buf: &mut [u8], timeout: Duration) -> Result<Option<usize>, BusError> {
        self.recv_timeout_into(buf, timeout)
    }

    /// [`Subscribe::try_recv_into`] into a new vector.
    fn try_recv(&self) -> Result<Option<Vec<u8>>, BusError> {
        let mut buf = vec![0u8; self.max_payload()];
        Ok(self.try_recv_into(&mut buf)?.map(|n| {
            buf.truncate(n);
            buf
        }))
    }

    /// [`Subscribe::recv_timeout_into`] into a new vector.
    fn recv_timeout(&self, timeout: Duration) -> Result<Option<Vec<u8>>, BusError> {
        let mut buf = vec![0u8; self.max_payload()];
        Ok(self.recv_timeout_into(&mut buf, timeout)?.map(|n| {
            buf.truncate(n);
            buf
        }))
    }
}

/// Copies a received payload into the caller's buffer.
pub(crate) fn copy_out(payload: &[u8], buf: &mut [u8]) -> Result<usize, BusError> {
    let capacity = buf.len();
    let dst =
        buf.get_mut(..payload.len()).ok_or(BusError::BufferTooSmall { len: payload.len(), capacity })?;
    dst.copy_from_slice(payload);
    Ok(payload.len())
}
