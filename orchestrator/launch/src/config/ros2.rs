//! The `[ros2]` table of a launch config: the graph's domain, the
//! namespace, the lab's router.
//!
//! Why here, in the config's module and not the ROS 2 output's: the
//! launch's config (`orchestrator/launch/src/config.rs`) holds it, and the
//! ROS 2 output (`ros2.rs`) reads the launch's config, so the output uses
//! the config and never the other way (no module cycles). `ros2.rs`
//! re-exports it beside what it configures.

use serde::{Deserialize, Serialize};

/// The `[ros2]` table of a launch config.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default, expecting = "a [ros2] table")]
pub struct Ros2Config {
    /// `ROS_DOMAIN_ID` of the graph to join.
    pub domain_id: u32,
    /// The namespace of the node and of each robot's pose topic (`/` or `/name…`).
    pub namespace: String,
    /// The lab's ROS 2 router (`rmw_zenohd`, `tcp/HOST:7447`): the launch
    /// joins the graph as its zenoh client (`orchestrator/launch/src/ros2_graph.rs`); absent,
    /// over the launch's own zenoh session.
    pub router: Option<String>,
}

impl Default for Ros2Config {
    fn default() -> Self {
        Self { domain_id: 0, namespace: "/".into(), router: None }
    }
}

/// The highest `ROS_DOMAIN_ID` ROS 2 documents (0 to 232).
pub const MAX_DOMAIN_ID: u32 = 232;

/// The longest topic name ROS 2 takes, in characters.
pub const MAX_TOPIC_LEN: usize = 255;

impl Ros2Config {
    /// A usage error unless the namespace is a ROS 2 namespace (`/`, or `/`
    /// then names of letters, digits and `_` separated by single `/`)
    /// short enough that every pose topic under it fits ROS 2's
    /// [`MAX_TOPIC_LEN`], and the domain is one of ROS 2's (0 to
    /// [`MAX_DOMAIN_ID`]).
    pub fn validate(&self) -> Result<(), String> {
        let ns = &self.namespace;
        if self.domain_id > MAX_DOMAIN_ID {
            return Err(format!(
                "ros2.domain_id {} is not a ROS 2 domain id: 0 to {MAX_DOMAIN_ID}",
                self.domain_id
            ));
        }
        // The longest topic under it: the pose topic of the highest robot id.
        let longest = self.pose_topic(u32::MAX).chars().count();
        if longest > MAX_TOPIC_LEN {
            let most = ns.chars().count() - (longest - MAX_TOPIC_LEN);
            return Err(format!(
                "ros2.namespace is {} characters long: its topics (`<namespace>/robot_<k>/pose`) would pass \
                 ROS 2's limit of {MAX_TOPIC_LEN} characters; give one of at most {most}",
                ns.chars().count()
            ));
        }
        if bycoms_ros2::rmw_zenoh::is_fully_qualified(ns, true) {
            Ok(())
        } else {
            Err(format!("ros2.namespace {ns:?} is not a ROS 2 namespace: `/` or `/name`, `/a/b` (letters, digits, `_`)"))
        }
    }

    /// Robot `k`'s pose topic.
    pub fn pose_topic(&self, robot: u32) -> String {
        format!("{}/robot_{robot}/pose", self.namespace.trim_end_matches('/'))
    }
}
