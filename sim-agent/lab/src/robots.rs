//! The lab's robots file: which robot answers on which UDP address, where
//! its gateway listens, and its key (`deploy/lab/robots.toml`); or, for a
//! ROS 2 ground robot (`kind = "ros2"`), its `cmd_vel` topic, message
//! type, limits and wheel base (`deploy/lab/ros2-robots.toml`).
//!
//! Why one file for both ends: the emulated lab (`sim-agent lab`) binds each
//! robot's address and sends to its gateway, and `orchestrator launch
//! --agents real` starts one `gateway` per robot on the gateway
//! address with the same key. A real lab writes the same file from its
//! robots' flashed settings; reading it in one place keeps the two ends from
//! drifting apart.

use bycoms_agent::wheeled::Limits;
use bycoms_protocol::link::{KeyFileError, LinkKey};
use bycoms_ros2::velocity::VelocityMessage;
use serde::Deserialize;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Largest robots file read, bytes (a lab has a handful of robots).
const MAX_FILE_LEN: u64 = 64 * 1024;

/// One acoustic robot's entry (`kind = "acoustic"`, the default).
#[derive(Clone, Debug, PartialEq, Eq)]
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

/// One ROS 2 ground robot's entry (`kind = "ros2"`).
#[derive(Clone, Debug, PartialEq)]
pub struct Ros2Entry {
    /// Robot id, as an acoustic robot's.
    pub id: u32,
    /// Its velocity topic (`None`: `<namespace>/robot_<id>/cmd_vel`).
    pub cmd_vel: Option<String>,
    /// The message its driver takes (`message`, default `twist`).
    pub message: VelocityMessage,
    /// The frame of a `TwistStamped`'s header (`frame_id`, default `base_link`).
    pub frame_id: String,
    /// `max_linear` (m/s), `max_angular` (rad/s), `wheel_base` (m); each
    /// defaults to a TurtleBot 3 Burger's.
    pub limits: Limits,
    /// Its driver stops the robot after this long without a command
    /// (`cmd_vel_timeout`, seconds, default 0.5): what the emulated lab's
    /// body does, and what the docs ask a lab to set on its driver.
    pub cmd_vel_timeout: Duration,
}

impl Ros2Entry {
    /// Its `cmd_vel` topic: the one given, else
    /// `<namespace>/robot_<id>/cmd_vel` (`/robot_<id>/cmd_vel` in the root
    /// namespace `/`).
    pub fn topic(&self, namespace: &str) -> String {
        let default = || format!("{}/robot_{}/cmd_vel", namespace.trim_end_matches('/'), self.id);
        self.cmd_vel.clone().unwrap_or_else(default)
    }
}

/// The robots file.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotsFile {
    /// The acoustic robots, in id order after [`RobotsFile::read`].
    pub robots: Vec<RobotEntry>,
    /// The ROS 2 robots, in id order.
    pub ros2: Vec<Ros2Entry>,
    /// The simulated members of a mixed swarm (`kind = "sim"`), in id
    /// order: robots the lab does not have, simulated in its arena.
    pub sim: Vec<u32>,
    /// The directory key files are relative to.
    pub dir: PathBuf,
}

/// The file as written: `[[robot]]` tables of either kind.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    robot: Vec<RawEntry>,
}

/// The kinds of robot a robots file declares.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// The paper's crawler with our firmware, behind its gateway.
    #[default]
    Acoustic,
    /// A ROS 2 ground robot driven by `cmd_vel`.
    Ros2,
    /// A simulated member of a mixed swarm: a `sim-agent` in the lab's
    /// arena, sensing the same virtual field as the ROS 2 robots.
    Sim,
}

/// One `[[robot]]` table as written: every key of either kind, checked
/// against its kind by [`RawEntry::typed`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEntry {
    id: u32,
    #[serde(default)]
    kind: Kind,
    address: Option<SocketAddr>,
    gateway: Option<SocketAddr>,
    key_file: Option<PathBuf>,
    cmd_vel: Option<String>,
    message: Option<String>,
    frame_id: Option<String>,
    max_linear: Option<f64>,
    max_angular: Option<f64>,
    wheel_base: Option<f64>,
    cmd_vel_timeout: Option<f64>,
}

/// A typed entry of either kind.
enum Typed {
    Acoustic(RobotEntry),
    Ros2(Ros2Entry),
    Sim(u32),
}

impl RawEntry {
    /// The entry of its kind, or why not (a key of the other kind, a
    /// missing or unusable one), naming the robot.
    fn typed(self) -> Result<Typed, String> {
        let id = self.id;
        match self.kind {
            Kind::Acoustic => {
                let other = [("cmd_vel", self.cmd_vel.is_some()), ("message", self.message.is_some())]
                    .into_iter()
                    .chain([("frame_id", self.frame_id.is_some()), ("max_linear", self.max_linear.is_some())])
                    .chain([
                        ("max_angular", self.max_angular.is_some()),
                        ("wheel_base", self.wheel_base.is_some()),
                    ])
                    .chain([("cmd_vel_timeout", self.cmd_vel_timeout.is_some())]);
                refuse_keys(id, "acoustic", other)?;
                let need = |what: &str| format!("robot {id} (an acoustic robot) needs `{what}`");
                Ok(Typed::Acoustic(RobotEntry {
                    id,
                    address: self.address.ok_or_else(|| need("address"))?,
                    gateway: self.gateway.ok_or_else(|| need("gateway"))?,
                    key_file: self.key_file.ok_or_else(|| need("key_file"))?,
                }))
            }
            Kind::Ros2 => self.ros2().map(Typed::Ros2),
            Kind::Sim => self.sim().map(Typed::Sim),
        }
    }

    /// A simulated member: its id and nothing else.
    fn sim(self) -> Result<u32, String> {
        let keys = [("address", self.address.is_some()), ("gateway", self.gateway.is_some())]
            .into_iter()
            .chain([("key_file", self.key_file.is_some()), ("cmd_vel", self.cmd_vel.is_some())])
            .chain([("message", self.message.is_some()), ("frame_id", self.frame_id.is_some())])
            .chain([("max_linear", self.max_linear.is_some()), ("max_angular", self.max_angular.is_some())])
            .chain([("wheel_base", self.wheel_base.is_some())])
            .chain([("cmd_vel_timeout", self.cmd_vel_timeout.is_some())]);
        refuse_keys(self.id, "sim", keys)?;
        Ok(self.id)
    }

    fn ros2(self) -> Result<Ros2Entry, String> {
        let id = self.id;
        let other = [("address", self.address.is_some()), ("gateway", self.gateway.is_some())];
        refuse_keys(id, "ros2", other.into_iter().chain([("key_file", self.key_file.is_some())]))?;
        let message = match self.message {
            Some(word) => word.parse().map_err(|e| format!("robot {id}'s message: {e}"))?,
            None => VelocityMessage::Twist,
        };
        let burger = Limits::TURTLEBOT3_BURGER;
        let limits = Limits {
            linear: self.max_linear.unwrap_or(burger.linear),
            angular: self.max_angular.unwrap_or(burger.angular),
            wheel_base: self.wheel_base.unwrap_or(burger.wheel_base),
        };
        limits.check().map_err(|e| format!("robot {id}: {e} (max_linear, max_angular, wheel_base)"))?;
        let timeout = self.cmd_vel_timeout.unwrap_or(0.5);
        let cmd_vel_timeout =
            Duration::try_from_secs_f64(timeout).ok().filter(|t| !t.is_zero()).ok_or_else(|| {
                format!("robot {id}'s cmd_vel_timeout must be a positive number of seconds, got {timeout}")
            })?;
        if let Some(topic) = &self.cmd_vel {
            if !bycoms_ros2::rmw_zenoh::is_fully_qualified(topic, false) {
                return Err(format!(
                    "robot {id}'s cmd_vel {topic:?} is not a ROS 2 topic (`/a/b`: letters, digits, `_`)"
                ));
            }
        }
        let frame_id = self.frame_id.unwrap_or_else(|| "base_link".into());
        Ok(Ros2Entry { id, cmd_vel: self.cmd_vel, message, frame_id, limits, cmd_vel_timeout })
    }
}

/// A key of another kind's, refused naming the robot and the key.
fn refuse_keys<'a>(
    id: u32,
    kind: &str,
    keys: impl IntoIterator<Item = (&'a str, bool)>,
) -> Result<(), String> {
    match keys.into_iter().find(|(_, given)| *given) {
        Some((key, _)) => Err(format!("robot {id} is of kind {kind:?}, which takes no `{key}`")),
        None => Ok(()),
    }
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
    /// A robot's keys do not fit its kind.
    #[error("bad robots file {}: {why}", path.display())]
    Entry {
        /// The file.
        path: PathBuf,
        /// Which robot, which key, what is wrong.
        why: String,
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
        let raw: RawFile =
            toml::from_str(&text).map_err(|source| RobotsError::Toml { path: path.to_path_buf(), source })?;
        let mut found: Vec<u32> = raw.robot.iter().map(|r| r.id).collect();
        found.sort_unstable();
        if found.is_empty() || found.iter().enumerate().any(|(i, &id)| id as usize != i + 1) {
            return Err(RobotsError::Ids { path: path.to_path_buf(), found });
        }
        let mut file =
            RobotsFile { robots: Vec::new(), ros2: Vec::new(), sim: Vec::new(), dir: PathBuf::new() };
        for entry in raw.robot {
            match entry.typed().map_err(|why| RobotsError::Entry { path: path.to_path_buf(), why })? {
                Typed::Acoustic(r) => file.robots.push(r),
                Typed::Ros2(r) => file.ros2.push(r),
                Typed::Sim(id) => file.sim.push(id),
            }
        }
        file.robots.sort_by_key(|r| r.id);
        file.ros2.sort_by_key(|r| r.id);
        file.sim.sort_unstable();
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

    /// The one kind of real robot the file declares (beside any simulated
    /// members), `Sim` when all are simulated, or `None` when it mixes
    /// acoustic and ROS 2 robots.
    pub fn kind(&self) -> Option<Kind> {
        match (self.robots.is_empty(), self.ros2.is_empty()) {
            (false, true) => Some(Kind::Acoustic),
            (true, false) => Some(Kind::Ros2),
            (true, true) => Some(Kind::Sim),
            (false, false) => None,
        }
    }

    /// Whether robot `id` is a simulated member (`kind = "sim"`).
    pub fn is_simulated(&self, id: u32) -> bool {
        self.sim.binary_search(&id).is_ok()
    }

    /// Robots in the file, of every kind.
    pub fn len(&self) -> usize {
        self.robots.len() + self.ros2.len() + self.sim.len()
    }

    /// Whether the file names no robot (never, once read).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every acoustic robot's key, in id order.
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
    fn ros2_robots_take_their_defaults_and_the_file_says_its_kind() {
        let dir = tempfile::tempdir().unwrap();
        let text =
            "[[robot]]\nid = 2\nkind = \"ros2\"\nmessage = \"twist-stamped\"\ncmd_vel = \"/tb3/cmd_vel\"\n\
                    max_linear = 0.1\ncmd_vel_timeout = 0.25\n[[robot]]\nid = 1\nkind = \"ros2\"\n";
        let f = RobotsFile::read(&write(dir.path(), "r.toml", text)).unwrap();
        assert_eq!(f.kind(), Some(Kind::Ros2));
        assert!(f.robots.is_empty());
        let burger = Limits::TURTLEBOT3_BURGER;
        let first = Ros2Entry {
            id: 1,
            cmd_vel: None,
            message: VelocityMessage::Twist,
            frame_id: "base_link".into(),
            limits: burger,
            cmd_vel_timeout: Duration::from_millis(500),
        };
        assert_eq!(f.ros2[0], first);
        assert_eq!(f.ros2[1].message, VelocityMessage::TwistStamped);
        assert_eq!(f.ros2[1].cmd_vel.as_deref(), Some("/tb3/cmd_vel"));
        assert_eq!(f.ros2[1].limits, Limits { linear: 0.1, ..burger });
        assert_eq!(f.ros2[1].cmd_vel_timeout, Duration::from_millis(250));
        assert_eq!(
            (f.ros2[0].topic("/"), f.ros2[0].topic("/lab/")),
            ("/robot_1/cmd_vel".into(), "/lab/robot_1/cmd_vel".into())
        );
        assert_eq!(f.ros2[1].topic("/lab"), "/tb3/cmd_vel");
        // Ids run across both kinds; a mixed file has no one kind.
        let mixed = format!("[[robot]]\nid = 1\n{ROBOT}[[robot]]\nid = 2\nkind = \"ros2\"\n");
        let f = RobotsFile::read(&write(dir.path(), "m.toml", &mixed)).unwrap();
        assert_eq!((f.robots.len(), f.ros2.len(), f.kind()), (1, 1, None));
    }

    #[test]
    fn simulated_members_stand_beside_ros2_robots_and_take_no_keys() {
        let dir = tempfile::tempdir().unwrap();
        let text = "[[robot]]\nid = 1\nkind = \"sim\"\n[[robot]]\nid = 2\nkind = \"ros2\"\n\
                    [[robot]]\nid = 3\nkind = \"sim\"\n";
        let f = RobotsFile::read(&write(dir.path(), "mixed.toml", text)).unwrap();
        assert_eq!((f.sim.clone(), f.ros2.len(), f.len()), (vec![1, 3], 1, 3));
        assert_eq!(f.kind(), Some(Kind::Ros2), "the kind of its real robots");
        assert!(f.is_simulated(1) && !f.is_simulated(2) && f.is_simulated(3));
        let all =
            RobotsFile::read(&write(dir.path(), "all.toml", "[[robot]]\nid = 1\nkind = \"sim\"\n")).unwrap();
        assert_eq!(all.kind(), Some(Kind::Sim));
        let keyed = "[[robot]]\nid = 1\nkind = \"sim\"\nmax_linear = 0.2\n";
        let err = RobotsFile::read(&write(dir.path(), "keyed.toml", keyed)).unwrap_err().to_string();
        assert!(err.contains("robot 1 is of kind \"sim\", which takes no `max_linear`"), "{err}");
    }

    #[test]
    fn bad_files_are_refused_with_a_reason() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "k1", "not a key");
        let cases = [
            (format!("[[robot]]\nid = 2\n{ROBOT}"), "robot ids must be 1, 2"),
            (format!("[[robot]]\nid = 1\n{ROBOT}[[robot]]\nid = 1\n{ROBOT}"), "robot ids must be 1, 2"),
            (format!("[[robot]]\nid = 1\ncolour = 3\n{ROBOT}"), "unknown field"),
            (
                format!("[[robot]]\nid = 1\nwheel_base = 0.2\n{ROBOT}"),
                "robot 1 is of kind \"acoustic\", which takes no `wheel_base`",
            ),
            ("[[robot]]\nid = 1\nkind = \"ros2\"\ngateway = \"127.0.0.1:1\"\n".into(), "takes no `gateway`"),
            (
                "[[robot]]\nid = 1\nkind = \"ros2\"\nmessage = \"Twist\"\n".into(),
                "robot 1's message: \"Twist\" is not a velocity message",
            ),
            (
                "[[robot]]\nid = 1\nkind = \"ros2\"\nwheel_base = 0.0\n".into(),
                "robot 1: the wheel base must be a positive",
            ),
            (
                "[[robot]]\nid = 1\nkind = \"ros2\"\ncmd_vel_timeout = -1\n".into(),
                "cmd_vel_timeout must be a positive",
            ),
            ("[[robot]]\nid = 1\nkind = \"ros2\"\ncmd_vel = \"cmd vel\"\n".into(), "is not a ROS 2 topic"),
            ("[[robot]]\nid = 1\nkind = \"tank\"\n".into(), "unknown variant `tank`"),
            (
                "[[robot]]\nid = 1\naddress = \"127.0.0.1:47101\"\n".into(),
                "robot 1 (an acoustic robot) needs `gateway`",
            ),
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
