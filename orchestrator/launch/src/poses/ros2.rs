//! A ROS 2 motion-capture driver behind the launch's poses seam
//! ([`PoseSource`]): `mocap.source = "ros2"`.
//!
//! Why: a lab whose OptiTrack or Vicon already feeds ROS 2 (vrpn_mocap,
//! motion_capture_tracking, mocap4r2, natnet_ros2) has one
//! `geometry_msgs/msg/PoseStamped` topic per rigid body; the launch
//! subscribes to the mapped topics over rmw_zenoh's wire format (the data
//! key of each topic, `bycoms-ros2`) on the ROS 2 session
//! (`launch::ros2_graph::session`), and declares a subscription token
//! (`MS`) per topic under its own node `bycoms_mocap`, so `ros2 node list`
//! and `ros2 topic info` show it. Each sample goes through the same tracker
//! as NatNet (`mocap::topics`), so swaps and occlusions are handled alike,
//! and the carried-by-hand rule is NatNet's ([`Carried`]).
//!
//! Samples arrive on zenoh's threads and wait in an inbox until the next
//! drain (which never waits); undecodable ones are bad traffic, counted.
//! The ROS 2 graph is watched ([`GraphWatch`]): a mapped topic without a
//! publisher after `mocap.ros2.graph_timeout` is warned about by name.

use super::mocap::Carried;
use super::{PoseError, PoseSink, PoseSource};
use crate::ros2::Ros2Config;
use crate::ros2_graph::{GraphWatch, Wanted};
use bycoms_mocap::{Ros2MocapConfig, TopicPipeline};
use bycoms_protocol::bus::BusError;
use bycoms_protocol::codec::CodecError;
use bycoms_protocol::RobotId;
use bycoms_ros2::msgs::{PoseStamped, RosMessage};
use bycoms_ros2::rmw_zenoh::{
    dds_type_name, graph_key_expr, liveliness_token, topic_key_expr, Endpoint, EntityKind, Node, Qos,
};
use std::collections::BTreeSet;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use zenoh::Wait;

/// Where `deploy/launch.toml`'s commented-out `[mocap.ros2]` example begins.
pub const DOCUMENTED: &str = "# The ROS 2 source";

/// The mocap node's name.
pub const NODE_NAME: &str = "bycoms_mocap";
/// Its node id in the session: clear of the publishing node's ids
/// (`launch::ros2`, from 0), since the two may share a session.
pub const NODE_ID: u64 = 1000;

/// Samples (robot, CDR bytes) and graph tokens (key, alive) as zenoh's
/// callbacks hand them, until the next drain.
#[derive(Default)]
struct Inbox {
    samples: Vec<(u32, Vec<u8>)>,
    tokens: Vec<(String, bool)>,
}

/// A ROS 2 driver's topics behind the seam.
pub struct Ros2Poses {
    inbox: Arc<Mutex<Inbox>>,
    /// Subscribers, the graph watch's and the tokens: held for the run.
    _held: Held,
    pipeline: TopicPipeline,
    opened: BTreeSet<u32>,
    carried: Carried,
    graph: GraphWatch,
    began: Instant,
}

struct Held {
    _subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
    _graph: zenoh::pubsub::Subscriber<()>,
    _tokens: Vec<zenoh::liveliness::LivelinessToken>,
}

impl Ros2Poses {
    /// Subscribes to `config`'s topics in `ros2`'s domain on `session`.
    pub fn open(
        config: &Ros2MocapConfig,
        ros2: &Ros2Config,
        session: &zenoh::Session,
    ) -> anyhow::Result<Self> {
        let inbox = Arc::new(Mutex::new(Inbox::default()));
        let node = Node {
            domain_id: ros2.domain_id,
            zid: session.zid().to_string(),
            id: NODE_ID,
            enclave: "/".into(),
            namespace: ros2.namespace.clone(),
            name: NODE_NAME.into(),
        };
        let (ros_type, hash) = (PoseStamped::DESCRIPTION.name, PoseStamped::DESCRIPTION.rihs01());
        let fail = |what: &str, e: &dyn std::fmt::Display| anyhow::anyhow!("ros2 mocap: cannot {what}: {e}");
        let mut tokens = vec![liveliness_token(&node, None)?];
        let mut subscribers = Vec::new();
        let mut wanted = Vec::new();
        for (i, (topic, robot)) in (1..).zip(&config.topics) {
            let endpoint = Endpoint {
                id: NODE_ID + i,
                kind: EntityKind::Subscription,
                topic: topic.clone(),
                ros_type: ros_type.to_string(),
                type_hash: hash.clone(),
                qos: Qos::best_effort(10),
            };
            tokens.push(liveliness_token(&node, Some(&endpoint))?);
            let key = topic_key_expr(ros2.domain_id, topic, ros_type, &hash);
            let (into, robot) = (Arc::clone(&inbox), robot.0);
            let subscriber = session
                .declare_subscriber(key.as_str())
                .callback(move |sample| {
                    let bytes = sample.payload().to_bytes().into_owned();
                    lock(&into).samples.push((robot, bytes));
                })
                .wait()
                .map_err(|e| fail(&format!("subscribe to {topic}"), &e))?;
            subscribers.push(subscriber);
            wanted.push(Wanted {
                topic: topic.clone(),
                dds_type: dds_type_name(ros_type),
                type_hash: hash.clone(),
            });
        }
        let into = Arc::clone(&inbox);
        let graph = session
            .liveliness()
            .declare_subscriber(graph_key_expr(ros2.domain_id))
            .history(true)
            .callback(move |sample| {
                let alive = sample.kind() == zenoh::sample::SampleKind::Put;
                lock(&into).tokens.push((sample.key_expr().as_str().to_string(), alive));
            })
            .wait()
            .map_err(|e| fail("watch the ROS 2 graph", &e))?;
        let declared = tokens
            .into_iter()
            .map(|t| session.liveliness().declare_token(t).wait())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| fail("declare a liveliness token", &e))?;
        tracing::info!(
            domain_id = ros2.domain_id,
            topics = config.topics.len(),
            "ros2: mocap from {ros_type} topics"
        );
        let timeout = Duration::from_secs_f64(config.graph_timeout);
        Ok(Self {
            inbox,
            _held: Held { _subscribers: subscribers, _graph: graph, _tokens: declared },
            pipeline: TopicPipeline::new(config),
            opened: BTreeSet::new(),
            carried: Carried::default(),
            graph: GraphWatch::new(ros2.domain_id, session.zid().to_string(), wanted, timeout),
            began: Instant::now(),
        })
    }
}

/// The inbox, even if a callback panicked while holding it.
fn lock(inbox: &Mutex<Inbox>) -> std::sync::MutexGuard<'_, Inbox> {
    inbox.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl PoseSource for Ros2Poses {
    fn kind(&self) -> &'static str {
        "ros2"
    }

    fn on_the_bus(&self) -> bool {
        false
    }

    fn open_robot(&mut self, id: u32) -> Result<(), PoseError> {
        self.opened.insert(id);
        Ok(())
    }

    fn drain(&mut self, sink: &mut PoseSink<'_>) -> Result<(), PoseError> {
        let Inbox { mut samples, tokens } = std::mem::take(&mut *lock(&self.inbox));
        for (key, alive) in tokens {
            self.graph.token(&key, alive);
        }
        for warning in self.graph.check(self.began.elapsed()) {
            tracing::warn!("{warning}");
        }
        // Robots in id order, each robot's samples in arrival order.
        samples.sort_by_key(|(robot, _)| *robot);
        for (robot, bytes) in samples.into_iter().filter(|(r, _)| self.opened.contains(r)) {
            self.carried.forget_in(self.pipeline.tracker_mut());
            match PoseStamped::from_cdr(&bytes) {
                Ok(msg) => {
                    if let Some(pose) = self.pipeline.on_sample(RobotId(robot), &msg) {
                        self.carried.seen(&pose);
                        sink.pose(robot, pose);
                    }
                }
                Err(e) => {
                    tracing::debug!(robot, error = %e, "ros2 mocap: a sample is not a PoseStamped");
                    let topic = self.pipeline.topic(RobotId(robot)).to_string();
                    sink.bad(&topic, BusError::Codec(CodecError::Malformed))?;
                }
            }
        }
        Ok(())
    }

    fn carried(&mut self, id: u32, by_hand: bool) {
        self.carried.set(id, by_hand, self.pipeline.tracker_mut());
    }
}

#[cfg(test)]
mod documented {
    use crate::LaunchConfig;

    /// The commented-out `[mocap.ros2]` example of `deploy/launch.toml`,
    /// uncommented, is a valid 3-robot lab config (with a router).
    #[test]
    fn the_documented_ros2_example_is_valid() {
        let file = include_str!("../../../../deploy/launch.toml");
        let start = file.find(super::DOCUMENTED).expect("the example is documented");
        let example: String = file[start..]
            .lines()
            .skip(1)
            .map(|l| l.strip_prefix("# ").or_else(|| l.strip_prefix('#')).unwrap_or(l))
            .collect::<Vec<_>>()
            .join("\n");
        let head = "robots = 3\n[ros2]\nrouter = \"tcp/127.0.0.1:7447\"\n[mocap]\nsource = \"ros2\"\n";
        let text = format!("{head}{example}");
        let cfg = LaunchConfig::parse(&text).unwrap_or_else(|e| panic!("{e:#}\n{text}"));
        cfg.validate().expect("valid");
        let ros2 = cfg.mocap.ros2.expect("ros2 section");
        assert_eq!((ros2.topics.len(), ros2.arena.up), (3, bycoms_mocap::UpAxis::Z));
    }
}
