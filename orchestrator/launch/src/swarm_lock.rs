//! One live launch per swarm name.
//!
//! Why: a swarm name is the namespace of every topic of a launch. Two live
//! launches under one name would share their robots' command and pose
//! topics and silently corrupt each other (robots deployed twice, poses of
//! one run judged by the other). So a launch takes an exclusive lock on
//! the swarm before it touches the bus and holds it until it ends; a second
//! launch of a live swarm is refused with the first one's pid (a usage
//! error, exit 2: nothing has started). The lock is an OS file lock
//! (`flock`), so it goes away with its process however that process ends,
//! even by `kill -9`: a dead launch never blocks the name, and its
//! shared-memory leftovers are cleaned when the next launch opens the bus,
//! as before.
//!
//! Where: the lock must be exactly as shared as the bus. iceoryx2's
//! segments live in the machine's shared memory (`/dev/shm`), which every
//! process sees whatever its `TMPDIR` and also under systemd's
//! `PrivateTmp=yes`; a lock in the temporary directory let a launch with
//! another `TMPDIR` run on top of a live swarm. So the lock file is
//! `/dev/shm/bycoms-swarm.[<tag>.]<swarm>.lock`, keyed like the bus: an
//! iceoryx2 isolation tag (`BYCOMS_IPC_ISOLATION`, `bus::ipc::root`) gives
//! a bus of its own, so the same swarm name under another tag is another
//! swarm. Without `/dev/shm` (not Linux) it falls back to the temporary
//! directory. Swarm names and tags are letters, digits, `-` and `_`, so the
//! dots keep the two apart.
//!
//! The file is removed when the launch ends. A launch that locked a file
//! which was removed meanwhile (the previous owner ending between our open
//! and our lock) would hold a lock nobody else sees, so after locking it
//! checks that the path still names the file it locked, and starts over if
//! not.
//!
//! A launch killed with `kill -9` cannot remove its file; nor could one
//! ended by SIGQUIT before that signal was handled. Such a file locks
//! nothing (its lock went with its process), but it stayed in `/dev/shm`
//! until a launch of the same swarm name came (seventeen after one
//! session of tests under many names). So every launch first sweeps the
//! lock files of every swarm and tag ([`sweep`]): a file that no process
//! holds is removed as its owner would have removed it (locked, then
//! removed, so a launch that opened it meanwhile notices, as above). The
//! iceoryx2 files of dead processes are removed by the bus when it opens
//! (`bus::ipc::cleanup_stale_resources`, every dead node of the tag's
//! root, whatever its swarm).

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

/// The machine's shared memory, where iceoryx2 keeps its segments.
const SHARED_MEMORY: &str = "/dev/shm";

/// The directory of the swarm lock files: the machine's shared memory, or
/// the temporary directory where there is none.
pub fn lock_dir() -> PathBuf {
    let shm = Path::new(SHARED_MEMORY);
    if shm.is_dir() {
        shm.to_path_buf()
    } else {
        std::env::temp_dir().join("bycoms-swarms")
    }
}

/// The lock file's name of `swarm` on the bus of isolation tag `tag`.
pub fn lock_name(tag: Option<&str>, swarm: &str) -> String {
    match tag {
        Some(tag) => format!("bycoms-swarm.{tag}.{swarm}.lock"),
        None => format!("bycoms-swarm.{swarm}.lock"),
    }
}

impl SwarmLock {
    /// Locks `swarm` on this process's bus (its isolation tag, from the
    /// environment) for this process, or says who holds it.
    pub fn acquire(swarm: &str) -> Result<Self, SwarmLockError> {
        let tag = bycoms_protocol::bus::ipc::root::tag_from_env();
        Self::acquire_in(&lock_dir(), &lock_name(tag.as_deref(), swarm), swarm)
    }

    /// [`Self::acquire`] as an error of the launch: a swarm in use is a
    /// usage error (exit 2), refused before anything started.
    pub fn for_launch(swarm: &str) -> anyhow::Result<Self> {
        Self::acquire(swarm).map_err(|e| match e {
            SwarmLockError::InUse { .. } => bycoms_runtime::exit::usage(e),
            SwarmLockError::Io { .. } => e.into(),
        })
    }

    /// [`Self::acquire`] with the lock file `dir/name`, after a [`sweep`]
    /// of `dir`.
    pub fn acquire_in(dir: &Path, name: &str, swarm: &str) -> Result<Self, SwarmLockError> {
        let path = dir.join(name);
        let io = |source| SwarmLockError::Io { swarm: swarm.to_string(), path: path.clone(), source };
        std::fs::create_dir_all(dir).map_err(io)?;
        let swept = sweep(dir);
        if swept > 0 {
            tracing::debug!(dir = %dir.display(), swept, "removed the lock files of swarms whose launch was killed");
        }
        loop {
            let opened = OpenOptions::new().read(true).write(true).create(true).truncate(false).open(&path);
            let (mut file, writable) = match opened {
                Ok(file) => (file, true),
                // Another user's lock file (the shared memory is every
                // user's): `flock` needs no write access to lock it.
                Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => {
                    (File::open(&path).map_err(io)?, false)
                }
                Err(e) => return Err(io(e)),
            };
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
            if writable {
                file.set_len(0).map_err(io)?;
                file.rewind().map_err(io)?;
                write!(file, "{}", std::process::id()).map_err(io)?;
            }
            return Ok(Self { file, path });
        }
    }
}

/// Whether `name` is a swarm lock file's name ([`lock_name`]).
fn is_lock_name(name: &str) -> bool {
    name.starts_with("bycoms-swarm.") && name.ends_with(".lock")
}

/// Removes from `dir` the lock files no process holds (left by launches
/// that were killed); returns how many. Files that cannot be opened or
/// removed (another user's) are left alone.
pub fn sweep(dir: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    let mut removed = 0;
    for entry in entries.flatten() {
        if !entry.file_name().to_str().is_some_and(is_lock_name) {
            continue;
        }
        let path = entry.path();
        let Ok(file) = File::open(&path) else { continue };
        // Held: a live launch's. Free: its owner is gone.
        if file.try_lock().is_err() {
            continue;
        }
        // Removed while locked, as `Drop` does: a launch that opened the
        // file meanwhile sees that the path no longer names it.
        if std::fs::remove_file(&path).is_ok() {
            removed += 1;
            // And its control socket (`orchestrator/launch/src/control.rs`), if it left one.
            let _ = std::fs::remove_file(path.with_extension("sock"));
        }
        let _ = file.unlock();
    }
    removed
}

/// Whether a live process holds the lock file at `path` (a launch runs).
pub fn is_held(path: &Path) -> bool {
    let Ok(file) = File::open(path) else { return false };
    match file.try_lock() {
        Ok(()) => {
            let _ = file.unlock();
            false
        }
        Err(TryLockError::WouldBlock) => true,
        Err(TryLockError::Error(_)) => false,
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
        let lock = |swarm: &str| SwarmLock::acquire_in(dir.path(), &lock_name(None, swarm), swarm);
        let first = lock("s1").expect("first lock");
        match lock("s1") {
            Err(SwarmLockError::InUse { swarm, owner }) => {
                assert_eq!((swarm.as_str(), owner), ("s1", Some(std::process::id())));
            }
            other => panic!("second lock of a held swarm: {other:?}"),
        }
        let other_name = lock("s2").expect("another name is free");
        drop(first);
        assert!(!dir.path().join(lock_name(None, "s1")).exists(), "the lock file is removed");
        let again = lock("s1").expect("free after release");
        drop((again, other_name));
    }

    #[test]
    fn the_files_of_killed_launches_are_swept_by_a_launch_of_any_name() {
        let dir = tempfile::tempdir().expect("temp dir");
        let lock = |swarm: &str| SwarmLock::acquire_in(dir.path(), &lock_name(None, swarm), swarm);
        // A launch killed with `kill -9`: its file stays, locked by nobody.
        for (tag, swarm) in [(None, "killed"), (Some("ci-3"), "quit")] {
            std::fs::write(dir.path().join(lock_name(tag, swarm)), "4194305").expect("leftover");
        }
        let live = lock("live").expect("a live launch");
        std::fs::write(dir.path().join("other.lock"), "").expect("not a swarm's");
        let next = lock("next").expect("a launch of another name");
        let mut names: Vec<String> = std::fs::read_dir(dir.path())
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(
            names,
            [lock_name(None, "live"), lock_name(None, "next"), "other.lock".to_string()],
            "the leftovers are gone, the live launches' files and others' stay"
        );
        match lock("live") {
            Err(SwarmLockError::InUse { owner, .. }) => assert_eq!(owner, Some(std::process::id())),
            other => panic!("the live swarm is still held: {other:?}"),
        }
        drop((live, next));
    }

    #[test]
    fn the_lock_is_where_the_bus_is_keyed_like_the_bus() {
        // iceoryx2's segments are in /dev/shm on Linux: so is the lock,
        // whatever TMPDIR says.
        if Path::new(SHARED_MEMORY).is_dir() {
            assert_eq!(lock_dir(), Path::new("/dev/shm"));
        }
        assert_eq!(lock_name(None, "lab"), "bycoms-swarm.lab.lock");
        assert_eq!(lock_name(Some("ci-1"), "lab"), "bycoms-swarm.ci-1.lab.lock");
    }

    #[test]
    fn a_swarm_in_use_is_a_usage_error() {
        let swarm = format!("usage-{}", std::process::id());
        let _held = SwarmLock::acquire(&swarm).expect("lock");
        let err = SwarmLock::for_launch(&swarm).expect_err("in use");
        assert_eq!(bycoms_runtime::exit::code_of(&err), bycoms_runtime::exit::USAGE, "{err:#}");
    }
}
