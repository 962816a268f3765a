//! Topic names, in one place, valid for both iceoryx2 and zenoh.
//!
//! Why one place: a process that spells a topic differently would publish
//! into the void without any error. Every name is therefore built here,
//! per swarm and per robot:
//!
//! | topic | name | message |
//! |---|---|---|
//! | orchestrator → agent | `bycoms/<swarm>/robot/<id>/to_agent` | [`ToAgent`] |
//! | world/sensor → agent | `bycoms/<swarm>/robot/<id>/sensor` | [`Sensor`] |
//! | mocap → orchestrator | `bycoms/<swarm>/robot/<id>/pose` | [`Pose`] |
//! | agent → orchestrator | `bycoms/<swarm>/robot/<id>/from_agent` | [`FromAgent`] |
//! | gate events | `bycoms/<swarm>/gate` | [`GateEvent`] |
//! | orchestrator → lab operator | `bycoms/<swarm>/operator` | [`Deploy`] (place robot at) |
//!
//! `<id>` is the decimal [`RobotId`]. A [`Topic<M>`] carries its message
//! type, so the typed bus layer cannot put a pose on a command topic.
//!
//! Why a report topic per robot: over zenoh the access control is by key,
//! so robot k's certificate may publish only under `robot/<k>/`, and a
//! report whose robot id is not its topic's is forged. The orchestrator
//! still waits on all reports and poses at once (a bus fan-in).
//!
//! Why doorbells: on iceoryx2 every wake-up service is a handful of open
//! files in each process that opens it, and the orchestrator opens every
//! robot's topics. So the robots' topics of one kind share one wake-up,
//! their [`TopicName::doorbell`]: `from_agent` rings
//! `bycoms/<swarm>/from_agents`, `pose` rings `bycoms/<swarm>/poses`,
//! `to_agent` and `sensor` ring `bycoms/<swarm>/to_agents` (an agent waits
//! on both), each ring carrying the robot id
//! ([`TopicName::doorbell_member`]) so that only that robot's readers and
//! the fan-ins of the whole family are woken.
//!
//! Character rules (enforced by [`TopicName::parse`] and [`Swarm::new`]):
//! a name is 1..=[`TOPIC_NAME_MAX`] bytes of chunks separated by single
//! `/`; no leading, trailing or doubled `/`; every chunk is made of ASCII
//! letters, digits, `-` and `_` only. A swarm name is one such chunk of at
//! most [`SWARM_NAME_MAX`] bytes. This is the intersection of the two
//! transports' rules: iceoryx2 service names must be non-empty ASCII
//! without NUL of at most 255 bytes and not start with `iox2://`; zenoh key
//! expressions forbid empty chunks and give `*`, `$`, `#`, `?` and `@`
//! special meaning. Spaces and everything else are rejected too, so a name
//! is also a safe file name component and needs no quoting in a shell.

use crate::msg::{Deploy, FromAgent, GateEvent, Pose, Sensor, ToAgent};
use crate::RobotId;
use core::fmt::Write as _;
use core::marker::PhantomData;

/// Longest topic name, bytes (well under iceoryx2's 255).
pub const TOPIC_NAME_MAX: usize = 128;
/// Longest swarm name, bytes.
pub const SWARM_NAME_MAX: usize = 64;
/// First chunk of every BYCOMS topic.
pub const ROOT: &str = "bycoms";

/// Why a name was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NameError {
    /// The name is empty.
    Empty,
    /// The name is longer than allowed.
    TooLong {
        /// Its length in bytes.
        len: usize,
        /// The limit.
        max: usize,
    },
    /// A character outside `[A-Za-z0-9_-]` (and `/` between chunks).
    InvalidChar {
        /// The offending character.
        ch: char,
        /// Its byte offset in the name.
        at: usize,
    },
    /// A leading, trailing or doubled `/`.
    EmptyChunk,
}

impl core::fmt::Display for NameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Empty => write!(f, "name is empty"),
            Self::TooLong { len, max } => write!(f, "name is {len} bytes long, at most {max}"),
            Self::InvalidChar { ch, at } => write!(
                f,
                "invalid character {ch:?} at byte {at}: only ASCII letters, digits, '-' and '_' are allowed"
            ),
            Self::EmptyChunk => write!(f, "name has an empty '/'-separated chunk"),
        }
    }
}

impl core::error::Error for NameError {}

fn is_chunk_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '-' || c == '_'
}

/// A validated topic name, stored inline (no allocation).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct TopicName {
    bytes: [u8; TOPIC_NAME_MAX],
    len: usize,
}

impl TopicName {
    /// Validates `name` against the character rules of this module.
    pub fn parse(name: &str) -> Result<Self, NameError> {
        if name.is_empty() {
            return Err(NameError::Empty);
        }
        if name.len() > TOPIC_NAME_MAX {
            return Err(NameError::TooLong { len: name.len(), max: TOPIC_NAME_MAX });
        }
        let mut chunk_len = 0;
        for (at, ch) in name.char_indices() {
            if ch == '/' {
                if chunk_len == 0 {
                    return Err(NameError::EmptyChunk);
                }
                chunk_len = 0;
            } else if is_chunk_char(ch) {
                chunk_len += 1;
            } else {
                return Err(NameError::InvalidChar { ch, at });
            }
        }
        if chunk_len == 0 {
            return Err(NameError::EmptyChunk);
        }
        let mut bytes = [0u8; TOPIC_NAME_MAX];
        bytes[..name.len()].copy_from_slice(name.as_bytes());
        Ok(Self { bytes, len: name.len() })
    }

    /// The name as text.
    pub fn as_str(&self) -> &str {
        // Only validated ASCII is ever stored, so this cannot fail; fall back
        // to "" rather than panic.
        core::str::from_utf8(&self.bytes[..self.len]).unwrap_or("")
    }

    /// The wake-up this topic's publishers ring and its readers wait on:
    /// the robots' topics of one kind share one (see the module docs):
    /// `bycoms/<swarm>/robot/<id>/from_agent` rings
    /// `bycoms/<swarm>/from_agents`, `…/pose` rings `bycoms/<swarm>/poses`,
    /// `…/to_agent` and `…/sensor` ring `bycoms/<swarm>/to_agents`; every
    /// other topic is its own doorbell.
    /// (iceoryx2 uses it as the topic's event service; backends that wake
    /// their readers otherwise ignore it.)
    pub fn doorbell(&self) -> TopicName {
        match self.family() {
            Some((swarm, _, bell)) => {
                let mut buf = NameBuf { bytes: [0u8; TOPIC_NAME_MAX], len: 0 };
                // Shorter than `self` (which is valid): cannot fail.
                let written = write!(buf, "{swarm}/{bell}").is_ok();
                let text = core::str::from_utf8(&buf.bytes[..buf.len]).unwrap_or("");
                match (written, TopicName::parse(text)) {
                    (true, Ok(bell)) => bell,
                    _ => *self,
                }
            }
            None => *self,
        }
    }

    /// Which member of its doorbell's family this topic is: its robot id
    /// (a reader of the whole family learns from it which topic rang, and
    /// a ring wakes only that robot's readers); `None` for a topic that is
    /// its own doorbell.
    pub fn doorbell_member(&self) -> Option<u32> {
        self.family().and_then(|(_, id, _)| id.parse().ok())
    }

    /// `(bycoms/<swarm>, <id>, <doorbell leaf>)` of a robot's topic that
    /// belongs to a doorbell family.
    fn family(&self) -> Option<(&str, &str, &'static str)> {
        DOORBELLS.iter().find_map(|&(leaf, bell)| {
            let rest = self.as_str().strip_suffix(leaf)?;
            let (swarm, id) = rest.rsplit_once("/robot/")?;
            let valid =
                swarm.strip_prefix(ROOT).is_some_and(|s| s.starts_with('/') && s.matches('/').count() == 1)
                    && !id.is_empty()
                    && id.bytes().all(|b| b.is_ascii_digit());
            valid.then_some((swarm, id, bell))
        })
    }
}

/// A robot's topics that share a doorbell: (the topic's last chunk, with
/// its `/`, and the doorbell's).
const DOORBELLS: [(&str, &str); 4] = [
    ("/from_agent", "from_agents"),
    ("/pose", "poses"),
    ("/to_agent", "to_agents"),
    ("/sensor", "to_agents"),
];

impl core::fmt::Display for TopicName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl core::fmt::Debug for TopicName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "TopicName({:?})", self.as_str())
    }
}

/// Builds a name into an inline buffer, then validates it.
struct NameBuf {
    bytes: [u8; TOPIC_NAME_MAX],
    len: usize,
}

impl core::fmt::Write for NameBuf {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let end = self.len + s.len();
        let dst = self.bytes.get_mut(self.len..end).ok_or(core::fmt::Error)?;
        dst.copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

/// A topic name together with the message type it carries.
pub struct Topic<M> {
    name: TopicName,
    _message: PhantomData<fn() -> M>,
}

impl<M> Topic<M> {
    /// A typed topic under a raw name (validated). Prefer the [`Swarm`]
    /// constructors; this exists for tests and tools.
    pub fn new(name: TopicName) -> Self {
        Self { name, _message: PhantomData }
    }

    /// The topic's name.
    pub fn name(&self) -> &TopicName {
        &self.name
    }
}

impl<M> Clone for Topic<M> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<M> Copy for Topic<M> {}

impl<M> core::fmt::Debug for Topic<M> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "Topic({:?})", self.name.as_str())
    }
}

/// A validated swarm name: the namespace of one run's topics.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Swarm {
    name: TopicName,
}

impl Swarm {
    /// Validates a swarm name: one chunk of `[A-Za-z0-9_-]`, at most
    /// [`SWARM_NAME_MAX`] bytes.
    pub fn new(name: &str) -> Result<Self, NameError> {
        if name.len() > SWARM_NAME_MAX {
            return Err(NameError::TooLong { len: name.len(), max: SWARM_NAME_MAX });
        }
        if let Some(at) = name.find('/') {
            return Err(NameError::InvalidChar { ch: '/', at });
        }
        Ok(Self { name: TopicName::parse(name)? })
    }

    /// The swarm's name.
    pub fn as_str(&self) -> &str {
        self.name.as_str()
    }

    fn build<M>(&self, args: core::fmt::Arguments<'_>) -> Topic<M> {
        let mut buf = NameBuf { bytes: [0u8; TOPIC_NAME_MAX], len: 0 };
        // Root (6) + swarm (≤ 64) + "/robot/" + u32 (≤ 10) + suffix (≤ 9)
        // is < TOPIC_NAME_MAX and all characters are valid, so neither the
        // write nor the parse can fail; a test pins the longest case.
        let written = buf.write_fmt(args).is_ok();
        let text = core::str::from_utf8(&buf.bytes[..buf.len]).unwrap_or("");
        match (written, TopicName::parse(text)) {
            (true, Ok(name)) => Topic::new(name),
            _ => unreachable!("topic names built from a valid swarm are valid"),
        }
    }

    fn robot_topic<M>(&self, robot: RobotId, leaf: &str) -> Topic<M> {
        self.build(format_args!("{ROOT}/{}/robot/{}/{leaf}", self.as_str(), robot.0))
    }

    /// `bycoms/<swarm>/robot/<id>/to_agent`: orchestrator → agent.
    pub fn to_agent(&self, robot: RobotId) -> Topic<ToAgent> {
        self.robot_topic(robot, "to_agent")
    }

    /// `bycoms/<swarm>/robot/<id>/sensor`: world/sensor → agent.
    pub fn sensor(&self, robot: RobotId) -> Topic<Sensor> {
        self.robot_topic(robot, "sensor")
    }

    /// `bycoms/<swarm>/robot/<id>/pose`: mocap → orchestrator.
    pub fn pose(&self, robot: RobotId) -> Topic<Pose> {
        self.robot_topic(robot, "pose")
    }

    /// `bycoms/<swarm>/robot/<id>/from_agent`: one agent → orchestrator.
    pub fn from_agent(&self, robot: RobotId) -> Topic<FromAgent> {
        self.robot_topic(robot, "from_agent")
    }

    /// `bycoms/<swarm>/gate`: the deployment gate's events.
    pub fn gate(&self) -> Topic<GateEvent> {
        self.build(format_args!("{ROOT}/{}/gate", self.as_str()))
    }

    /// `bycoms/<swarm>/operator`: the orchestrator asks the lab's operator
    /// to place a robot at a pose (the start) before enabling it; a
    /// [`Deploy`] names the robot and the pose. Real robots only: a person
    /// reads the same request on the terminal, the emulated lab's operator
    /// reads it here.
    pub fn operator(&self) -> Topic<Deploy> {
        self.build(format_args!("{ROOT}/{}/operator", self.as_str()))
    }
}

impl core::fmt::Debug for Swarm {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "Swarm({:?})", self.as_str())
    }
}

mod alive;
mod keys;
mod settings;
pub use alive::Member;
pub use keys::{KeyPattern, Route};

#[cfg(test)]
mod tests;
