//! The one reader of a user's file with a size cap: terrains, robots
//! files, lab scenarios, launch configs, key files, zenoh configs,
//! certificates and sweep outputs all read through it.
//!
//! Why: a wrong path (a recording, a log, `/dev/zero`, a FIFO) must not make
//! a tool read without end or build its memory from it. A regular file
//! larger than the cap is refused from its length before anything is read;
//! anything else (a device, a pipe, a file the file system does not size)
//! is read up to one byte past the cap and refused there. In the protocol
//! crate (feature `std`, no dependencies) so that its own readers (a
//! robot's key file, a zenoh config, a certificate) use it; the other
//! crates reach it as `bycoms_runtime::capped` too.

use std::io::Read;
use std::path::Path;

/// Why a capped read failed.
#[derive(Debug)]
pub enum CappedError {
    /// The operating system's error (a missing file, no permission).
    Io(std::io::Error),
    /// More bytes than the cap.
    TooLarge {
        /// The size, when the file system knew it before reading.
        size: Option<u64>,
        /// The cap, bytes.
        limit: u64,
    },
    /// The bytes are not UTF-8 text.
    NotText,
}

impl core::fmt::Display for CappedError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            CappedError::Io(e) => write!(f, "{e}"),
            CappedError::TooLarge { size: Some(size), limit } => {
                write!(f, "{size} bytes, more than the limit of {limit} bytes")
            }
            CappedError::TooLarge { size: None, limit } => {
                write!(f, "more than the limit of {limit} bytes")
            }
            CappedError::NotText => write!(f, "not UTF-8 text"),
        }
    }
}

impl core::error::Error for CappedError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            CappedError::Io(e) => Some(e),
            _ => None,
        }
    }
}

impl From<std::io::Error> for CappedError {
    fn from(e: std::io::Error) -> Self {
        CappedError::Io(e)
    }
}

/// The text of a stream, refusing more than `limit` bytes (reads at most
/// one byte past it).
pub fn read_capped(reader: impl Read, limit: u64) -> Result<String, CappedError> {
    text(read_capped_bytes(reader, limit)?)
}

/// The bytes of a stream, refusing more than `limit` (reads at most one
/// byte past it).
pub fn read_capped_bytes(reader: impl Read, limit: u64) -> Result<Vec<u8>, CappedError> {
    let mut bytes = Vec::new();
    reader.take(limit.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(CappedError::TooLarge { size: None, limit });
    }
    Ok(bytes)
}

/// The text of the file at `path`, refusing more than `limit` bytes: a
/// regular file from its length before anything is read, anything else
/// (`/dev/zero`, a pipe) one byte past the cap.
pub fn read_capped_file(path: &Path, limit: u64) -> Result<String, CappedError> {
    text(read_capped_file_bytes(path, limit)?)
}

/// The bytes of the file at `path` (a certificate), capped as
/// [`read_capped_file`] caps its text.
pub fn read_capped_file_bytes(path: &Path, limit: u64) -> Result<Vec<u8>, CappedError> {
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if meta.is_file() && meta.len() > limit {
        return Err(CappedError::TooLarge { size: Some(meta.len()), limit });
    }
    read_capped_bytes(file, limit)
}

fn text(bytes: Vec<u8>) -> Result<String, CappedError> {
    String::from_utf8(bytes).map_err(|_| CappedError::NotText)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_device_without_end_a_large_file_and_binary_bytes_are_refused() {
        let e = read_capped_file(Path::new("/dev/zero"), 1024).expect_err("endless");
        assert!(matches!(e, CappedError::TooLarge { size: None, limit: 1024 }), "{e}");
        let dir = tempfile::tempdir().expect("temp dir");
        let big = dir.path().join("big");
        std::fs::File::create(&big).and_then(|f| f.set_len(5000)).expect("sparse file");
        let e = read_capped_file(&big, 1024).expect_err("too large");
        assert_eq!(e.to_string(), "5000 bytes, more than the limit of 1024 bytes");
        let small = dir.path().join("small");
        std::fs::write(&small, "robots = 3\n").expect("write");
        assert_eq!(read_capped_file(&small, 1024).expect("read"), "robots = 3\n");
        assert!(matches!(read_capped(&[0xff, 0xfe][..], 10), Err(CappedError::NotText)));
        assert!(matches!(read_capped_file(&dir.path().join("none"), 10), Err(CappedError::Io(_))));
    }
}
