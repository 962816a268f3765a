//! The lab's robots file: which robot answers on which UDP address, where
//! its gateway listens, and its key (`deploy/lab/robots.toml`).
//!
//! Why one file for both ends: the emulated lab (`sim-agent lab`) binds each
//! robot's address and sends to its gateway, and `orchestrator launch
//! --agents real` starts one `gateway` per robot on the gateway
//! address with the same key. A real lab writes the same file from its
//! robots' flashed settings; reading it in one place keeps the two ends from
//! drifting apart.

use bycoms_protocol::link::{KeyFileError, LinkKey};
use serde::Deserialize;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};

/// Largest robots file read, bytes (a lab has a handful of robots).
const MAX_FILE_LEN: u64 = 64 * 1024;

/// One robot's entry.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotEntry {
    /// Robot id: 1, 2, … in deployment order, each once, no gaps.
    pub id: u32,
    /// The robot's own UDP address (the emulated ESP32 binds it).
    pub address: SocketAddr,
    /// Where the robot's gateway listens (the robot sends there).
    pub gateway: SocketAddr,
    /// The robot's key file (64 hex digits), relative to the robots file.
    pub key_file: PathBuf,
}

/// The robots file.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotsFile {
    /// The robots, in id order after [`RobotsFile::read`].
    #[serde(rename = "robot")]
    pub robots: Vec<RobotEntry>,
    /// The directory key files are relative to.
    #[serde(skip)]
    pub dir: PathBuf,
}

/// Why a robots file or a key file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum RobotsError {
    /// The file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The file is larger than any sane robots file, or not text.
    #[error("cannot read robots file {}: {source}; is this a robots file?", path.display())]
    Unusable {
        /// The file.
        path: PathBuf,
        /// What is wrong with it (its size, bytes that are not text).
        source: bycoms_runtime::capped::CappedError,
    },
    /// The TOML is malformed or has unknown keys.
    #[error("bad robots file {}: {source}", path.display())]
    Toml {
        /// The file.
        path: PathBuf,
        /// Where and what.
        source: toml::de::Error,
    },
    /// The ids are not 1..=n each once.
    #[error("bad robots file {}: robot ids must be 1, 2, … each once; found {found:?}", path.display())]
    Ids {
        /// The file.
        path: PathBuf,
        /// The ids found, sorted.
        found: Vec<u32>,
    },
    /// A robot's address or its gateway's has port 0: both are fixed
    /// (flashed into the robot), never "any free port".
    #[error("bad robots file {}: robot {robot}'s {key} = \"{addr}\" has port 0; give its fixed port", path.display())]
    PortZero {
        /// The file.
        path: PathBuf,
        /// The robot.
        robot: u32,
        /// `address` or `gateway`.
        key: &'static str,
        /// The address given.
        addr: SocketAddr,
    },
    /// An address is used twice.
    #[error("bad robots file {}: {why}", path.display())]
    Address {
        /// The file.
        path: PathBuf,
        /// Which robot, which address, what is wrong.
        why: String,
    },
    /// A key file is unreadable or does not hold 64 hex digits (the
    /// link's reader, `LinkKey::read_file`, as the gateway's).
    #[error(transparent)]
    Key(#[from] KeyFileError),
}

/// The file's text through the one capped reader ([`bycoms_runtime::capped`]).
fn read_limited(path: &Path) -> Result<String, RobotsError> {
    use bycoms_runtime::capped::{read_capped_file, CappedError};
    read_capped_file(path, MAX_FILE_LEN).map_err(|e| match e {
        CappedError::Io(source) => RobotsError::Read { path: path.to_path_buf(), source },
        source => RobotsError::Unusable { path: path.to_path_buf(), source },
    })
}

impl RobotsFile {
    /// Reads and checks a robots file; robots come back sorted by id.
    pub fn read(path: &Path) -> Result<Self, RobotsError> {
        let text = read_limited(path)?;
        let mut file: RobotsFile =
            toml::from_str(&text).map_err(|source| RobotsError::Toml { path: path.to_path_buf(), source })?;
        file.robots.sort_by_key(|r| r.id);
        let found: Vec<u32> = file.robots.iter().map(|r| r.id).collect();
        if found.is_empty() || found.iter().enumerate().any(|(i, &id)| id as usize != i + 1) {
            return Err(RobotsError::Ids { path: path.to_path_buf(), found });
        }
        file.check_ports(path)?;
        if let Some(why) = file.address_refused() {
            return Err(RobotsError::Address { path: path.to_path_buf(), why });
        }
        file.dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Ok(file)
    }

    /// Refuses an `address` or `gateway` of port 0 (the first, in id order).
    fn check_ports(&self, path: &Path) -> Result<(), RobotsError> {
        let zero = self.robots.iter().find_map(|r| {
            [("address", r.address), ("gateway", r.gateway)]
                .into_iter()
                .find(|(_, addr)| addr.port() == 0)
                .map(|(key, addr)| (r.id, key, addr))
        });
        match zero {
            Some((robot, key, addr)) => {
                Err(RobotsError::PortZero { path: path.to_path_buf(), robot, key, addr })
            }
            None => Ok(()),
        }
    }

    /// An address used twice, naming both robots and the address (issue
    /// 49): each robot's address and each gateway's is its own socket.
    fn address_refused(&self) -> Option<String> {
        let mut seen = std::collections::BTreeMap::new();
        for r in &self.robots {
            for (what, addr) in [("address", r.address), ("gateway", r.gateway)] {
                if let Some((id, other)) = seen.insert(addr, (r.id, what)) {
                    return Some(format!("robot {}'s {what} {addr} is also robot {id}'s {other}", r.id));
                }
            }
        }
        None
    }

    /// A robot's key file path (relative paths are the file's directory's).
    pub fn key_path(&self, robot: &RobotEntry) -> PathBuf {
        self.dir.join(&robot.key_file)
    }

    /// Every robot's key, in id order.
    pub fn keys(&self) -> Result<Vec<LinkKey>, RobotsError> {
        self.robots.iter().map(|r| Ok(LinkKey::read_file(&self.key_path(r))?)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    const ROBOT: &str = "address = \"127.0.0.1:47101\"\ngateway = \"127.0.0.1:47001\"\nkey_file = \"k1\"\n";

    #[test]
    fn reads_robots_and_keys_relative_to_the_file() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "k1", &format!("{}\n", "ab".repeat(32)));
        let two = ROBOT.replace("k1", "k2").replace("471", "472").replace("470", "480");
        write(dir.path(), "k2", &"01".repeat(32));
        let p = write(dir.path(), "r.toml", &format!("[[robot]]\nid = 2\n{two}[[robot]]\nid = 1\n{ROBOT}"));
        let f = RobotsFile::read(&p).unwrap();
        assert_eq!(f.robots.iter().map(|r| r.id).collect::<Vec<_>>(), [1, 2]);
        assert_eq!(f.robots[0].gateway, "127.0.0.1:47001".parse().unwrap());
        assert_eq!(f.keys().unwrap().len(), 2);
    }

    #[test]
    fn bad_files_are_refused_with_a_reason() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "k1", "not a key");
        let cases = [
            (format!("[[robot]]\nid = 2\n{ROBOT}"), "robot ids must be 1, 2"),
            (format!("[[robot]]\nid = 1\n{ROBOT}[[robot]]\nid = 1\n{ROBOT}"), "robot ids must be 1, 2"),
            (format!("[[robot]]\nid = 1\ncolour = 3\n{ROBOT}"), "unknown field"),
            ("[[robot]]\nid = 1\naddress = \"nowhere\"\n".to_string(), "bad robots file"),
            (
                format!("[[robot]]\nid = 1\n{}", ROBOT.replace("127.0.0.1:47101", "127.0.0.1:0")),
                "robot 1's address = \"127.0.0.1:0\" has port 0; give its fixed port",
            ),
            (
                format!("[[robot]]\nid = 1\n{}", ROBOT.replace("127.0.0.1:47001", "[::1]:0")),
                "robot 1's gateway = \"[::1]:0\" has port 0",
            ),
            // Issue 49: the robot and the address are named.
            (
                format!(
                    "[[robot]]\nid = 1\n{ROBOT}[[robot]]\nid = 2\n{}",
                    ROBOT.replace("k1", "k2").replace("47001", "47002")
                ),
                "robot 2's address 127.0.0.1:47101 is also robot 1's address",
            ),
            (
                format!("[[robot]]\nid = 1\n{ROBOT}[[robot]]\nid = 2\n{}", ROBOT.replace("47101", "47102")),
                "robot 2's gateway 127.0.0.1:47001 is also robot 1's gateway",
            ),
        ];
        for (text, why) in cases {
            let p = write(dir.path(), "r.toml", &text);
            let e = RobotsFile::read(&p).unwrap_err().to_string();
            assert!(e.contains(why), "{text}: {e}");
        }
        let p = write(dir.path(), "r.toml", &format!("[[robot]]\nid = 1\n{ROBOT}"));
        let e = RobotsFile::read(&p).unwrap().keys().unwrap_err().to_string();
        assert!(e.contains("64 hexadecimal digits"), "{e}");
        // Endless or huge files are refused without being read whole.
        let e = RobotsFile::read(Path::new("/dev/zero")).unwrap_err().to_string();
        assert!(e.contains("/dev/zero: more than the limit of 65536 bytes"), "{e}");
        assert!(RobotsFile::read(&dir.path().join("missing.toml"))
            .unwrap_err()
            .to_string()
            .contains("cannot read"));
    }
}
