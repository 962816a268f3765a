//! Names of the liveliness tokens: who of a swarm is alive.
//!
//! Why names of their own: a zenoh liveliness token is a key expression
//! that exists as long as the session declaring it is reachable; a watcher
//! learns of every token that appears (alive) and disappears (lost: undeclared,
//! process killed, or link cut past zenoh's lease). Each agent declares one
//! for its robot and the orchestrator one for itself, so the orchestrator
//! sees a lost agent and an agent sees a lost orchestrator, in well under a
//! second, without a heartbeat protocol of our own. The names follow the
//! same character rules as every topic (so they are valid iceoryx2 service
//! names too) and live under one prefix, so one pattern watches them all:
//!
//! | who | name |
//! |---|---|
//! | agent of robot `<id>` | `bycoms/<swarm>/alive/robot/<id>` |
//! | the orchestrator | `bycoms/<swarm>/alive/orchestrator` |
//! | everyone (pattern) | `bycoms/<swarm>/alive/**` |

use super::{KeyPattern, NameBuf, Swarm, TopicName, ROOT, TOPIC_NAME_MAX};
use crate::RobotId;
use core::fmt::Write as _;

/// Whose liveliness a token announces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Member {
    /// The orchestrator of the swarm.
    Orchestrator,
    /// The agent driving this robot.
    Agent(RobotId),
}

impl core::fmt::Display for Member {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Orchestrator => f.write_str("orchestrator"),
            Self::Agent(id) => write!(f, "agent of robot {}", id.0),
        }
    }
}

impl Swarm {
    fn alive_name(&self, args: core::fmt::Arguments<'_>) -> TopicName {
        let mut buf = NameBuf { bytes: [0u8; TOPIC_NAME_MAX], len: 0 };
        // Root (6) + swarm (≤ 64) + "/alive/robot/" + u32 (≤ 10) < 128 and
        // every character is valid; a test pins the longest case.
        let written = buf.write_fmt(args).is_ok();
        let text = core::str::from_utf8(&buf.bytes[..buf.len]).unwrap_or("");
        match (written, TopicName::parse(text)) {
            (true, Ok(name)) => name,
            _ => unreachable!("liveliness names built from a valid swarm are valid"),
        }
    }

    /// `bycoms/<swarm>/alive/robot/<id>`: the token of robot `id`'s agent.
    pub fn alive_agent(&self, robot: RobotId) -> TopicName {
        self.alive_name(format_args!("{ROOT}/{}/alive/robot/{}", self.as_str(), robot.0))
    }

    /// `bycoms/<swarm>/alive/orchestrator`: the orchestrator's token.
    pub fn alive_orchestrator(&self) -> TopicName {
        self.alive_name(format_args!("{ROOT}/{}/alive/orchestrator", self.as_str()))
    }

    /// The token name of `member`.
    pub fn alive(&self, member: Member) -> TopicName {
        match member {
            Member::Orchestrator => self.alive_orchestrator(),
            Member::Agent(robot) => self.alive_agent(robot),
        }
    }

    /// `bycoms/<swarm>/alive/**`: every liveliness token of the swarm.
    pub fn alive_everyone(&self) -> KeyPattern {
        let mut buf = NameBuf { bytes: [0u8; TOPIC_NAME_MAX], len: 0 };
        // Root (6) + swarm (≤ 64) + "/alive/**" fits TOPIC_NAME_MAX.
        let _fits = write!(buf, "{ROOT}/{}/alive/**", self.as_str()).is_ok();
        KeyPattern { bytes: buf.bytes, len: buf.len }
    }

    /// Whose token `name` is within this swarm; `None` for anything else
    /// (another swarm, a data topic, a robot id that is not a decimal
    /// `u32` without leading zeros).
    pub fn member_of(&self, name: &str) -> Option<Member> {
        let rest = name.strip_prefix(ROOT)?.strip_prefix('/')?;
        let rest = rest.strip_prefix(self.as_str())?.strip_prefix("/alive/")?;
        if rest == "orchestrator" {
            return Some(Member::Orchestrator);
        }
        let id = rest.strip_prefix("robot/")?;
        if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) || (id.len() > 1 && id.starts_with('0')) {
            return None;
        }
        Some(Member::Agent(RobotId(id.parse().ok()?)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::naming::SWARM_NAME_MAX;

    #[test]
    fn names_and_their_way_back() {
        let s = Swarm::new("lab-1").expect("swarm");
        assert_eq!(s.alive_agent(RobotId(7)).as_str(), "bycoms/lab-1/alive/robot/7");
        assert_eq!(s.alive_orchestrator().as_str(), "bycoms/lab-1/alive/orchestrator");
        assert_eq!(s.alive_everyone().as_str(), "bycoms/lab-1/alive/**");
        for member in [Member::Orchestrator, Member::Agent(RobotId(0)), Member::Agent(RobotId(u32::MAX))] {
            assert_eq!(s.member_of(s.alive(member).as_str()), Some(member));
        }
    }

    #[test]
    fn foreign_names_are_no_member() {
        let s = Swarm::new("lab-1").expect("swarm");
        for bad in [
            "bycoms/lab-2/alive/orchestrator",
            "bycoms/lab-1/robot/3/pose",
            "bycoms/lab-1/alive/robot/03",
            "bycoms/lab-1/alive/robot/",
            "bycoms/lab-1/alive/robot/4294967296",
            "bycoms/lab-1/alive/robot/3/x",
            "bycoms/lab-1/alive/other",
        ] {
            assert_eq!(s.member_of(bad), None, "{bad}");
        }
    }

    #[test]
    fn longest_names_fit() {
        let s = Swarm::new(&"s".repeat(SWARM_NAME_MAX)).expect("swarm");
        assert!(s.alive_agent(RobotId(u32::MAX)).as_str().ends_with("/alive/robot/4294967295"));
        assert!(s.alive_everyone().as_str().ends_with("/alive/**"));
    }
}
