//! Every schema name, message encoding and topic a launch recording uses, defined once.
//!
//! Why one module: a recording is written in one place (the launch: `launch::ports`,
//! `launch::recording`, `launch::events`, the scene, the mocap sources) and read in three
//! (`draw`, `replay`, `record recover`, all through [`super::read`] and [`super::decode`]). A
//! name spelled twice drifts: the reader silently stops finding what the writer wrote, and
//! old recordings stop replaying. Writers and readers import the names from here; the
//! dispatch from a name to a decoded message is in [`super::decode`], also once.
//!
//! Bus topics (`bycoms/<swarm>/robot/<k>/pose`, …/to_agent, …/from_agent, …/gate,
//! …/operator) are the protocol's (`bycoms_protocol::Swarm`): a recording keeps the names the
//! bus uses. The topics below are the recording's own, beside them in the same tree.

use bycoms_protocol::RobotId;

/// Message encoding of raw protocol bytes (bus messages exactly as they crossed the bus).
pub const POSTCARD: &str = "postcard";

/// Message encoding of the JSON channels.
pub const JSON: &str = "json";

// Bus messages, recorded as postcard bytes (schema encoding empty: postcard is not
// self-describing).

/// Orchestrator → agent commands (`robot/<k>/to_agent`).
pub const TO_AGENT: &str = "bycoms.ToAgent";
/// Agent → orchestrator reports (`robot/<k>/from_agent`).
pub const FROM_AGENT: &str = "bycoms.FromAgent";
/// Motion capture poses (`robot/<k>/pose`).
pub const POSE: &str = "bycoms.Pose";
/// Gate decisions (`gate`).
pub const GATE: &str = "bycoms.GateEvent";
/// Placement requests to the lab's operator (`operator`).
pub const OPERATOR: &str = "bycoms.Deploy";

// The launch core's log (postcard of `launch::core::log`'s types): what the replay re-runs.
// Its schema's version is in the name: a launch writes the current one; a
// reader reads every one and upgrades it (`launch::core::log::Version`).

/// The version of the launch core's log a launch records (its `log::Version::CURRENT`).
pub const CORE_LOG_VERSION: u32 = 2;
/// The launch core's setup (`core/setup`), of version [`CORE_LOG_VERSION`].
pub const CORE_SETUP: &str = "bycoms.CoreSetup.v2";
/// Calls the launch made on its core (`core/calls`), of version [`CORE_LOG_VERSION`].
pub const CORE_CALLS: &str = "bycoms.CoreCalls.v2";
/// The launch core's setup of version 1 (before the log's schema had versions): read, no
/// longer written.
pub const CORE_SETUP_V1: &str = "bycoms.CoreSetup";
/// Calls the launch made on its core, of version 1: read, no longer written.
pub const CORE_CALLS_V1: &str = "bycoms.CoreCalls";
/// A pose the launch core applied (`core/moved`), postcard like the bus's
/// [`POSE`]: what the views show. The bus's pose topics hold every pose
/// motion capture delivered, refused ones too; a recording whose run
/// metadata says `applied_poses` is drawn and exported from these.
pub const MOVED: &str = "bycoms.Moved";
/// A change of the launch core's beacon table (`core/beacon`): postcard of
/// the bus's `ToAgent::Beacon` (its `seq` 0), the robot and where its
/// beacon now stands, bit for bit. Every beacon the views show, creeping as
/// the core's; a recording whose run metadata says `beacons_told` is drawn
/// and exported with these.
pub const BEACON: &str = "bycoms.Beacon";
/// A change of a robot's state in the launch core (`core/state`): JSON
/// `{"robot": k, "state": "moving"}` (`scene::json::RobotSlot`). Every
/// state the views show; a recording whose run metadata says
/// `states_told` is exported with these, an older one with the states its
/// gate decisions imply.
pub const CORE_STATE: &str = "bycoms.SlotState";

// Motion capture as received (the NatNet datagram's bytes).

/// A NatNet frame of data (`mocap/natnet`).
pub const NATNET_FRAME: &str = "natnet.FrameOfData";
/// The NatNet model definitions, a `NAT_MODELDEF` packet (`mocap/natnet_modeldef`).
pub const NATNET_MODELDEF: &str = "natnet.ModelDef";

// The launch's JSON channels (`launch::events`), each with a JSON schema.

/// The run's metadata (`run`), written first: terrain, start, goal, configuration.
pub const RUN: &str = "bycoms.LaunchConfig";
/// Agents' comings and goings (`events`).
pub const EVENT: &str = "bycoms.LaunchEvent";
/// The launch summary (`summary`).
pub const SUMMARY: &str = "bycoms.LaunchSummary";

// The scene's JSON channels (`crate::scene::json`); its protobuf channels use Foxglove's
// well-known schema names (`foxglove.SceneUpdate`, …), which the SDK names.

/// A robot's pose as JSON (`robot/<k>/pose/json`).
pub const ROBOT_POSE: &str = "bycoms.RobotPose";
/// A robot's controller mode (`robot/<k>/mode`).
pub const ROBOT_MODE: &str = "bycoms.RobotMode";
/// A robot's agent reports as JSON (`robot/<k>/telemetry`).
pub const TELEMETRY: &str = "bycoms.Telemetry";
/// A gate decision as JSON (`gate/json`).
pub const GATE_DECISION: &str = "bycoms.GateDecision";
/// A beacon where it stands, as JSON (`beacon/json`): each change of the
/// launch core's beacon table.
pub const BEACON_AT: &str = "bycoms.BeaconAt";
/// A robot's state as JSON (`robot/<k>/state`): each change the launch
/// core said.
pub const ROBOT_SLOT: &str = "bycoms.RobotSlot";

// The live view's own JSON channels (`bycoms_orchestrator::live`): not recorded, named here with the rest
// so that one file lists every schema name the orchestrator writes.

/// The live view's run state (`bycoms_orchestrator::live`).
pub const LIVE_STATE: &str = "bycoms.live.State";
/// The live view's world (`bycoms_orchestrator::live`).
pub const LIVE_WORLD: &str = "bycoms.live.World";

/// Name of the metadata record that says what the log times mean.
pub const CLOCK_METADATA: &str = "bycoms.clock";

/// Name of the metadata record `orchestrator record recover` writes into a
/// copy that is not the whole run (the input was cut short, or parts of it
/// were left out as damaged): its key [`RECOVERED_PARTIAL`] says what is
/// missing, so every reader of the copy says it too.
pub const RECOVERED_METADATA: &str = "bycoms.recovered";

/// The key of [`RECOVERED_METADATA`] that says what the copy lacks.
pub const RECOVERED_PARTIAL: &str = "partial";

/// The recording's own topics of one swarm, all under `bycoms/<swarm>/`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topics {
    prefix: String,
}

impl Topics {
    /// The topics of swarm `swarm`.
    pub fn new(swarm: &str) -> Self {
        Self { prefix: format!("bycoms/{swarm}") }
    }
    /// A topic `leaf` of the swarm, `bycoms/<swarm>/<leaf>`.
    pub fn leaf(&self, leaf: &str) -> String {
        format!("{}/{leaf}", self.prefix)
    }
    /// The run metadata ([`RUN`]).
    pub fn run(&self) -> String {
        self.leaf(RUN_LEAF)
    }
    /// `foxglove.SceneUpdate`.
    pub fn scene(&self) -> String {
        self.leaf("scene")
    }
    /// `foxglove.FrameTransforms`.
    pub fn tf(&self) -> String {
        self.leaf("tf")
    }
    /// `foxglove.Log`.
    pub fn log(&self) -> String {
        self.leaf("log")
    }
    /// The poses the launch core applied ([`MOVED`]).
    pub fn moved(&self) -> String {
        self.leaf("core/moved")
    }
    /// The changes of the launch core's beacon table ([`BEACON`]).
    pub fn beacon(&self) -> String {
        self.leaf("core/beacon")
    }
    /// The changes of the launch core's robots' states ([`CORE_STATE`]).
    pub fn state(&self) -> String {
        self.leaf("core/state")
    }
    /// Gate decisions as JSON ([`GATE_DECISION`]).
    pub fn gate_json(&self) -> String {
        self.leaf("gate/json")
    }
    /// Beacons where they stand as JSON ([`BEACON_AT`]).
    pub fn beacon_json(&self) -> String {
        self.leaf("beacon/json")
    }
    /// Robot `k`'s poses as JSON ([`ROBOT_POSE`]).
    pub fn pose_json(&self, k: u32) -> String {
        format!("{}/robot/{k}/pose/json", self.prefix)
    }
    /// Robot `k`'s mode ([`ROBOT_MODE`]).
    pub fn mode(&self, k: u32) -> String {
        format!("{}/robot/{k}/mode", self.prefix)
    }
    /// Robot `k`'s states ([`ROBOT_SLOT`]).
    pub fn slot(&self, k: u32) -> String {
        format!("{}/robot/{k}/state", self.prefix)
    }
    /// Robot `k`'s agent reports ([`TELEMETRY`]).
    pub fn telemetry(&self, k: u32) -> String {
        format!("{}/robot/{k}/telemetry", self.prefix)
    }
}

/// Leaf of the run metadata topic.
pub const RUN_LEAF: &str = "run";
/// Leaf of the recorded NatNet frames ([`NATNET_FRAME`]).
pub const NATNET_FRAME_LEAF: &str = "mocap/natnet";
/// Leaf of the recorded NatNet model definitions ([`NATNET_MODELDEF`]).
pub const NATNET_MODELDEF_LEAF: &str = "mocap/natnet_modeldef";

/// One ROS 2 robot's velocity topic, as the run metadata ([`RUN`]) lists it
/// (`ros2_robots`): where its agent published the commands its
/// `Commanded` reports record, so `record export --ros2` puts them back on
/// that topic, with that type, from the recording alone.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
pub struct Ros2RobotTopic {
    /// The robot.
    pub robot: u32,
    /// Its fully qualified `cmd_vel` topic.
    pub cmd_vel: String,
    /// The message its driver takes, as the robots file spells it:
    /// `twist` or `twist-stamped`.
    pub message: String,
    /// That message's ROS 2 type (`geometry_msgs/msg/Twist`, `…/TwistStamped`).
    pub r#type: String,
    /// A `TwistStamped`'s `header.frame_id`.
    pub frame_id: String,
}

/// Whether `topic` is a swarm's run metadata topic (`bycoms/<swarm>/run`), whatever the swarm.
pub fn is_run_topic(topic: &str) -> bool {
    topic.strip_suffix(RUN_LEAF).is_some_and(|rest| rest.ends_with('/'))
}

/// The robot of a `…/robot/<k>/…` topic, whatever the swarm (a recording's reader does not
/// know the swarm before it has read the run metadata).
pub fn robot_of_topic(topic: &str) -> Option<RobotId> {
    let mut parts = topic.split('/');
    parts.by_ref().find(|p| *p == "robot")?;
    parts.next()?.parse().ok().map(RobotId)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robot_ids_come_from_the_topic() {
        assert_eq!(robot_of_topic("bycoms/s/robot/12/to_agent"), Some(RobotId(12)));
        assert_eq!(robot_of_topic("bycoms/s/gate"), None);
        assert_eq!(robot_of_topic("bycoms/s/robot/x/pose"), None);
    }

    #[test]
    fn the_run_topic_is_known_by_its_leaf() {
        assert!(is_run_topic(&Topics::new("lab-1").run()));
        assert!(!is_run_topic("bycoms/lab-1/rerun"));
        assert!(!is_run_topic("run"));
    }

    /// The bus topics the recording keeps are the protocol's, under the same prefix.
    #[test]
    fn the_recordings_topics_share_the_protocols_tree() {
        let swarm = bycoms_protocol::Swarm::new("lab-1").expect("a swarm name");
        let gate = *swarm.gate().name();
        assert_eq!(Topics::new("lab-1").leaf("gate"), gate.as_str());
    }
}
