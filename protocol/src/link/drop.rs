//! Why a link frame was refused, and how often.
//!
//! Why typed and counted: a refused frame is never acted on, but silently
//! eating it would hide a misconfigured key, a second gateway talking to the
//! same robot, or someone replaying captures. Each side keeps one counter
//! per reason; the robot reports its total in its telemetry and the gateway
//! logs and publishes its own.

/// Why a datagram was dropped. Checked in this order by
/// [`super::decode`] (stateless) and then by the session state machines.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DropReason {
    /// Shorter than a header plus a tag: not a link frame at all.
    Truncated,
    /// The version byte is not [`super::LINK_VERSION`].
    WrongVersion,
    /// The kind byte names no frame kind.
    UnknownKind,
    /// The length does not match the frame kind's fixed size.
    BadLength,
    /// The robot id is not the one this endpoint serves.
    ForeignRobot,
    /// A frame kind that only the receiver itself sends (e.g. a command
    /// reflected back to the gateway).
    WrongDirection,
    /// The authentication tag does not match (wrong key, or tampering).
    BadTag,
    /// Authentic, but a field is out of range (an unknown state, a
    /// non-finite number, reserved bits set).
    Malformed,
    /// Authentic, but no session is established yet (only a hello or a
    /// welcome can start one).
    NoSession,
    /// Authentic, but for another session than the current one: an old
    /// session's capture replayed, or a peer that has not noticed a reboot.
    WrongSession,
    /// Authentic and in session, but its sequence number is not newer than
    /// the last accepted one: a replay, a duplicate or a reordered frame.
    Replayed,
    /// A welcome that does not answer this robot's current hello.
    UnexpectedWelcome,
}

impl DropReason {
    /// Every reason, in counter order.
    pub const ALL: [DropReason; 12] = [
        Self::Truncated,
        Self::WrongVersion,
        Self::UnknownKind,
        Self::BadLength,
        Self::ForeignRobot,
        Self::WrongDirection,
        Self::BadTag,
        Self::Malformed,
        Self::NoSession,
        Self::WrongSession,
        Self::Replayed,
        Self::UnexpectedWelcome,
    ];

    fn index(self) -> usize {
        self as usize
    }

    /// A short snake_case name, for logs and metrics.
    pub fn name(self) -> &'static str {
        match self {
            Self::Truncated => "truncated",
            Self::WrongVersion => "wrong_version",
            Self::UnknownKind => "unknown_kind",
            Self::BadLength => "bad_length",
            Self::ForeignRobot => "foreign_robot",
            Self::WrongDirection => "wrong_direction",
            Self::BadTag => "bad_tag",
            Self::Malformed => "malformed",
            Self::NoSession => "no_session",
            Self::WrongSession => "wrong_session",
            Self::Replayed => "replayed",
            Self::UnexpectedWelcome => "unexpected_welcome",
        }
    }
}

impl core::fmt::Display for DropReason {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let why = match self {
            Self::Truncated => "datagram shorter than a link header and tag",
            Self::WrongVersion => "unsupported link version",
            Self::UnknownKind => "unknown frame kind",
            Self::BadLength => "length does not match the frame kind",
            Self::ForeignRobot => "frame for another robot",
            Self::WrongDirection => "frame kind sent in the wrong direction",
            Self::BadTag => "authentication tag mismatch",
            Self::Malformed => "authentic frame with an out-of-range field",
            Self::NoSession => "no session established",
            Self::WrongSession => "frame of another session",
            Self::Replayed => "sequence number not newer than the last accepted",
            Self::UnexpectedWelcome => "welcome does not answer the current hello",
        };
        f.write_str(why)
    }
}

impl core::error::Error for DropReason {}

/// One saturating counter per [`DropReason`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DropCounters {
    counts: [u32; DropReason::ALL.len()],
}

impl DropCounters {
    /// Counts one drop.
    pub fn record(&mut self, reason: DropReason) {
        let c = &mut self.counts[reason.index()];
        *c = c.saturating_add(1);
    }

    /// Drops counted for `reason`.
    pub fn count(&self, reason: DropReason) -> u32 {
        self.counts[reason.index()]
    }

    /// Drops counted for all reasons (saturating).
    pub fn total(&self) -> u32 {
        self.counts.iter().fold(0u32, |a, &c| a.saturating_add(c))
    }

    /// (reason, count) for every reason with a non-zero count.
    pub fn nonzero(&self) -> impl Iterator<Item = (DropReason, u32)> + '_ {
        DropReason::ALL.iter().map(|&r| (r, self.count(r))).filter(|&(_, c)| c > 0)
    }
}
