//! `sim-agent lab --ros2-router ENDPOINT`: the ROS 2 robots' `cmd_vel`
//! topics, read as their drivers would read them, handed to their bodies
//! on the lab clock.
//!
//! Why rmw_zenoh's wire format on a zenoh client session of the lab's
//! router: a robot's agent (`ros2-robot`) must not be able to tell the
//! emulated robot from a TurtleBot, so the lab subscribes where a driver's
//! subscription gets its samples (`bycoms_ros2::rmw_zenoh::topic_key_expr`
//! of the robot's topic and message type) and announces a subscription
//! token per robot under its node `bycoms_lab`, so `ros2 topic info` lists
//! a subscriber. Samples arrive on zenoh's threads with their wall time and
//! wait in an inbox until the lab's loop drains it; each becomes a command
//! at the lab time its arrival maps to (`--speed`: lab time runs faster
//! than the wall's). An undecodable sample is counted and logged, never
//! fatal (a real driver drops it too).

use super::robots::Ros2Entry;
use super::world::Lab;
use bycoms_agent::wheeled::Velocity;
use bycoms_protocol::bus::zenoh::{Mode, ZenohBus};
use bycoms_protocol::RobotId;
use bycoms_ros2::cdr::CdrError;
use bycoms_ros2::msgs::{Twist, TwistStamped};
use bycoms_ros2::rmw_zenoh::{liveliness_token, topic_key_expr, Endpoint, EntityKind, Node, Qos};
use bycoms_ros2::velocity::VelocityMessage;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};
use zenoh::Wait;

/// The lab's ROS 2 node name.
pub const NODE_NAME: &str = "bycoms_lab";

/// Where the ROS 2 robots' commands come from: the router, the domain,
/// the namespace of the default topics.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ros2Link {
    /// The lab's zenoh router (rmw_zenohd), a zenoh endpoint.
    pub router: String,
    /// `ROS_DOMAIN_ID`.
    pub domain_id: u32,
    /// The namespace of `<namespace>/robot_<id>/cmd_vel`.
    pub namespace: String,
}

/// One sample as zenoh handed it: (robot index, arrival, CDR bytes).
type Inbox = Arc<Mutex<Vec<(usize, Instant, Vec<u8>)>>>;

/// What became of one robot's samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Counts {
    /// Decoded and handed to the body.
    pub commands: u64,
    /// Not a message of the robot's type.
    pub undecodable: u64,
    /// Decoded while the robot waited off the arena (lost).
    pub unplaced: u64,
    /// The last command handed to the body (what it drives by until its
    /// driver's timeout).
    pub last: Option<Velocity>,
}

/// The ROS 2 robots' `cmd_vel` subscriptions.
pub struct CmdVelIn {
    inbox: Inbox,
    robots: Vec<(RobotId, VelocityMessage, String)>,
    counts: Vec<Counts>,
    _held: (Vec<zenoh::pubsub::Subscriber<()>>, Vec<zenoh::liveliness::LivelinessToken>),
    _bus: ZenohBus,
}

/// A velocity command of `message`'s type, decoded.
pub fn decode(message: VelocityMessage, cdr: &[u8]) -> Result<Velocity, CdrError> {
    let twist = match message {
        VelocityMessage::Twist => Twist::from_cdr(cdr)?,
        VelocityMessage::TwistStamped => TwistStamped::from_cdr(cdr)?.twist,
    };
    Ok(Velocity { linear: twist.linear.0.x, angular: twist.angular.0.z })
}

/// The lab time a sample that arrived at `wall` maps to, the lab having
/// started at `t0` and running `speed` × the wall's time; never after the
/// lab's `now` (a lab running late takes it now).
pub fn lab_time(wall: Instant, t0: Instant, speed: f64, now: Duration) -> Duration {
    wall.saturating_duration_since(t0).mul_f64(speed).min(now)
}

fn error(what: &str, e: impl std::fmt::Display) -> String {
    format!("ros2: cannot {what}: {e}")
}

impl CmdVelIn {
    /// Joins `link`'s router as a zenoh client and subscribes to every
    /// robot's `cmd_vel`.
    pub fn open(link: &Ros2Link, robots: &[Ros2Entry]) -> Result<Self, String> {
        let config = bycoms_runtime::zenoh_config(Mode::Client, Vec::new(), vec![link.router.clone()], None);
        let bus = ZenohBus::open(config)
            .map_err(|e| format!("ros2: no zenoh router answers at {} (--ros2-router): {e}", link.router))?;
        let session = bus.session();
        let node = Node {
            domain_id: link.domain_id,
            zid: session.zid().to_string(),
            id: 0,
            enclave: "/".into(),
            namespace: link.namespace.clone(),
            name: NODE_NAME.into(),
        };
        let inbox = Inbox::default();
        let mut tokens = vec![liveliness_token(&node, None).map_err(|e| error("name the node", e))?];
        let (mut subscribers, mut named) = (Vec::new(), Vec::new());
        for (index, entry) in robots.iter().enumerate() {
            let (topic, description) = (entry.topic(&link.namespace), entry.message.description());
            let (ros_type, hash) = (description.name, description.rihs01());
            let endpoint = Endpoint {
                id: index as u64 + 1,
                kind: EntityKind::Subscription,
                topic: topic.clone(),
                ros_type: ros_type.to_string(),
                type_hash: hash.clone(),
                qos: Qos::reliable(10),
            };
            tokens.push(liveliness_token(&node, Some(&endpoint)).map_err(|e| error("name a token", e))?);
            let key = topic_key_expr(link.domain_id, &topic, ros_type, &hash);
            let into = Arc::clone(&inbox);
            let subscriber = session
                .declare_subscriber(key.as_str())
                .callback(move |sample| {
                    let bytes = sample.payload().to_bytes().into_owned();
                    into.lock().unwrap_or_else(PoisonError::into_inner).push((index, Instant::now(), bytes));
                })
                .wait()
                .map_err(|e| error(&format!("subscribe to {topic}"), e))?;
            subscribers.push(subscriber);
            tracing::info!(robot = entry.id, %topic, %ros_type, key, "lab: robot's cmd_vel");
            named.push((RobotId(entry.id), entry.message, topic));
        }
        let tokens = tokens
            .into_iter()
            .map(|t| session.liveliness().declare_token(t).wait())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| error("declare a liveliness token", e))?;
        tracing::info!(router = %link.router, domain_id = link.domain_id, zid = %session.zid(), "lab: on the ROS 2 graph");
        let counts = vec![Counts::default(); named.len()];
        Ok(Self { inbox, robots: named, counts, _held: (subscribers, tokens), _bus: bus })
    }

    /// Hands every sample since the last drain to its robot's body, at the
    /// lab time its arrival maps to ([`lab_time`]).
    pub fn drain(&mut self, lab: &mut Lab, t0: Instant, speed: f64) {
        let samples = std::mem::take(&mut *self.inbox.lock().unwrap_or_else(PoisonError::into_inner));
        for (index, wall, bytes) in samples {
            let ((robot, message, topic), counts) = (&self.robots[index], &mut self.counts[index]);
            let velocity = match decode(*message, &bytes) {
                Ok(v) => v,
                Err(e) => {
                    counts.undecodable += 1;
                    let n = counts.undecodable;
                    tracing::warn!(robot = robot.0, %topic, error = %e, undecodable = n, "lab: a cmd_vel sample is not a {message}");
                    continue;
                }
            };
            let at = lab_time(wall, t0, speed, lab.now());
            if lab.command(*robot, at, velocity) {
                counts.commands += 1;
                counts.last = Some(velocity);
            } else {
                counts.unplaced += 1;
                tracing::debug!(robot = robot.0, "lab: a command for a robot off the arena, lost");
            }
        }
    }

    /// What became of robot `id`'s samples.
    pub fn counts(&self, id: RobotId) -> Counts {
        self.robots.iter().position(|(r, _, _)| *r == id).map(|i| self.counts[i]).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_ros2::msgs::RosMessage;

    #[test]
    fn both_messages_decode_to_a_planar_command_and_garbage_does_not() {
        let cdr = Twist::planar(0.15, -0.4).to_cdr();
        assert_eq!(decode(VelocityMessage::Twist, &cdr), Ok(Velocity { linear: 0.15, angular: -0.4 }));
        let stamped = TwistStamped { twist: Twist::planar(0.1, 0.2), ..TwistStamped::default() }.to_cdr();
        assert_eq!(
            decode(VelocityMessage::TwistStamped, &stamped),
            Ok(Velocity { linear: 0.1, angular: 0.2 })
        );
        assert!(decode(VelocityMessage::TwistStamped, &cdr).is_err(), "a Twist is no TwistStamped");
        assert!(decode(VelocityMessage::Twist, &[0, 1, 0, 0, 7]).is_err());
    }

    #[test]
    fn arrivals_map_to_lab_time_at_the_lab_s_speed_never_past_its_now() {
        let t0 = Instant::now();
        let at = |ms: u64, speed: f64, now_ms: u64| {
            lab_time(t0 + Duration::from_millis(ms), t0, speed, Duration::from_millis(now_ms))
        };
        assert_eq!(at(100, 1.0, 1000), Duration::from_millis(100));
        assert_eq!(at(100, 4.0, 1000), Duration::from_millis(400));
        assert_eq!(at(100, 4.0, 300), Duration::from_millis(300), "a late lab takes it now");
        assert_eq!(lab_time(t0, t0 + Duration::from_secs(1), 2.0, Duration::ZERO), Duration::ZERO);
    }
}
