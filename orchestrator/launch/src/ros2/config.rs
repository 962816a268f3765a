//! The `[ros2]` table of a launch config: the graph's domain, the
//! namespace, the lab's router.
//!
//! Why a file of its own: the launch's config (`orchestrator/launch/src/config.rs`) holds
//! it, and the ROS 2 output (`ros2.rs`) reads the launch's config (no file
//! cycles).

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

impl Ros2Config {
    /// A usage error unless the namespace is a ROS 2 namespace: `/`, or `/`
    /// then names of letters, digits and `_` separated by single `/`.
    pub fn validate(&self) -> Result<(), String> {
        let ns = &self.namespace;
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
