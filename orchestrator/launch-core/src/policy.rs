//! What the core does when an agent dies ([`OnDeath`]) and what a robot
//! whose agent never registers means ([`Missing`]): the launch config's
//! `gate.on_agent_death` and `supervision.missing`, the core's policies.
//!
//! Why here: the core decides by them and its setup carries them, so the
//! core owns them; the config (`bycoms_launch::config`) re-exports them
//! at their old path. Behind the `clap` feature they are command-line
//! values too (`--on-agent-death`, `--missing`).

use serde::{Deserialize, Serialize};

/// What the gate does when an agent process dies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum OnDeath {
    /// The robot is physically where it was last seen: a beacon; go on.
    Beacon,
    /// End the launch with an error.
    Abort,
}

/// What a robot whose agent never registers means (`supervision.missing`,
/// `--missing`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Missing {
    /// The robot is skipped at its turn (recorded as absent, with why) and
    /// the next one goes; a remote agent that registers later takes a
    /// later turn, a process started here that dies before registering is
    /// started once more first.
    #[default]
    Skip,
    /// The run needs every robot: agents that exist on their own are all
    /// awaited before the first deployment, and any robot whose agent never
    /// registers ends the launch with an error naming it (a run compared
    /// robot for robot with another, e.g. the paper's).
    Fail,
}
