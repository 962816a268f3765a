//! Counting bad traffic instead of crashing on it.
//!
//! Why: a process on a shared bus will, sooner or later, see garbage bytes,
//! a peer of another protocol version, a message for a robot it does not
//! know or a duplicate registration. None of these may take a robot or the
//! orchestrator down; each is counted by kind and logged (the first few of
//! each kind, then every 1000th, so a flood cannot drown the terminal). The
//! agent and the orchestrator share this type, and the orchestrator's
//! summary reports the counts.

use bycoms_protocol::bus::BusError;
use bycoms_protocol::CodecError;
use serde::Serialize;

/// How many messages of each kind are logged before thinning out.
const LOG_FIRST: u64 = 5;

pub use crate::bad::BadKind;

/// Counts of bad messages by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Traffic {
    /// Bytes that do not decode.
    pub garbage: u64,
    /// Messages of another protocol version.
    pub wrong_version: u64,
    /// Messages about unknown robots.
    pub unknown_robot: u64,
    /// Duplicate registrations.
    pub duplicate: u64,
    /// Decoded but refused.
    pub refused: u64,
}

impl Traffic {
    /// All bad messages.
    pub fn total(&self) -> u64 {
        self.garbage + self.wrong_version + self.unknown_robot + self.duplicate + self.refused
    }

    /// Counts one bad message and logs it (thinned) under `who` with `what`.
    pub fn count(&mut self, who: &str, kind: BadKind, what: &dyn core::fmt::Display) {
        let slot = match kind {
            BadKind::Garbage => &mut self.garbage,
            BadKind::WrongVersion => &mut self.wrong_version,
            BadKind::UnknownRobot => &mut self.unknown_robot,
            BadKind::Duplicate => &mut self.duplicate,
            BadKind::Refused => &mut self.refused,
        };
        *slot += 1;
        let n = *slot;
        if n <= LOG_FIRST || n % 1000 == 0 {
            tracing::warn!(who, n, ?kind, "bad message: {what}");
        }
    }

    /// Counts a receive error if it is about the message (a codec error or
    /// an oversized payload) and returns `None`; a wait interrupted by a
    /// signal is no error at all (`None`, nothing counted: the caller's loop
    /// looks at its flags next); returns the error back if the transport
    /// itself failed.
    ///
    /// (The iceoryx2 listener reports a signal during its wait — EINTR, e.g.
    /// Ctrl-C or SIGTERM handled by a flag — as an error.)
    pub fn absorb(&mut self, who: &str, topic: &str, e: BusError) -> Option<BusError> {
        if is_interrupt(&e) {
            return None;
        }
        self.absorb_message_error(who, topic, e)
    }

    /// Counts a receive error if it is about the message (a codec error or
    /// an oversized payload) and returns `None`; returns the error back if
    /// the transport itself failed.
    fn absorb_message_error(&mut self, who: &str, topic: &str, e: BusError) -> Option<BusError> {
        let kind = match &e {
            BusError::Codec(CodecError::UnsupportedVersion { .. }) => BadKind::WrongVersion,
            BusError::Codec(_) | BusError::BufferTooSmall { .. } => BadKind::Garbage,
            _ => return Some(e),
        };
        self.count(who, kind, &format_args!("on {topic}: {e}"));
        None
    }
}

/// "2 undecodable, 1 duplicate registration": the non-zero counts, in words.
impl core::fmt::Display for Traffic {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let parts = [
            (self.garbage, "undecodable"),
            (self.wrong_version, "of another protocol version"),
            (self.unknown_robot, "about an unknown robot"),
            (self.duplicate, "duplicate registration"),
            (self.refused, "refused"),
        ];
        let mut first = true;
        for (n, what) in parts.into_iter().filter(|(n, _)| *n > 0) {
            let sep = if first { "" } else { ", " };
            first = false;
            write!(f, "{sep}{n} {what}")?;
        }
        if first {
            write!(f, "none")?;
        }
        Ok(())
    }
}

/// Whether `e` is a wait cut short by a signal (not a failure).
pub fn is_interrupt(e: &BusError) -> bool {
    matches!(e, BusError::Backend { detail, .. } if detail.contains("InterruptSignal"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sorts_errors_by_kind_and_passes_transport_failures_on() {
        let mut t = Traffic::default();
        let v = BusError::Codec(CodecError::UnsupportedVersion { found: 9, supported: 1 });
        assert!(t.absorb("test", "x", v).is_none());
        assert!(t.absorb("test", "x", BusError::Codec(CodecError::Malformed)).is_none());
        // A non-canonical spelling (an overlong varint) is garbage too.
        assert!(t.absorb("test", "x", BusError::Codec(CodecError::NonCanonical)).is_none());
        assert!(t.absorb("test", "x", BusError::BufferTooSmall { len: 99, capacity: 64 }).is_none());
        let eintr = BusError::Backend { op: "wait for event", topic: None, detail: "InterruptSignal".into() };
        assert!(t.absorb("test", "x", eintr).is_none());
        let fatal = BusError::InvalidConfig("x");
        assert_eq!(t.absorb("test", "x", fatal.clone()), Some(fatal));
        t.count("test", BadKind::Duplicate, &"again");
        assert_eq!((t.wrong_version, t.garbage, t.duplicate, t.total()), (1, 3, 1, 5));
        assert_eq!(t.to_string(), "3 undecodable, 1 of another protocol version, 1 duplicate registration");
        assert_eq!(Traffic::default().to_string(), "none");
    }
}
