//! A robot's key file: the 32-byte pre-shared key as 64 hexadecimal
//! digits (surrounding whitespace allowed), e.g. `deploy/lab/keys/robot-1.key`.
//!
//! Why here, with the link: both ends of a lab read key files — the real
//! robot's `gateway` (`--key-file`) and the emulated lab and the
//! launch (from the lab's robots file) — and the gateway must not depend on
//! the simulator to read one. One reader keeps the format and its errors
//! the same everywhere.

use super::LinkKey;
use crate::capped::{read_capped_file, CappedError};
use std::path::{Path, PathBuf};

/// Largest key file read, bytes (a key is 64 digits and a newline; room
/// for surrounding whitespace). Read through the one capped reader: a key
/// file that is `/dev/zero` is refused one byte past it.
pub const MAX_KEY_FILE_LEN: u64 = 1024;

/// Why a key file could not be used.
#[derive(Debug)]
pub enum KeyFileError {
    /// The file could not be read.
    Read {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The file is larger than any key file, or not text.
    Unusable {
        /// The file.
        path: PathBuf,
        /// Its size past the cap, or bytes that are not text.
        source: CappedError,
    },
    /// The file does not hold 64 hex digits.
    NotAKey {
        /// The file.
        path: PathBuf,
    },
}

impl core::fmt::Display for KeyFileError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Read { path, source } => write!(f, "cannot read {}: {source}", path.display()),
            Self::Unusable { path, source } => write!(f, "bad key file {}: {source}", path.display()),
            Self::NotAKey { path } => {
                write!(f, "bad key file {}: expected 64 hexadecimal digits (a 32-byte key)", path.display())
            }
        }
    }
}

impl core::error::Error for KeyFileError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Self::Read { source, .. } => Some(source),
            Self::Unusable { source, .. } => Some(source),
            Self::NotAKey { .. } => None,
        }
    }
}

impl LinkKey {
    /// Reads a key file: 64 hex digits, surrounding whitespace allowed.
    pub fn read_file(path: &Path) -> Result<Self, KeyFileError> {
        let text = read_capped_file(path, MAX_KEY_FILE_LEN).map_err(|e| match e {
            CappedError::Io(source) => KeyFileError::Read { path: path.to_path_buf(), source },
            source => KeyFileError::Unusable { path: path.to_path_buf(), source },
        })?;
        Self::from_hex(&text).ok_or_else(|| KeyFileError::NotAKey { path: path.to_path_buf() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_file_is_64_hex_digits_and_errors_name_the_file() {
        let dir = std::env::temp_dir().join(format!("bycoms-key-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.key");
        std::fs::write(&good, format!("  {}\n", "ab".repeat(32))).unwrap();
        assert!(LinkKey::read_file(&good).is_ok());
        let bad = dir.join("bad.key");
        std::fs::write(&bad, "not a key").unwrap();
        let e = LinkKey::read_file(&bad).unwrap_err().to_string();
        assert!(e.contains("64 hexadecimal digits") && e.contains("bad.key"), "{e}");
        let e = LinkKey::read_file(&dir.join("missing.key")).unwrap_err().to_string();
        assert!(e.starts_with("cannot read") && e.contains("missing.key"), "{e}");
        let e = LinkKey::read_file(Path::new("/dev/zero")).unwrap_err().to_string();
        assert_eq!(e, "bad key file /dev/zero: more than the limit of 1024 bytes");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
