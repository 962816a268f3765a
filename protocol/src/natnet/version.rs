//! The NatNet bitstream version a packet is laid out for.
//!
//! Why a file of its own: every part of the codec (`command.rs`,
//! `frame.rs`, `modeldef.rs`) reads it, and `mod.rs` uses them all (no
//! file cycles).

use super::Error;

/// A NatNet bitstream version (major.minor): the frame layout depends on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Version {
    /// Major version (4 for NatNet 4.x).
    pub major: u8,
    /// Minor version.
    pub minor: u8,
}

impl Version {
    /// NatNet 4.0 (Motive 3.0): no per-section byte sizes, no assets.
    pub const V4_0: Self = Self { major: 4, minor: 0 };
    /// NatNet 4.1 (Motive 3.1): per-section byte sizes and assets.
    pub const V4_1: Self = Self { major: 4, minor: 1 };

    /// Sections carry their byte size after their count (4.1+).
    pub(crate) fn has_sizes(self) -> bool {
        self >= Self::V4_1
    }

    /// Refuses layouts older than 4.0, which this codec does not speak.
    pub(crate) fn check(self) -> Result<(), Error> {
        if self.major < 4 {
            return Err(Error::UnsupportedVersion(self.major, self.minor));
        }
        Ok(())
    }
}
