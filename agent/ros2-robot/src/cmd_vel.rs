//! The robot's `cmd_vel` on the ROS 2 graph: node `bycoms_robot_<k>` with
//! one publisher of `geometry_msgs/msg/Twist` or `TwistStamped`, over
//! rmw_zenoh (the runtime's [`Ros2Node`], the launch's own way of
//! publishing), on a zenoh client session to the graph's router.
//!
//! Why a client of the router: rmw_zenoh's router (`rmw_zenohd`) does not
//! forward between peers; a process that is not a ROS node reaches the
//! graph's subscribers (the robot's driver) as its client, as the launch
//! does (`orchestrator/launch/src/ros2_graph.rs`).

use crate::run::CmdVel;
use bycoms_agent::wheeled::Velocity;
use bycoms_protocol::bus::zenoh::{Mode, ZenohBus};
use bycoms_ros2::msgs::{Header, Time, Twist, TwistStamped};
use bycoms_ros2::rmw_zenoh::Qos;
use bycoms_ros2::velocity::VelocityMessage;
use bycoms_runtime::ros2::{wall_clock_ns, Ros2Node, Ros2Publisher};

/// The node's name for robot `robot`: what `ros2 topic info -v` lists as
/// the publisher of its `cmd_vel`.
pub fn node_name(robot: u32) -> String {
    format!("bycoms_robot_{robot}")
}

/// Where and how a robot's velocity commands are published.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Target {
    /// The graph's zenoh router.
    pub router: String,
    /// `ROS_DOMAIN_ID`.
    pub domain_id: u32,
    /// The node's namespace.
    pub namespace: String,
    /// The robot (its node is `bycoms_robot_<k>`).
    pub robot: u32,
    /// The fully qualified velocity topic.
    pub topic: String,
    /// Its message type.
    pub message: VelocityMessage,
    /// A `TwistStamped`'s frame.
    pub frame_id: String,
}

/// A robot's `cmd_vel` publisher on its own zenoh session.
pub struct ZenohCmdVel {
    publisher: Ros2Publisher,
    message: VelocityMessage,
    frame_id: String,
    // Declared on it: dropped after the publisher (fields drop in order).
    _node: Ros2Node,
    _bus: ZenohBus,
}

impl ZenohCmdVel {
    /// Joins the graph at `target.router` and declares the node and its
    /// publisher; the error says what to check.
    pub fn open(target: &Target) -> Result<Self, String> {
        let router = &target.router;
        let config = bycoms_runtime::zenoh_config(Mode::Client, Vec::new(), vec![router.clone()], None);
        let bus = ZenohBus::open(config).map_err(|e| {
            format!(
                "ros2: no zenoh router answers at {router} (--ros2-router): {e}. \
                 Start the lab's router (`ros2 run rmw_zenoh_cpp rmw_zenohd`) or give its endpoint"
            )
        })?;
        let session = bus.session();
        let mut node =
            Ros2Node::declare(session, target.domain_id, &target.namespace, &node_name(target.robot))
                .map_err(|e| e.to_string())?;
        let description = target.message.description();
        let topic = &target.topic;
        let publisher =
            node.publisher(session, topic, description, Qos::reliable(10)).map_err(|e| e.to_string())?;
        tracing::info!(%topic, router = %router, "ros2: cmd_vel publisher declared");
        Ok(Self {
            publisher,
            message: target.message,
            frame_id: target.frame_id.clone(),
            _node: node,
            _bus: bus,
        })
    }
}

impl CmdVel for ZenohCmdVel {
    fn send(&mut self, velocity: Velocity) -> Result<(), String> {
        let twist = Twist::planar(velocity.linear, velocity.angular);
        let sent = match self.message {
            VelocityMessage::Twist => self.publisher.publish(&twist),
            VelocityMessage::TwistStamped => {
                let header =
                    Header { stamp: Time::from_nanos(wall_clock_ns()), frame_id: self.frame_id.clone() };
                self.publisher.publish(&TwistStamped { header, twist })
            }
        };
        sent.map(|_| ()).map_err(|e| e.to_string())
    }
}
