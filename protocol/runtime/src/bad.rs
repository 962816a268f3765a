//! What was wrong with a bad message ([`BadKind`]).
//!
//! Why a module of its own, outside `traffic` (the counting, behind the
//! `process` feature, which re-exports it): the launch core, which has no
//! IO, names the kind of each bad message it puts out, and needs none of
//! the features a process brings.

/// What was wrong with a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BadKind {
    /// Bytes that do not decode (malformed, truncated, trailing bytes,
    /// unknown variant, non-canonical, too long for the buffer).
    Garbage,
    /// A well-framed message of another protocol version.
    WrongVersion,
    /// A message about a robot this process does not know.
    UnknownRobot,
    /// A second registration of the same robot.
    Duplicate,
    /// Decoded but refused (out of place, non-finite values, ...).
    Refused,
}
