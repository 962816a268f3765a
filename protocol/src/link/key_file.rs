//! A robot's key file: the 32-byte pre-shared key as 64 hexadecimal
//! digits (surrounding whitespace allowed), e.g. `deploy/lab/keys/robot-1.key`.
//!
//! Why here, with the link: both ends of a lab read key files — the real
//! robot's `gateway` (`--key-file`) and the emulated lab and the
//! launch (from the lab's robots file) — and the gateway must not depend on
//! the simulator to read one. One reader keeps the format and its errors
//! the same everywhere.

use super::LinkKey;
use std::path::{Path, PathBuf};

/// Largest key file read, bytes (a key is 64 digits and a newline).
pub const MAX_KEY_FILE_LEN: u64 = 64 * 1024;

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
    /// The file is larger than any key file.
    TooLarge {
        /// The file.
        path: PathBuf,
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
            Self::TooLarge { path } => {
                write!(f, "{} is larger than {MAX_KEY_FILE_LEN} bytes", path.display())
            }
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
            _ => None,
        }
    }
}

impl LinkKey {
    /// Reads a key file: 64 hex digits, surrounding whitespace allowed.
    pub fn read_file(path: &Path) -> Result<Self, KeyFileError> {
        let read = |source| KeyFileError::Read { path: path.to_path_buf(), source };
        let len = std::fs::metadata(path).map_err(read)?.len();
        if len > MAX_KEY_FILE_LEN {
            return Err(KeyFileError::TooLarge { path: path.to_path_buf() });
        }
        let text = std::fs::read_to_string(path).map_err(read)?;
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
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
