//! `[mocap]` of a launch config: where the gate's poses come from.
//!
//! Why a section of its own: in simulation the agents are their own motion
//! capture (`source = "bus"`, the default: nothing else to set); in a lab
//! the orchestrator reads OptiTrack (`source = "natnet"`), and then needs
//! the server's address, which rigid body is which robot, the axis
//! convention and how long a body may be unseen before it is reported
//! lost. How the operator places each robot at the start is the launch's
//! one `[placement]` table ([`PlacementConfig`]), whatever the source. A lab whose
//! motion capture already runs in ROS 2 (`source = "ros2"`: a driver such
//! as vrpn_mocap or motion_capture_tracking publishing one
//! `geometry_msgs/msg/PoseStamped` topic per body) maps topics to robots
//! the way NatNet maps body names, with the same axes and tracker keys. Every key is documented in `deploy/launch.toml`
//! (commented out: not the default).

use super::{ArenaTransform, ClientConfig, TrackerConfig};
use bycoms_protocol::RobotId;
use bycoms_runtime::seconds::{check_millis, check_seconds, Zero};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Which pose source a launch uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MocapSource {
    /// The simulated agents publish their own poses on the bus.
    #[default]
    Bus,
    /// OptiTrack NatNet (a real lab, or the emulated lab's `natnet-serve`).
    Natnet,
    /// A ROS 2 motion-capture driver's `PoseStamped` topics, over rmw_zenoh.
    Ros2,
}

/// `[mocap]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default, expecting = "a [mocap] table")]
pub struct MocapConfig {
    /// `bus`, `natnet` or `ros2`.
    pub source: MocapSource,
    /// `[mocap.natnet]`: required with `source = "natnet"`.
    pub natnet: Option<NatNetSourceConfig>,
    /// `[mocap.ros2]`: required with `source = "ros2"`.
    pub ros2: Option<Ros2MocapConfig>,
}

/// `[mocap.ros2]`: poses from a ROS 2 motion-capture driver, one
/// `geometry_msgs/msg/PoseStamped` topic per robot (positions in metres,
/// REP-103: Z up), read over rmw_zenoh in the `[ros2]` table's domain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ros2MocapConfig {
    /// Topic (fully qualified, e.g. `/vrpn_mocap/robot1/pose`) → robot id.
    pub topics: BTreeMap<String, RobotId>,
    /// Driver frame → arena: up axis (default `z`, ROS's), origin, scale.
    #[serde(default = "ros_arena")]
    pub arena: ArenaTransform,
    /// Plausible motion and the lost-body time (the NatNet tracker's keys).
    pub tracker: TrackerConfig,
    /// Warn when a mapped topic has no publisher in the ROS 2 graph this
    /// long (s) after the launch started (a wrong domain, topic or router).
    #[serde(default = "graph_timeout")]
    pub graph_timeout: f64,
}

fn ros_arena() -> ArenaTransform {
    ArenaTransform { up: super::UpAxis::Z, ..ArenaTransform::default() }
}

fn graph_timeout() -> f64 {
    5.0
}

/// `[mocap.natnet]`: the NatNet source.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NatNetSourceConfig {
    /// How to reach the server.
    pub client: ClientConfig,
    /// Mocap → arena: up axis, origin, scale.
    #[serde(default)]
    pub arena: ArenaTransform,
    /// Rigid-body name (as in Motive) → robot id.
    pub bodies: BTreeMap<String, RobotId>,
    /// Plausible motion and the lost-body time.
    pub tracker: TrackerConfig,
}

/// The `[placement]` table (the launch core's, owned there).
pub use bycoms_gate::placement::PlacementConfig;

impl MocapConfig {
    /// Checks the section against a launch of `robots` robots, of which
    /// `simulated` (a mixed swarm's simulated members) are not seen by
    /// motion capture; the message names the key.
    pub fn validate(&self, robots: u32, simulated: &[u32]) -> Result<(), String> {
        let source = match self.source {
            MocapSource::Bus => "bus",
            MocapSource::Natnet => "natnet",
            MocapSource::Ros2 => "ros2",
        };
        let tables = [
            ("natnet", self.natnet.is_some(), MocapSource::Natnet),
            ("ros2", self.ros2.is_some(), MocapSource::Ros2),
        ];
        if let Some((table, ..)) = tables.iter().find(|(_, set, wanted)| *set && self.source != *wanted) {
            return Err(format!("[mocap.{table}] is set but mocap.source is \"{source}\""));
        }
        if let Some((table, ..)) = tables.iter().find(|(_, set, wanted)| !*set && self.source == *wanted) {
            return Err(format!("mocap.source = \"{table}\" needs a [mocap.{table}] section"));
        }
        match (&self.natnet, &self.ros2) {
            (Some(natnet), _) => natnet.validate(robots, simulated),
            (_, Some(ros2)) => ros2.validate(robots, simulated),
            _ => Ok(()),
        }
    }
}

/// Every mapped name (a body, a topic) is one robot, ids from 1, and every
/// robot of the launch but the `simulated` ones has one; `key` names the
/// table in messages.
fn check_mapping(
    key: &str,
    what: &str,
    map: &BTreeMap<String, RobotId>,
    robots: u32,
    simulated: &[u32],
) -> Result<(), String> {
    let mut seen = BTreeMap::new();
    for (name, robot) in map {
        if robot.0 == 0 {
            return Err(format!("{key}.{name} = 0 is not a robot (ids start at 1)"));
        }
        if let Some(other) = seen.insert(*robot, name) {
            return Err(format!("{key}: {other} and {name} are both robot {}", robot.0));
        }
    }
    match (1..=robots).find(|k| !seen.contains_key(&RobotId(*k)) && !simulated.contains(k)) {
        Some(missing) => Err(format!("{key}: no {what} is robot {missing}")),
        None => Ok(()),
    }
}

/// The tracker's and the axes' numbers, named under `key` (`mocap.natnet`,
/// `mocap.ros2`).
fn check_tracking(key: &str, t: &TrackerConfig, s: &ArenaTransform) -> Result<(), String> {
    for (name, value) in [("tracker.max_speed", t.max_speed), ("arena.scale", s.scale)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(format!("{key}.{name} must be a positive number, got {value}"));
        }
    }
    if !(t.jump_slack.is_finite() && t.jump_slack >= 0.0) {
        return Err(format!("{key}.tracker.jump_slack must be a non-negative number, got {}", t.jump_slack));
    }
    if t.lost_after_us == 0 {
        return Err(format!("{key}.tracker.lost_after_us must be at least 1"));
    }
    Ok(())
}

impl Ros2MocapConfig {
    /// The settings for a launch of `robots` robots: topics of later robots
    /// are left out (as [`NatNetSourceConfig::for_robots`]).
    pub fn for_robots(&self, robots: u32) -> Self {
        let mut cfg = self.clone();
        cfg.topics.retain(|_, robot| robot.0 <= robots);
        cfg
    }

    /// Checks the ROS 2 settings against a launch of `robots` robots.
    pub fn validate(&self, robots: u32, simulated: &[u32]) -> Result<(), String> {
        for topic in self.topics.keys() {
            if !is_topic_name(topic) {
                return Err(format!(
                    "mocap.ros2.topics: {topic:?} is not a fully qualified ROS 2 topic name \
                     (`/name/name`, letters, digits and `_`)"
                ));
            }
        }
        check_mapping("mocap.ros2.topics", "topic", &self.topics, robots, simulated)?;
        check_tracking("mocap.ros2", &self.tracker, &self.arena)?;
        check_seconds("mocap.ros2.graph_timeout", self.graph_timeout, Zero::Allowed)?;
        Ok(())
    }
}

fn is_topic_name(name: &str) -> bool {
    bycoms_ros2::rmw_zenoh::is_fully_qualified(name, false)
}

impl NatNetSourceConfig {
    /// The settings for a launch of `robots` robots: bodies mapped to later
    /// robots are left out (one lab file names every robot of the lab; a
    /// scenario uses the first ones, as with the robots file).
    pub fn for_robots(&self, robots: u32) -> Self {
        let mut cfg = self.clone();
        cfg.bodies.retain(|_, robot| robot.0 <= robots);
        cfg
    }

    /// Checks the NatNet settings against a launch of `robots` robots
    /// (bodies of later robots are allowed: see [`Self::for_robots`]).
    pub fn validate(&self, robots: u32, simulated: &[u32]) -> Result<(), String> {
        check_mapping("mocap.natnet.bodies", "rigid body", &self.bodies, robots, simulated)?;
        check_tracking("mocap.natnet", &self.tracker, &self.arena)?;
        // Added to an `Instant` for every command: near u64::MAX it
        // overflowed (a panic); 0 is no socket timeout at all.
        let reply_ms = self.client.reply_timeout_ms;
        check_millis("mocap.natnet.client.reply_timeout_ms", reply_ms, Zero::Refused).map(drop)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LAB: &str = r#"
        source = "natnet"
        [natnet.client]
        server = "127.0.0.1:1510"
        [natnet.arena]
        up = "y"
        scale = 10.0
        [natnet.bodies]
        robot1 = 1
        robot2 = 2
        [natnet.tracker]
        max_speed = 1.5
        jump_slack = 0.2
        lost_after_us = 500000
    "#;

    #[test]
    fn a_lab_section_parses_validates_and_round_trips() {
        let cfg: MocapConfig = toml::from_str(LAB).unwrap();
        assert_eq!(cfg.source, MocapSource::Natnet);
        let natnet = cfg.natnet.as_ref().unwrap();
        assert_eq!(natnet.bodies["robot2"], RobotId(2));
        cfg.validate(2, &[]).unwrap();
        let again: MocapConfig = toml::from_str(&toml::to_string(&cfg).unwrap()).unwrap();
        assert_eq!(again, cfg);
    }

    #[test]
    fn every_mistake_is_named() {
        let cfg: MocapConfig = toml::from_str(LAB).unwrap();
        let err = cfg.validate(3, &[]).unwrap_err();
        assert!(err.contains("robot 3"), "{err}");
        // A mixed swarm's simulated robot 3 has no body: motion capture does not see it.
        cfg.validate(3, &[3]).expect("robot 3 simulated");
        // A lab file names every robot; a launch of fewer uses the first.
        cfg.validate(1, &[]).expect("robot 2's body is left out of a 1-robot launch");
        let one = cfg.natnet.as_ref().expect("natnet").for_robots(1);
        assert_eq!(one.bodies.keys().collect::<Vec<_>>(), ["robot1"]);
        let zero = LAB.replace("robot2 = 2", "robot2 = 0");
        let err = toml::from_str::<MocapConfig>(&zero).unwrap().validate(2, &[]).unwrap_err();
        assert!(err.contains("bodies.robot2"), "{err}");
        let natnet_off = MocapConfig { source: MocapSource::Natnet, natnet: None, ros2: None };
        assert!(natnet_off.validate(1, &[]).unwrap_err().contains("[mocap.natnet]"));
        let err = toml::from_str::<MocapConfig>(&LAB.replace("jump_slack", "jump_slak")).unwrap_err();
        assert!(err.to_string().contains("jump_slak"), "{err}");
        let twice = LAB.replace("robot2 = 2", "robot2 = 1");
        let err = toml::from_str::<MocapConfig>(&twice).unwrap().validate(2, &[]).unwrap_err();
        assert!(err.contains("both robot 1"), "{err}");
        assert_eq!(MocapConfig::default().validate(5, &[]), Ok(()));
    }

    #[test]
    fn a_reply_timeout_past_any_run_or_of_zero_is_named() {
        let with = |ms: u64| {
            let text = LAB.replace(
                "server = \"127.0.0.1:1510\"",
                &format!("server = \"127.0.0.1:1510\"\nreply_timeout_ms = {ms}"),
            );
            toml::from_str::<MocapConfig>(&text).expect("parses").validate(2, &[])
        };
        for ms in [u64::MAX, 100_000_000_001, 0] {
            let err = with(ms).unwrap_err();
            let says = format!("mocap.natnet.client.reply_timeout_ms must be a number of milliseconds in (0, 100000000000], got {ms}");
            assert_eq!(err, says);
        }
        assert_eq!(with(100_000_000_000), Ok(()));
        assert_eq!(with(1), Ok(()));
    }

    const ROS2: &str = r#"
        source = "ros2"
        [ros2.topics]
        "/vrpn_mocap/robot1/pose" = 1
        "/vrpn_mocap/robot2/pose" = 2
        [ros2.tracker]
        max_speed = 0.6
        jump_slack = 0.05
        lost_after_us = 500000
    "#;

    /// The ROS 2 section: Z up by default (REP-103), the same mapping and
    /// tracker checks as NatNet, each naming its `mocap.ros2` key.
    #[test]
    fn a_ros2_section_parses_with_ros_axes_and_every_mistake_is_named() {
        let cfg: MocapConfig = toml::from_str(ROS2).unwrap();
        let ros2 = cfg.ros2.as_ref().expect("ros2");
        assert_eq!(
            (cfg.source, ros2.arena.up, ros2.graph_timeout),
            (MocapSource::Ros2, super::super::UpAxis::Z, 5.0)
        );
        cfg.validate(2, &[]).unwrap();
        assert_eq!(ros2.for_robots(1).topics.len(), 1);
        let again: MocapConfig = toml::from_str(&toml::to_string(&cfg).unwrap()).unwrap();
        assert_eq!(again, cfg);
        let err = |text: String| toml::from_str::<MocapConfig>(&text).unwrap().validate(2, &[]).unwrap_err();
        assert!(cfg.validate(3, &[]).unwrap_err().contains("mocap.ros2.topics: no topic is robot 3"));
        let e = err(ROS2.replace("\"/vrpn_mocap/robot2/pose\"", "\"vrpn/robot2\""));
        assert!(e.contains("\"vrpn/robot2\" is not a fully qualified ROS 2 topic name"), "{e}");
        let e = err(ROS2.replace("= 2", "= 1"));
        assert!(e.contains("both robot 1"), "{e}");
        let e = err(ROS2.replace("max_speed = 0.6", "max_speed = -1.0"));
        assert_eq!(e, "mocap.ros2.tracker.max_speed must be a positive number, got -1");
        let e = err(ROS2.replace("source = \"ros2\"", "source = \"natnet\""));
        assert_eq!(e, "[mocap.ros2] is set but mocap.source is \"natnet\"");
        let bare = MocapConfig { source: MocapSource::Ros2, ..MocapConfig::default() };
        assert_eq!(
            bare.validate(1, &[]).unwrap_err(),
            "mocap.source = \"ros2\" needs a [mocap.ros2] section"
        );
    }
}
