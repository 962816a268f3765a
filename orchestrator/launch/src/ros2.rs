//! `launch --ros2`: the run in the ROS 2 graph, over rmw_zenoh's wire format
//! on the launch's own zenoh session (issue 32, first part).
//!
//! Why an [`Observer`]: it must see exactly the poses the gate judged, as
//! they are recorded, and must not change the run (lockstep parity): it
//! only reads. One publisher, two sinks: what the run is as ROS 2 messages
//! (topics, types, CDR bytes, run times) is computed once by
//! [`publish::RunMessages`] (which lists the topics), and a [`publish::Sink`]
//! puts them somewhere: [`ZenohSink`] on each topic's rmw_zenoh key with
//! its attachment, one node token (`<namespace>/bycoms`) and one publisher
//! token per topic so `ros2 node list` / `ros2 topic list` find them
//! (declared through [`bycoms_runtime::ros2`], which a robot's agent uses
//! too; the wait for routes is the launch's own, and its transient-local
//! publishers — the map, `/tf_static`, the beacons — answer late joiners
//! from their caches there); or
//! [`bag::BagSink`], a rosbag2 MCAP file (`orchestrator record export
//! --ros2`). The bytes are `bycoms-ros2`'s, pinned against independent
//! implementations there.
//!
//! Clocks: every `header.stamp` and `/clock` are the run's time (µs since
//! it started, lockstep: step × dt), so ROS nodes run on it with
//! `use_sim_time`; the attachment's source timestamp is the wall clock
//! (ns since the UNIX epoch), as rmw_zenoh stamps it. Positions are in
//! terrain cells (1 cell = 1 unit of the `world` frame).

pub mod bag;
mod messages;
pub mod publish;

pub use super::config::Ros2Config;
pub use messages::{ros_messages, run_time, static_frames, ARENA_FRAME, MOCAP_FRAME, WORLD_FRAME};

use super::config::LaunchConfig;
use super::observe::Observer;
use super::World;
use bycoms_protocol::msg::{FromAgent, GateEvent, Pose};
use bycoms_record::scene::SharedScene;
use bycoms_ros2::rmw_zenoh::{graph_key_expr, EntityKind, TokenView, ADMIN_SPACE};
use bycoms_runtime::ros2::{Ros2Node, Ros2Publisher};
use publish::{RunMessages, Sink, Topic};
use std::collections::BTreeSet;
use std::time::{Duration, Instant};
use zenoh::Wait;

/// The node's name.
pub const NODE_NAME: &str = "bycoms";

/// How long a launch waits, before its run, for the route to each ROS 2
/// subscriber already in the graph (its liveliness token seen).
pub const ROUTE_TIMEOUT: Duration = Duration::from_secs(5);
/// How long a launch asks the graph for its tokens.
const GRAPH_QUERY_TIMEOUT: Duration = Duration::from_secs(1);
/// How long the routes to the graph's subscribers are given, once matched,
/// before the run. Why: a zenoh router computes the trees that carry data
/// to other routers at most every 100 ms after the network changed
/// (`TREES_COMPUTATION_DELAY_MS` in zenoh 1.10's routing), while a
/// publisher matches as soon as the subscriber's declaration arrives; what
/// is put in between is dropped. A launch connected to a ROS 2 router that
/// started right away lost its first 50 to 200 ticks' samples (the map
/// among them) in one run of eight (issue 35's sixth pass, where the
/// launch's start became faster). Two tree computations' delay.
const ROUTES_SETTLE: Duration = Duration::from_millis(200);

/// The rmw_zenoh sink: the node and each topic's publisher (key
/// expression, GID, sequence numbers) declared on the launch's zenoh
/// session through [`bycoms_runtime::ros2`], whose tokens live as long as
/// the sink.
pub struct ZenohSink {
    publishers: Vec<Ros2Publisher>,
    failed: bool,
}

impl ZenohSink {
    /// Declares the node and one publisher per topic on `session`, then
    /// waits for the routes to the subscribers already in the graph.
    pub fn open(cfg: &Ros2Config, session: &zenoh::Session, topics: &[Topic]) -> anyhow::Result<Self> {
        let mut node = Ros2Node::declare(session, cfg.domain_id, &cfg.namespace, NODE_NAME)?;
        let publishers = topics
            .iter()
            .map(|t| node.publisher(session, &t.name, t.description, t.qos))
            .collect::<Result<Vec<_>, _>>()?;
        let sink = Self { publishers, failed: false };
        let waiting = subscribed_topics(session, cfg.domain_id);
        sink.wait_for_routes(topics, &waiting);
        Ok(sink)
    }

    /// Start-up loss: a zenoh put is dropped at its source until the
    /// session knows a matching subscriber (the route). A ROS 2 node that
    /// already subscribes (RViz, a recorder) would miss the run's first
    /// samples — the map, the first poses — so, for each topic of ours a
    /// subscription token names, this waits (up to [`ROUTE_TIMEOUT`] in
    /// all) until the publisher matches. Subscribers that join later get
    /// what is put from then on, as from any volatile ROS 2 publisher.
    /// Once they match, the routes are given [`ROUTES_SETTLE`] more.
    fn wait_for_routes(&self, topics: &[Topic], waiting: &BTreeSet<String>) {
        let deadline = Instant::now() + ROUTE_TIMEOUT;
        for (publisher, topic) in self.publishers.iter().zip(topics) {
            if !waiting.contains(&topic.name) {
                continue;
            }
            let matched = publisher.wait_matching(deadline.saturating_duration_since(Instant::now()));
            if !matched {
                tracing::warn!(
                    topic = %topic.name,
                    "ros2: a subscriber of this topic is in the graph, but no route to it after {:?}: \
                     its first samples may be lost",
                    ROUTE_TIMEOUT
                );
            }
        }
        if self.publishers.iter().zip(topics).any(|(_, t)| waiting.contains(&t.name)) {
            std::thread::sleep(ROUTES_SETTLE);
        }
        tracing::debug!(topics = waiting.len(), "ros2: routes to the graph's subscribers ready");
    }
}

/// The topics the ROS 2 graph of `domain` already subscribes to (its
/// subscription tokens), asked until the graph answers or
/// [`GRAPH_QUERY_TIMEOUT`] has passed: the session connects in the
/// background and learns the graph's tokens from its router or peers some
/// milliseconds after, and until then only its own tokens answer. The
/// graph has answered once a token of another session does (a ROS 2 graph
/// with no node at all costs the timeout, once, at the start).
fn subscribed_topics(session: &zenoh::Session, domain: u32) -> BTreeSet<String> {
    let own = format!("{ADMIN_SPACE}/{domain}/{}/", session.zid());
    let deadline = Instant::now() + GRAPH_QUERY_TIMEOUT;
    loop {
        let remaining = deadline.saturating_duration_since(Instant::now());
        let tokens = match session.liveliness().get(graph_key_expr(domain)).timeout(remaining).wait() {
            Ok(replies) => {
                let mut tokens = vec![];
                while let Ok(reply) = replies.recv() {
                    if let Ok(sample) = reply.result() {
                        tokens.push(sample.key_expr().as_str().to_string());
                    }
                }
                tokens
            }
            Err(e) => {
                tracing::warn!(error = %e, "ros2: cannot ask the graph for its subscribers");
                return BTreeSet::new();
            }
        };
        if tokens.iter().any(|t| !t.starts_with(&own)) || Instant::now() >= deadline {
            return tokens
                .iter()
                .filter_map(|t| TokenView::parse(t).filter(|v| v.kind == EntityKind::Subscription))
                .map(|v| v.topic)
                .collect();
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

impl Sink for ZenohSink {
    fn send(&mut self, topic: usize, _time_ns: u64, cdr: &[u8]) {
        let publisher = &mut self.publishers[topic];
        if let Err(e) = publisher.put(cdr) {
            // Said once: a dead session fails every put after.
            if !std::mem::replace(&mut self.failed, true) {
                tracing::warn!(key = %publisher.wire().key_expr, error = %e, "ros2: a sample was not sent");
            }
        }
    }
}

/// The arena transform of the launch's motion capture, if its poses come
/// from one.
fn mocap_arena(mocap: &bycoms_mocap::MocapConfig) -> Option<&bycoms_mocap::ArenaTransform> {
    match mocap.source {
        bycoms_mocap::MocapSource::Natnet => mocap.natnet.as_ref().map(|n| &n.arena),
        bycoms_mocap::MocapSource::Ros2 => mocap.ros2.as_ref().map(|r| &r.arena),
        bycoms_mocap::MocapSource::Bus => None,
    }
}

/// Publishes the run into the ROS 2 graph (an [`Observer`] of the launch):
/// the run's messages ([`RunMessages`]) into the rmw_zenoh sink.
pub struct Ros2Bridge {
    run: RunMessages,
    sink: ZenohSink,
}

impl Ros2Bridge {
    /// Declares the node and its publishers on `session` for `robots` robots.
    pub fn open(cfg: &Ros2Config, session: &zenoh::Session, robots: u32) -> anyhow::Result<Self> {
        let run = RunMessages::new(cfg, robots);
        let sink = ZenohSink::open(cfg, session, run.topics())?;
        tracing::info!(
            domain_id = cfg.domain_id,
            node = %format_args!("{}/{NODE_NAME}", cfg.namespace.trim_end_matches('/')),
            topics = run.topics().len(),
            "ros2: publishing poses, paths, /tf, /clock, diagnostics and, latched for late joiners, the map, /tf_static and beacons over rmw_zenoh"
        );
        Ok(Self { run, sink })
    }
}

impl Observer for Ros2Bridge {
    fn world(&mut self, _swarm: &str, world: &World, cfg: &LaunchConfig, _scene: Option<&SharedScene>) {
        self.run.set_static_frames(static_frames(mocap_arena(&cfg.mocap)));
        self.run.set_real(crate::lab::real_robots(cfg, world));
        self.run.world(&world.terrain, cfg.eps, &mut self.sink);
    }
    fn pose(&mut self, pose: &Pose) {
        self.run.pose(pose, &mut self.sink);
    }
    fn gate(&mut self, event: &GateEvent) {
        self.run.gate(event, &mut self.sink);
    }
    fn beacon(&mut self, robot: u32, at: bycoms_sim::Vec2) {
        self.run.beacon(robot, at, &mut self.sink);
    }
    fn state(&mut self, robot: u32, state: crate::core::SlotState) {
        self.run.state(robot, state, &mut self.sink);
    }
    fn report(&mut self, report: &FromAgent) {
        self.run.report(report, &mut self.sink);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::RobotId;
    use bycoms_ros2::msgs::Time;

    #[test]
    fn namespaces_are_checked_and_name_the_key() {
        for good in ["/", "/lab", "/lab_2/swarm"] {
            assert_eq!(Ros2Config { namespace: good.into(), ..Ros2Config::default() }.validate(), Ok(()));
        }
        for bad in ["", "lab", "/lab/", "//", "/2lab", "/la-b"] {
            let err = Ros2Config { namespace: bad.into(), ..Ros2Config::default() }.validate().unwrap_err();
            assert!(err.contains("ros2.namespace"), "{bad}: {err}");
        }
        assert_eq!(Ros2Config::default().pose_topic(3), "/robot_3/pose");
        // Its topics within ROS 2's 255 characters: 233 (with 22 for
        // `/robot_4294967295/pose`) is the longest namespace.
        let long =
            |n: usize| Ros2Config { namespace: format!("/{}", "a".repeat(n - 1)), ..Ros2Config::default() };
        assert_eq!(long(233).validate(), Ok(()));
        let err = long(234).validate().unwrap_err();
        assert!(
            err.starts_with("ros2.namespace is 234 characters long") && err.contains("at most 233"),
            "{err}"
        );
        let err = long(100_000).validate().unwrap_err();
        assert!(err.contains("limit of 255 characters"), "{err}");
        assert!(err.len() < 300, "the namespace is not quoted whole: {err}");
        assert_eq!(
            Ros2Config { namespace: "/lab".into(), ..Ros2Config::default() }.pose_topic(1),
            "/lab/robot_1/pose"
        );
    }

    /// `domain_id` is one of ROS 2's: 0 to 232.
    #[test]
    fn domain_ids_are_ros_2_s() {
        let domain = |domain_id| Ros2Config { domain_id, ..Ros2Config::default() }.validate();
        assert_eq!(domain(0), Ok(()));
        assert_eq!(domain(232), Ok(()));
        for bad in [233, u32::MAX] {
            assert_eq!(domain(bad), Err(format!("ros2.domain_id {bad} is not a ROS 2 domain id: 0 to 232")));
        }
    }

    #[test]
    fn a_pose_becomes_a_stamped_pose_and_a_transform_at_the_runs_time() {
        let pose = Pose {
            robot: RobotId(2),
            x: 3.0,
            y: -1.5,
            heading: std::f64::consts::FRAC_PI_2,
            step: 7,
            time_us: 2_500_000,
        };
        let (stamped, tf) = ros_messages(&pose);
        assert_eq!(stamped.header.stamp, Time { sec: 2, nanosec: 500_000_000 });
        assert_eq!(stamped.header.frame_id, "world");
        assert_eq!((stamped.pose.position.x, stamped.pose.position.y), (3.0, -1.5));
        assert!((stamped.pose.orientation.z - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-12);
        assert_eq!(tf.child_frame_id, "robot_2");
        assert_eq!(tf.transform.translation.0, stamped.pose.position);
    }
}
