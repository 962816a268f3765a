//! Key expressions over many topics, and the way back from a topic name to
//! what it carries.
//!
//! Why here: zenoh subscribers can use wildcards, and tools that watch a
//! whole swarm (the bridge, monitors, `deploy/clients/watch.py`) must spell
//! the pattern exactly like the names of [`super`]. `bycoms/<swarm>/**`
//! matches every topic of one swarm. [`Swarm::route`] reads a received
//! name back into its [`Route`], so a watcher knows which message type to
//! decode without a table of its own.

use super::{NameBuf, Swarm, ROOT, TOPIC_NAME_MAX};
use crate::RobotId;
use core::fmt::Write as _;

/// A key expression that may contain zenoh wildcards (`*`, `**`), built
/// only by this module. Stored inline (no allocation).
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct KeyPattern {
    pub(super) bytes: [u8; TOPIC_NAME_MAX],
    pub(super) len: usize,
}

impl KeyPattern {
    /// The pattern as text, e.g. `bycoms/lab-1/**`.
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(&self.bytes[..self.len]).unwrap_or("")
    }
}

impl core::fmt::Display for KeyPattern {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl core::fmt::Debug for KeyPattern {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "KeyPattern({:?})", self.as_str())
    }
}

/// Which topic of a swarm a name is, and so which message it carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Route {
    /// `robot/<id>/to_agent`: [`crate::msg::ToAgent`].
    ToAgent(RobotId),
    /// `robot/<id>/sensor`: [`crate::msg::Sensor`].
    Sensor(RobotId),
    /// `robot/<id>/pose`: [`crate::msg::Pose`].
    Pose(RobotId),
    /// `robot/<id>/from_agent`: [`crate::msg::FromAgent`].
    FromAgent(RobotId),
    /// `gate`: [`crate::msg::GateEvent`].
    Gate,
    /// `operator`: [`crate::msg::Deploy`] (place a robot).
    Operator,
}

impl Swarm {
    /// `bycoms/<swarm>/**`: every topic of this swarm (a zenoh key
    /// expression; iceoryx2 has no wildcards).
    pub fn everything(&self) -> KeyPattern {
        let mut buf = NameBuf { bytes: [0u8; TOPIC_NAME_MAX], len: 0 };
        // Root (6) + swarm (≤ 64) + "/**" fits TOPIC_NAME_MAX; a test pins it.
        let _fits = write!(buf, "{ROOT}/{}/**", self.as_str()).is_ok();
        KeyPattern { bytes: buf.bytes, len: buf.len }
    }

    /// The topic that `name` is within this swarm, or `None` when it is
    /// not one of this swarm's topics (another swarm, an unknown leaf, a
    /// robot id that is not a decimal `u32`).
    pub fn route(&self, name: &str) -> Option<Route> {
        let rest = name.strip_prefix(ROOT)?.strip_prefix('/')?;
        let rest = rest.strip_prefix(self.as_str())?.strip_prefix('/')?;
        match rest {
            "gate" => return Some(Route::Gate),
            "operator" => return Some(Route::Operator),
            _ => {}
        }
        let rest = rest.strip_prefix("robot/")?;
        let (id, leaf) = rest.split_once('/')?;
        if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) || (id.len() > 1 && id.starts_with('0')) {
            return None;
        }
        let robot = RobotId(id.parse().ok()?);
        match leaf {
            "to_agent" => Some(Route::ToAgent(robot)),
            "sensor" => Some(Route::Sensor(robot)),
            "pose" => Some(Route::Pose(robot)),
            "from_agent" => Some(Route::FromAgent(robot)),
            _ => None,
        }
    }
}
