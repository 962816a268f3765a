//! The launch's own JSON channels in a recording, each with a JSON schema:
//! the run's metadata (`bycoms/<swarm>/run`), the agents' comings and
//! goings (`bycoms/<swarm>/events`) and the summary
//! (`bycoms/<swarm>/summary`, [`super::Summary`]).
//!
//! Why typed and not `json!`: a channel's schema comes from the type
//! (`schemars`, like the scene's JSON channels in `bycoms_record::scene::json`), so
//! what is written and what the schema says cannot drift, and Foxglove or
//! any script reads the fields by name.

use super::summary::Point;
use schemars::JsonSchema;
use serde::Serialize;

/// Schema names of the run metadata, events and summary channels (defined
/// with every other schema name in `bycoms_record::schema`).
pub use bycoms_record::schema::{EVENT as EVENT_SCHEMA, RUN as RUN_SCHEMA, SUMMARY as SUMMARY_SCHEMA};

/// An agent's events (the launch core's outputs, owned there).
pub use bycoms_launch_core::events::{EventKind, LaunchEvent};

/// The run's metadata, written first: enough to draw and replay the run.
#[derive(Clone, Debug, Serialize, JsonSchema)]
pub struct RunMeta<'a> {
    /// The swarm name (topic namespace).
    pub swarm: &'a str,
    /// Where the terrain came from (a file or a built-in scenario).
    pub terrain: &'a str,
    /// The terrain in the text format.
    pub terrain_text: &'a str,
    /// The start.
    #[schemars(with = "Point")]
    pub start: bycoms_sim::Vec2,
    /// The goal.
    #[schemars(with = "Point")]
    pub goal: bycoms_sim::Vec2,
    /// The launch configuration, as `deploy/launch.toml` documents it.
    #[schemars(with = "serde_json::Map<String, serde_json::Value>")]
    pub config: &'a super::LaunchConfig,
    /// The poses the launch core applied are on `core/moved`: readers
    /// draw and export those, not the bus's pose topics (which hold every
    /// pose delivered, refused ones too). Absent in older recordings.
    pub applied_poses: bool,
    /// Every change of the launch core's beacon table is on
    /// `core/beacon`: readers show beacons from those (creeping as the
    /// core's), not from the gate's decisions. Absent in older recordings.
    pub beacons_told: bool,
    /// Every change of a robot's state in the launch core is on
    /// `core/state`: readers show states from those, not from the gate's
    /// decisions. Absent in older recordings.
    pub states_told: bool,
    /// Each ROS 2 robot's velocity topic and message type (robots of
    /// `kind = "ros2"`): where `record export --ros2` puts the commands
    /// their agents reported. Absent without ROS 2 robots.
    #[serde(default, skip_serializing_if = "<[_]>::is_empty")]
    pub ros2_robots: &'a [bycoms_record::schema::Ros2RobotTopic],
    /// The robots with a real body (`lab::real_robots`): every robot of a
    /// launch of real robots but a mixed swarm's simulated members. Absent
    /// when every robot is simulated (and in older recordings).
    #[serde(default, skip_serializing_if = "<[_]>::is_empty")]
    pub real: &'a [u32],
}
