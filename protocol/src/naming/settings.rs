//! The names of what the orchestrator answers when asked: the run's
//! settings (where an agent asks what to run) and its clock (where an
//! agent or `doctor` measures its clock offset).
//!
//! Why a name of its own, outside the message topics: the settings (the
//! terrain's text, ε, the seed, ...) do not fit a bus message (payloads are
//! at most one protocol message, ≤ 64 bytes), and they are asked for, not
//! published: over zenoh the orchestrator declares a queryable on this key
//! and an agent started with only its swarm and robot id queries it (see
//! `bus::zenoh`'s `settings` module). The key follows the same character
//! rules as every topic:
//!
//! | what | name |
//! |---|---|
//! | the run's settings (zenoh queryable) | `bycoms/<swarm>/settings` |
//! | the orchestrator's clock (zenoh queryable) | `bycoms/<swarm>/clock` |

use super::{NameBuf, Swarm, TopicName, ROOT, TOPIC_NAME_MAX};
use core::fmt::Write as _;

impl Swarm {
    /// `bycoms/<swarm>/settings`: the key the orchestrator answers with the
    /// run's encoded settings.
    pub fn settings(&self) -> TopicName {
        self.asked("settings")
    }

    /// `bycoms/<swarm>/clock`: the key the orchestrator answers with its
    /// clock (`bus::zenoh::clock`).
    pub fn clock(&self) -> TopicName {
        self.asked("clock")
    }

    fn asked(&self, leaf: &str) -> TopicName {
        let mut buf = NameBuf { bytes: [0u8; TOPIC_NAME_MAX], len: 0 };
        // Root (6) + swarm (≤ 64) + "/settings" fits TOPIC_NAME_MAX, and
        // every character is valid; a test pins the longest case.
        let written = write!(buf, "{ROOT}/{}/{leaf}", self.as_str()).is_ok();
        let text = core::str::from_utf8(&buf.bytes[..buf.len]).unwrap_or("");
        match (written, TopicName::parse(text)) {
            (true, Ok(name)) => name,
            _ => unreachable!("the settings and clock keys of a valid swarm are valid"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::naming::SWARM_NAME_MAX;

    #[test]
    fn the_settings_key() {
        let s = Swarm::new("lab-1").expect("swarm");
        assert_eq!(s.settings().as_str(), "bycoms/lab-1/settings");
        // Not a liveliness token, not a robot's topic.
        assert_eq!(s.member_of(s.settings().as_str()), None);
        let longest = Swarm::new(&"s".repeat(SWARM_NAME_MAX)).expect("swarm");
        assert!(longest.settings().as_str().ends_with("/settings"));
        assert_eq!(s.clock().as_str(), "bycoms/lab-1/clock");
        assert_eq!(s.member_of(s.clock().as_str()), None);
        assert!(longest.clock().as_str().ends_with("/clock"));
    }
}
