//! Where iceoryx2 keeps its files, and how long it waits for another process.
//!
//! Why this exists: iceoryx2's files — the node and service directories
//! under its root path and the shared-memory segments named with its prefix
//! — are machine-wide. Every run on a host sees every dead node that any
//! other run left behind, so a test suite is not hermetic and two unrelated
//! deployments on one host can meet. An *isolation tag* gives a run its own
//! root path and prefix: nothing of one tag is visible to another. The tag
//! comes from [`IpcConfig::isolation`](super::IpcConfig::isolation) or, for
//! whole process trees (an orchestrator and the agents it spawns inherit
//! it), from the environment variable [`ISOLATION_ENV`].
//!
//! Every configuration also waits longer than iceoryx2's default of one
//! second for a service that another process is creating: on a loaded
//! 2-core machine that second ran out and a launch failed with
//! `ServiceConfigCouldNotBeCreated`. And every subscriber keeps room for
//! [`EXPIRED_CONNECTIONS`] departed publishers' last samples, not
//! iceoryx2's default 128: each slot is about 3.6 KB of resident memory per
//! subscription, and an agent subscribes to every earlier robot's pose
//! (measured: 694 KB per subscription at 50 robots before, 247 KB after).
//!
//! The roots are in the machine's shared memory (`/dev/shm`, a memory file
//! system, where iceoryx2 keeps its segments too), not in the temporary
//! directory ([`files_dir`]): every port a process opens creates a few
//! small files under the root, and on a disk file system that cost more
//! than anything else in starting agents (issue 35: on this project's
//! machine `/tmp` is ext4 without a journal, whose inode allocation scans
//! the recently deleted inodes; half the CPU of starting 200 agents, and
//! 1000 agents started in 11.6–15.8 s there, 7.3–9.3 s in `/dev/shm`).
//! Files and segments now also go together: a reboot removes both.

use crate::bus::BusError;
use core::time::Duration;
use iceoryx2::prelude::{FileName, Path, SemanticString};

/// iceoryx2's configuration type (to list nodes under a root, for instance).
pub use iceoryx2::prelude::Config;

/// Environment variable with the isolation tag of a process tree.
pub const ISOLATION_ENV: &str = "BYCOMS_IPC_ISOLATION";

/// iceoryx2's built-in machine-wide root path (its `ICEORYX2_ROOT_PATH` on
/// Linux), replaced by [`files_dir`]'s unless its configuration file sets
/// another.
const ICEORYX2_DEFAULT_ROOT: &str = "/tmp/iceoryx2/";

/// Longest a tag may be (it becomes part of file names).
pub const MAX_TAG_LEN: usize = 48;

/// How long a process waits for a service another process is creating.
pub const CREATION_TIMEOUT: Duration = Duration::from_secs(10);

/// Departed publishers whose last samples a subscriber keeps (iceoryx2's
/// `subscriber_expired_connection_buffer`, default 128; at least its
/// `subscriber_max_borrowed_samples`, 2). A publisher that leaves is an
/// agent that ended: a launch reads its last pose long before four more
/// have left.
pub const EXPIRED_CONNECTIONS: usize = 4;

/// The isolation tag of this process: [`ISOLATION_ENV`] if set and not empty.
pub fn tag_from_env() -> Option<String> {
    std::env::var(ISOLATION_ENV).ok().filter(|t| !t.is_empty())
}

/// Where the roots go: `/dev/shm` where there is one (Linux), else the
/// temporary directory (see the module's docs for why).
pub fn files_dir() -> std::path::PathBuf {
    let shm = std::path::Path::new("/dev/shm");
    if shm.is_dir() {
        shm.to_path_buf()
    } else {
        std::env::temp_dir()
    }
}

/// Root directory of tag `tag`.
pub fn root_dir(tag: &str) -> std::path::PathBuf {
    files_dir().join("bycoms-iox2").join(tag)
}

/// The machine-wide root (no tag) when iceoryx2's configuration keeps its
/// built-in one (`/tmp/iceoryx2/`); a root set in its configuration file
/// is kept.
fn machine_root_dir() -> std::path::PathBuf {
    files_dir().join("iceoryx2")
}

/// `dir` as iceoryx2's root path (with its trailing `/`).
fn root_path(dir: &std::path::Path, what: &'static str) -> Result<Path, BusError> {
    let mut root = dir.to_string_lossy().into_owned();
    root.push('/');
    Path::new(root.as_bytes()).map_err(|e| BusError::backend(what, None, e))
}

/// File-name prefix of tag `tag` (its shared-memory segments start with it).
pub fn prefix(tag: &str) -> String {
    format!("iox2_{tag}_")
}

/// The iceoryx2 configuration for `tag`: the machine-wide one without a tag.
pub fn config(tag: Option<&str>) -> Result<Config, BusError> {
    let mut config = Config::global_config().clone();
    config.global.creation_timeout = CREATION_TIMEOUT;
    config.defaults.publish_subscribe.subscriber_expired_connection_buffer = EXPIRED_CONNECTIONS;
    let Some(tag) = tag else {
        // Compared as bytes: building a `Config::default()` to compare
        // with cost every agent ~160 KB more resident (anonymous) memory
        // (`bench scale`, 1000 agents: 1429 → 1249 KB each).
        if config.global.root_path().as_bytes() == ICEORYX2_DEFAULT_ROOT.as_bytes() {
            config.global.set_root_path(&root_path(&machine_root_dir(), "machine-wide root path")?);
        }
        return Ok(config);
    };
    let valid = tag.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_');
    if tag.is_empty() || tag.len() > MAX_TAG_LEN || !valid {
        return Err(BusError::InvalidConfig(
            "an iceoryx2 isolation tag has 1 to 48 letters, digits, '-' or '_'",
        ));
    }
    config.global.set_root_path(&root_path(&root_dir(tag), "isolation root path")?);
    config.global.prefix =
        FileName::new(prefix(tag).as_bytes()).map_err(|e| BusError::backend("isolation prefix", None, e))?;
    Ok(config)
}

/// Removes everything iceoryx2 left under tag `tag`: its root directory and
/// its shared-memory segments. For the end of a test run or a deployment,
/// when no process of the tag is left.
pub fn remove(tag: &str) -> std::io::Result<()> {
    match std::fs::remove_dir_all(root_dir(tag)) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(e),
    }
    let prefix = prefix(tag);
    let Ok(shm) = std::fs::read_dir("/dev/shm") else { return Ok(()) };
    for entry in shm.flatten() {
        if entry.file_name().to_string_lossy().starts_with(&prefix) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
    Ok(())
}

/// An isolation tag that removes its files when dropped (tests).
#[derive(Debug)]
pub struct Isolated {
    tag: String,
}

impl Isolated {
    /// A fresh tag from `name`, this process's id and a counter.
    pub fn new(name: &str) -> Self {
        use core::sync::atomic::{AtomicU32, Ordering};
        static NEXT: AtomicU32 = AtomicU32::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let name: String = name.chars().filter(char::is_ascii_alphanumeric).take(24).collect();
        let tag = format!("{name}-{}-{n}", std::process::id());
        let _ = remove(&tag);
        Self { tag }
    }

    /// The tag.
    pub fn tag(&self) -> &str {
        &self.tag
    }
}

impl Drop for Isolated {
    fn drop(&mut self) {
        if let Err(e) = remove(&self.tag) {
            // Tests only; the protocol crate has no logger of its own.
            eprintln!("could not remove the iceoryx2 files of isolation tag {}: {e}", self.tag);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_are_checked_and_give_their_own_root_and_prefix() {
        let c = config(Some("abc-1")).expect("valid tag");
        assert!(c.global.root_path().to_string().contains("bycoms-iox2/abc-1"), "{:?}", c.global.root_path());
        assert_eq!(c.global.prefix.to_string(), "iox2_abc-1_");
        assert_eq!(c.global.creation_timeout, CREATION_TIMEOUT);
        for bad in ["", "a/b", "a b", &"x".repeat(49)] {
            assert!(config(Some(bad)).is_err(), "{bad:?} accepted");
        }
        let plain = config(None).expect("global");
        assert_eq!(plain.global.prefix, Config::global_config().global.prefix);
        if std::path::Path::new("/dev/shm").is_dir() {
            // Both roots in shared memory, not on a disk's /tmp.
            assert!(c.global.root_path().to_string().starts_with("/dev/shm/bycoms-iox2/"));
            assert_eq!(plain.global.root_path().to_string(), "/dev/shm/iceoryx2/");
        }
    }
}
