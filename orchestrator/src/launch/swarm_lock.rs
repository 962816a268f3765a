//! One live launch per swarm name.
//!
//! Why: a swarm name is the namespace of every topic of a launch. Two live
//! launches under one name would share their robots' command and pose
//! topics and silently corrupt each other (robots deployed twice, poses of
//! one run judged by the other). So a launch takes an exclusive lock on
//! `<temp dir>/bycoms-swarms/<swarm>.lock` before it touches the bus and
//! holds it until it ends; a second launch of a live swarm is refused with
//! the first one's pid. The lock is an OS file lock (`flock`), so it goes
//! away with its process however that process ends, even by `kill -9`: a
//! dead launch never blocks the name, and its shared-memory leftovers are
//! cleaned when the next launch opens the bus, as before.
//!
//! The file is removed when the launch ends. A launch that locked a file
//! which was removed meanwhile (the previous owner ending between our open
//! and our lock) would hold a lock nobody else sees, so after locking it
//! checks that the path still names the file it locked, and starts over if
//! not.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// Why a swarm could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum SwarmLockError {
    /// Another live launch holds the swarm.
    #[error(
        "swarm {swarm:?} is in use by a running launch{}; wait for it to end or pick another --swarm",
        owner.map(|p| format!(" (orchestrator pid {p})")).unwrap_or_default()
    )]
    InUse {
        /// The swarm name.
        swarm: String,
        /// The pid written by the owner, if it could be read.
        owner: Option<u32>,
    },
    /// The lock file could not be created or locked.
    #[error("cannot lock swarm {swarm:?} ({}): {source}", path.display())]
    Io {
        /// The swarm name.
        swarm: String,
        /// The lock file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
}

/// The held lock of one swarm name; released (and its file removed) on drop.
#[derive(Debug)]
pub struct SwarmLock {
    file: File,
    path: PathBuf,
}

/// The directory of the swarm lock files.
pub fn lock_dir() -> PathBuf {
    std::env::temp_dir().join("bycoms-swarms")
}

impl SwarmLock {
    /// Locks `swarm` for this process, or says who holds it.
    pub fn acquire(swarm: &str) -> Result<Self, SwarmLockError> {
        Self::acquire_in(&lock_dir(), swarm)
    }

    /// [`Self::acquire`] with the lock files in `dir`.
    pub fn acquire_in(dir: &Path, swarm: &str) -> Result<Self, SwarmLockError> {
        let path = dir.join(format!("{swarm}.lock"));
        let io = |source| SwarmLockError::Io { swarm: swarm.to_string(), path: path.clone(), source };
        std::fs::create_dir_all(dir).map_err(io)?;
        loop {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(io)?;
            match file.try_lock() {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => {
                    let mut text = String::new();
                    let owner = file.read_to_string(&mut text).ok().and_then(|_| text.trim().parse().ok());
                    return Err(SwarmLockError::InUse { swarm: swarm.to_string(), owner });
                }
                Err(TryLockError::Error(e)) => return Err(io(e)),
            }
            // Still the file the path names? (See the module docs.)
            let locked = file.metadata().map_err(io)?;
            match std::fs::metadata(&path) {
                Ok(now) if now.ino() == locked.ino() && now.dev() == locked.dev() => {}
                _ => continue,
            }
            file.set_len(0).map_err(io)?;
            file.rewind().map_err(io)?;
            write!(file, "{}", std::process::id()).map_err(io)?;
            return Ok(Self { file, path });
        }
    }
}

impl Drop for SwarmLock {
    fn drop(&mut self) {
        // Remove while still locked, so nobody locks the file being removed
        // without noticing (they re-check the path after locking).
        let _ = std::fs::remove_file(&self.path);
        let _ = self.file.unlock();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_swarm_is_refused_with_its_owner_and_free_again_once_released() {
        let dir = tempfile::tempdir().expect("temp dir");
        let first = SwarmLock::acquire_in(dir.path(), "s1").expect("first lock");
        match SwarmLock::acquire_in(dir.path(), "s1") {
            Err(SwarmLockError::InUse { swarm, owner }) => {
                assert_eq!((swarm.as_str(), owner), ("s1", Some(std::process::id())));
            }
            other => panic!("second lock of a held swarm: {other:?}"),
        }
        let other_name = SwarmLock::acquire_in(dir.path(), "s2").expect("another name is free");
        drop(first);
        assert!(!dir.path().join("s1.lock").exists(), "the lock file is removed");
        let again = SwarmLock::acquire_in(dir.path(), "s1").expect("free after release");
        drop((again, other_name));
    }
}
