//! Which files a recording (or a recovered copy) may be written over.
//!
//! Why a rule at all: `--record run.mcap` after a typo (`--record
//! terrain.txt`) used to truncate whatever was there. The rule, checked
//! before anything starts:
//!
//! * no file there, or an empty one: write it (nothing can be lost);
//! * an MCAP file (it starts with the MCAP magic bytes): overwrite it only
//!   when asked to (`--force`), since it is somebody's recording;
//! * anything else (a terrain, a config, a directory, …): never, not even
//!   with `--force`: it is not ours to replace.

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Why a file must not be written over.
#[derive(Debug, thiserror::Error)]
pub enum TargetError {
    /// An existing recording, without `--force`.
    #[error("{} is already a recording; give --force to overwrite it", path.display())]
    Recording {
        /// The file.
        path: PathBuf,
    },
    /// Something that is not an MCAP recording.
    #[error("{} exists and is not an MCAP recording; refusing to overwrite it (even with --force)", path.display())]
    NotARecording {
        /// The file.
        path: PathBuf,
    },
    /// The file could not be inspected.
    #[error("cannot inspect {}: {source}", path.display())]
    Inspect {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
}

/// Checks that a recording may be written to `path` (see the module
/// documentation for the rule); `force` allows replacing a recording.
pub fn check_target(path: &Path, force: bool) -> Result<(), TargetError> {
    let inspect = |source| TargetError::Inspect { path: path.to_path_buf(), source };
    let meta = match std::fs::metadata(path) {
        Ok(meta) => meta,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(inspect(e)),
    };
    if !meta.is_file() {
        return Err(TargetError::NotARecording { path: path.to_path_buf() });
    }
    if meta.len() == 0 {
        return Ok(());
    }
    let mut head = [0u8; 8];
    let mut file = File::open(path).map_err(inspect)?;
    let n = file.read(&mut head).map_err(inspect)?;
    match (head.get(..n) == Some(mcap::MAGIC), force) {
        (true, true) => Ok(()),
        (true, false) => Err(TargetError::Recording { path: path.to_path_buf() }),
        (false, _) => Err(TargetError::NotARecording { path: path.to_path_buf() }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_and_empty_files_are_fine_recordings_need_force_and_others_are_refused() {
        let dir = tempfile::tempdir().expect("temp dir");
        let new = dir.path().join("new.mcap");
        assert!(check_target(&new, false).is_ok());
        std::fs::write(&new, b"").expect("empty");
        assert!(check_target(&new, false).is_ok(), "an empty file holds nothing");

        let rec = dir.path().join("old.mcap");
        let mut bytes = mcap::MAGIC.to_vec();
        bytes.extend_from_slice(b"rest of a recording");
        std::fs::write(&rec, bytes).expect("recording");
        let refused = check_target(&rec, false).expect_err("a recording without --force");
        assert!(matches!(refused, TargetError::Recording { .. }) && refused.to_string().contains("--force"));
        assert!(check_target(&rec, true).is_ok());

        let terrain = dir.path().join("terrain.txt");
        std::fs::write(&terrain, b"....#...\n").expect("terrain");
        for force in [false, true] {
            let refused = check_target(&terrain, force).expect_err("not a recording");
            assert!(matches!(refused, TargetError::NotARecording { .. }), "{refused}");
        }
        assert!(matches!(check_target(dir.path(), true), Err(TargetError::NotARecording { .. })));
        let short = dir.path().join("short");
        std::fs::write(&short, [0x89, b'M']).expect("short");
        assert!(check_target(&short, true).is_err(), "a prefix of the magic is not a recording");
    }
}
