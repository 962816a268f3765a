//! The one encode/decode pair every process uses.
//!
//! Why one pair: if each process framed messages its own way, a version skew
//! between an old agent and a new orchestrator would surface as garbage
//! poses instead of a clear error. Every message therefore travels inside
//! the same envelope, `[version: u16 varint][body: postcard]`, and
//! [`decode`] checks the version first, then the body, then that nothing is
//! left over; it refuses any spelling but the one [`encode`] writes (one
//! message, one encoding: an overlong varint such as `82 00` for 2 is
//! [`CodecError::NonCanonical`]). Only types that implement [`Message`] (the per-direction
//! enums in [`crate::msg`]) can be encoded, so a topic never carries a stray
//! integer or a half message.
//!
//! Postcard is used because it is `no_std`, allocation-free, compact
//! (varints) and has a documented, stable wire format; f64 fields are their
//! 8 little-endian IEEE-754 bytes, so simulated poses cross processes
//! bit-exactly.

use serde::{de::DeserializeOwned, Serialize};

/// The wire-format version carried by every message. Bump it whenever the
/// byte layout of any message changes (the golden-byte tests will tell).
pub const PROTOCOL_VERSION: u16 = 3;

/// Upper bound of an encoded message (envelope included), for stack buffers.
/// A test encodes every variant with its largest values to prove it.
pub const MAX_MESSAGE_LEN: usize = 64;

/// A top-level wire message: one of the per-direction enums of
/// [`crate::msg`]. Only these go through [`encode`]/[`decode`].
pub trait Message: Serialize + DeserializeOwned {}

/// Why a message could not be encoded or decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum CodecError {
    /// The output buffer is too small for the encoded message.
    BufferTooSmall,
    /// The input ended before the message was complete.
    Truncated,
    /// A complete message was followed by `extra` unexpected bytes.
    TrailingBytes {
        /// How many bytes were left over.
        extra: usize,
    },
    /// The envelope carries a protocol version this build does not speak.
    UnsupportedVersion {
        /// The version found in the envelope.
        found: u16,
        /// The version this build speaks ([`PROTOCOL_VERSION`]).
        supported: u16,
    },
    /// An enum discriminant names no known variant (a newer peer, or noise).
    UnknownVariant,
    /// The bytes are not a valid encoding (bad varint, bool, or the like).
    Malformed,
    /// The bytes spell a valid message, but not the way [`encode`] writes
    /// it (an overlong varint such as `82 00` for 2): one message has one
    /// encoding.
    NonCanonical,
    /// The serializer failed for a reason other than a full buffer.
    Serialize,
}

impl core::fmt::Display for CodecError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::BufferTooSmall => write!(f, "output buffer too small for the message"),
            Self::Truncated => write!(f, "message truncated: input ended early"),
            Self::TrailingBytes { extra } => {
                write!(f, "{extra} unexpected trailing byte(s) after the message")
            }
            Self::UnsupportedVersion { found, supported } => {
                write!(f, "unsupported protocol version {found} (this build speaks {supported})")
            }
            Self::UnknownVariant => write!(f, "unknown message variant"),
            Self::Malformed => write!(f, "malformed message bytes"),
            Self::NonCanonical => write!(f, "non-canonical encoding (an overlong varint)"),
            Self::Serialize => write!(f, "message could not be serialized"),
        }
    }
}

impl core::error::Error for CodecError {}

impl From<postcard::Error> for CodecError {
    fn from(e: postcard::Error) -> Self {
        use postcard::Error as P;
        match e {
            P::SerializeBufferFull => Self::BufferTooSmall,
            P::DeserializeUnexpectedEnd => Self::Truncated,
            // Serde's derived enum visitors reject an out-of-range variant
            // index with a custom error (`invalid_value`), which postcard
            // reports as `SerdeDeCustom`; every message is a plain derive
            // over fixed-size fields, so that is the only source of it.
            P::DeserializeBadEnum | P::SerdeDeCustom => Self::UnknownVariant,
            P::WontImplement
            | P::NotYetImplemented
            | P::SerializeSeqLengthUnknown
            | P::SerdeSerCustom
            | P::CollectStrError => Self::Serialize,
            _ => Self::Malformed,
        }
    }
}

/// The envelope: postcard writes struct fields in order with no names, so
/// this is exactly `[version varint][body]`.
#[derive(Serialize)]
struct Envelope<'a, T> {
    version: u16,
    body: &'a T,
}

/// Encodes `msg` in its envelope into `buf`; returns the written prefix.
pub fn encode<'b, T: Message>(msg: &T, buf: &'b mut [u8]) -> Result<&'b [u8], CodecError> {
    let envelope = Envelope { version: PROTOCOL_VERSION, body: msg };
    let written = postcard::to_slice(&envelope, buf)?;
    Ok(written)
}

/// Encodes `msg` in its envelope into a new vector.
#[cfg(feature = "std")]
pub fn encode_vec<T: Message>(msg: &T) -> Result<Vec<u8>, CodecError> {
    let envelope = Envelope { version: PROTOCOL_VERSION, body: msg };
    Ok(postcard::to_allocvec(&envelope)?)
}

/// Decodes one whole message: checks the version, the body, that both are
/// spelled canonically, and that no bytes are left over.
pub fn decode<T: Message>(bytes: &[u8]) -> Result<T, CodecError> {
    let (found, rest) = take_canonical::<u16>(bytes)?;
    if found != PROTOCOL_VERSION {
        return Err(CodecError::UnsupportedVersion { found, supported: PROTOCOL_VERSION });
    }
    let (msg, rest) = take_canonical::<T>(rest)?;
    if !rest.is_empty() {
        return Err(CodecError::TrailingBytes { extra: rest.len() });
    }
    Ok(msg)
}

/// Decodes one value from the front of `bytes` and refuses it unless
/// encoding it again gives exactly the bytes it was read from.
///
/// Why re-encode and compare: postcard's reader accepts overlong varints
/// (`82 00` reads as 2), and varints are in every field kind that has more
/// than one spelling (integers, robot ids, enum discriminants; a bool or an
/// option tag is one byte that postcard already checks, and no message has
/// a length prefix). Postcard's encoder writes the one shortest spelling,
/// so "re-encodes to the same bytes" is exactly "canonical", for every
/// field present and future, with no field-by-field reader to keep in step
/// with the types. It costs one encode into a stack buffer of
/// [`MAX_MESSAGE_LEN`] bytes (no allocation, `no_std`); every value that
/// decodes re-encodes within it (a test proves the bound).
fn take_canonical<T: Serialize + DeserializeOwned>(bytes: &[u8]) -> Result<(T, &[u8]), CodecError> {
    let (value, rest) = postcard::take_from_bytes::<T>(bytes)?;
    let read = &bytes[..bytes.len() - rest.len()];
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    match postcard::to_slice(&value, &mut buf) {
        Ok(written) if written == read => Ok((value, rest)),
        _ => Err(CodecError::NonCanonical),
    }
}
