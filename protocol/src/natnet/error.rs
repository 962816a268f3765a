//! Why a NatNet packet could not be parsed or encoded.
//!
//! Why a file of its own: every part of the codec (`wire.rs`,
//! `command.rs`, `frame.rs`, `modeldef.rs`) returns it, and `mod.rs` uses
//! them all (no file cycles).

/// Why a NatNet packet could not be parsed or encoded.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The bytes ended inside a field.
    #[error("NatNet packet truncated: {what} at byte {at}")]
    Truncated {
        /// The field being read.
        what: &'static str,
        /// Its offset in the payload.
        at: usize,
    },
    /// The header announces more payload than the datagram holds.
    #[error("NatNet header announces {announced} payload bytes, datagram has {available}")]
    LengthMismatch {
        /// Payload length in the header.
        announced: usize,
        /// Bytes after the header.
        available: usize,
    },
    /// A count is negative or larger than the rest of the packet can hold.
    #[error("NatNet {what} count {count} at byte {at} is impossible for the packet's length")]
    BadCount {
        /// What was counted.
        what: &'static str,
        /// The count read.
        count: i32,
        /// Its offset in the payload.
        at: usize,
    },
    /// A string has no terminating NUL.
    #[error("NatNet string ({what}) at byte {at} has no terminating NUL")]
    Unterminated {
        /// The string field.
        what: &'static str,
        /// Its offset in the payload.
        at: usize,
    },
    /// A string is not UTF-8.
    #[error("NatNet string ({what}) at byte {at} is not UTF-8")]
    NotUtf8 {
        /// The string field.
        what: &'static str,
        /// Its offset in the payload.
        at: usize,
    },
    /// The message id is none NatNet 4.x defines.
    #[error("unknown NatNet message id {0}")]
    UnknownMessage(u16),
    /// A model definition of a kind this codec does not decode, in a 4.0
    /// stream (which has no size to skip it by).
    #[error("NatNet model definition of kind {0} cannot be skipped without 4.1 sizes")]
    UnsupportedDescription(i32),
    /// Bytes were left after a complete message.
    #[error("{extra} unexpected byte(s) after a complete NatNet {what}")]
    TrailingBytes {
        /// The message.
        what: &'static str,
        /// How many bytes were left.
        extra: usize,
    },
    /// The message cannot be encoded: too long for its field.
    #[error("NatNet {what} too large to encode")]
    TooLarge {
        /// The field or message.
        what: &'static str,
    },
    /// Frames and model definitions before NatNet 4.0 are not supported.
    #[error("NatNet {0}.{1} frames are not supported (4.x only)")]
    UnsupportedVersion(u8, u8),
    /// A string to encode contains a NUL byte.
    #[error("NatNet string ({what}) contains a NUL byte")]
    InteriorNul {
        /// The string field.
        what: &'static str,
    },
}
