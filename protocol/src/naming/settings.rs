//! The name of the run's settings: where an agent asks the orchestrator
//! what to run.
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

use super::{NameBuf, Swarm, TopicName, ROOT, TOPIC_NAME_MAX};
use core::fmt::Write as _;

impl Swarm {
    /// `bycoms/<swarm>/settings`: the key the orchestrator answers with the
    /// run's encoded settings.
    pub fn settings(&self) -> TopicName {
        let mut buf = NameBuf { bytes: [0u8; TOPIC_NAME_MAX], len: 0 };
        // Root (6) + swarm (≤ 64) + "/settings" fits TOPIC_NAME_MAX, and
        // every character is valid; a test pins the longest case.
        let written = write!(buf, "{ROOT}/{}/settings", self.as_str()).is_ok();
        let text = core::str::from_utf8(&buf.bytes[..buf.len]).unwrap_or("");
        match (written, TopicName::parse(text)) {
            (true, Ok(name)) => name,
            _ => unreachable!("the settings key of a valid swarm is valid"),
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
    }
}
