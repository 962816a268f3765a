//! The orchestrator's ports on the bus, with recording and bad-traffic
//! counting built in.
//!
//! Why raw byte ports under the typed messages: the recording must hold
//! every message exactly as it crossed the bus — including garbage that
//! does not decode — so bytes are recorded first and decoded second. Every
//! message the orchestrator sends is encoded once, recorded, published.
//!
//! A robot's command port is opened before its agent is started (as its
//! pose source is), so nothing sent after it starts can be missed (the bus
//! keeps no history). Every robot's report topic is read at once, from the
//! start, by one fan-in (`Bus::fan_in`); a report whose robot is not its
//! topic's is forged (over zenoh the access control lets robot k's
//! certificate publish only under robot k): counted, recorded, dropped. The ports are on a [`SharedBus`]: any backend (see
//! `transport`). Poses are not read here but by the launch's pose source
//! (`poses`), which may not be the bus at all.

use super::observe::Observer;
use super::poses::PoseBytes;
use super::recording::{Recording, Seen};
use super::transport::{AnyPublisher, AnySubscriber, SharedBus};
use crate::core::view::{BeaconAt, StateChange};
use bycoms_protocol::bus::{untag, BusError, FAN_IN_TAG};
use bycoms_protocol::msg::{Beacon, Deploy, FromAgent, GateEvent, Pose, ToAgent};
use bycoms_protocol::{decode, encode, Message, RobotId, Swarm, TopicName, MAX_MESSAGE_LEN};
use bycoms_runtime::{BadKind, Traffic};
use std::collections::BTreeMap;
use std::time::Duration;

type Pub = AnyPublisher;
type Sub = AnySubscriber;

const WHO: &str = "launch";

/// Schema names in the recording: the recording's own, defined once.
pub use bycoms_record::schema;

/// Every port the orchestrator uses, and what it counted.
pub struct Ports {
    bus: SharedBus,
    swarm: Swarm,
    to_agent: BTreeMap<u32, (TopicName, Pub)>,
    relays: BTreeMap<u32, Pub>,
    /// Every robot's `from_agent` topic, in robot order (robot k at k − 1),
    /// and the fan-in that reads them all.
    reports: (Vec<TopicName>, Sub),
    gate: (TopicName, Pub),
    /// Opened at the first placement request (real robots only).
    operator: Option<(TopicName, Pub)>,
    /// The recording everything goes into.
    pub recording: Recording,
    /// Who else sees every pose and gate event (e.g. the live view).
    pub observers: Vec<Box<dyn Observer>>,
    /// Bad messages seen.
    pub traffic: Traffic,
    /// The last pose of each robot as encoded (an off-bus pose once per
    /// frame, by its pose sink: [`PoseBytes`]).
    pub pose_bytes: PoseBytes,
    buf: Vec<u8>,
}

impl Ports {
    /// Opens the shared ports on `bus`, and the reports of robots
    /// 1..=`robots`.
    pub fn open(bus: SharedBus, swarm: Swarm, robots: u32, recording: Recording) -> Result<Self, BusError> {
        let topics: Vec<TopicName> = (1..=robots).map(|k| *swarm.from_agent(RobotId(k)).name()).collect();
        let gate = *swarm.gate().name();
        let fan_in = bus.fan_in(&topics)?;
        let reports = (topics, fan_in);
        let gate = (gate, bus.publisher(&gate)?);
        let buf = vec![0u8; bus.limits().max_payload + FAN_IN_TAG];
        Ok(Self {
            bus,
            swarm,
            to_agent: BTreeMap::new(),
            relays: BTreeMap::new(),
            reports,
            gate,
            operator: None,
            recording,
            observers: Vec::new(),
            traffic: Traffic::default(),
            pose_bytes: PoseBytes::default(),
            buf,
        })
    }

    /// Opens robot `robot`'s command port (before its agent starts).
    pub fn open_robot(&mut self, robot: u32) -> Result<(), BusError> {
        if !self.to_agent.contains_key(&robot) {
            let name = *self.swarm.to_agent(RobotId(robot)).name();
            self.to_agent.insert(robot, (name, self.bus.publisher(&name)?));
        }
        Ok(())
    }

    /// The bus the ports are on (a bus pose source opens its own there).
    pub fn bus(&self) -> &SharedBus {
        &self.bus
    }

    /// What a pose source's sink records into and counts in.
    pub fn intake(&mut self) -> (&mut Recording, &mut Traffic, &Swarm) {
        (&mut self.recording, &mut self.traffic, &self.swarm)
    }

    /// The swarm the ports are of.
    pub fn swarm(&self) -> &Swarm {
        &self.swarm
    }

    /// Sends a command to robot `robot` (whose ports are open); `more`:
    /// another command to it follows at once, and only that one wakes it.
    pub fn send(&mut self, robot: u32, msg: &ToAgent, more: bool) -> Result<(), BusError> {
        let Some((name, publisher)) = self.to_agent.get(&robot) else {
            return Err(BusError::InvalidConfig("command to a robot whose ports are not open"));
        };
        // The last of a batch wakes the agent, which then reads them all.
        send_recorded(&mut self.recording, name, publisher, schema::TO_AGENT, msg, more)
    }

    /// Publishes a gate event.
    pub fn publish_gate(&mut self, event: &GateEvent) -> Result<(), BusError> {
        let (name, publisher) = &self.gate;
        // The recording adds the decoded event (`gate/json`, the log, the scene).
        send_recorded(&mut self.recording, name, publisher, schema::GATE, event, false)?;
        self.observers.iter_mut().for_each(|o| o.gate(event));
        Ok(())
    }

    /// Asks the lab's operator to place a robot (`bycoms/<swarm>/operator`).
    pub fn ask_operator(&mut self, request: &Deploy) -> Result<(), BusError> {
        if self.operator.is_none() {
            let name = *self.swarm.operator().name();
            self.operator = Some((name, self.bus.publisher(&name)?));
        }
        match &self.operator {
            Some((name, publisher)) => {
                send_recorded(&mut self.recording, name, publisher, schema::OPERATOR, request, false)
            }
            None => Ok(()),
        }
    }

    /// Publishes a dead robot's last pose on its pose topic, as motion
    /// capture keeps seeing the body: it stays a source of the field.
    pub fn relay(&mut self, pose: &Pose) -> Result<(), BusError> {
        let robot = pose.robot.0;
        let name = *self.swarm.pose(pose.robot).name();
        if !self.relays.contains_key(&robot) {
            self.relays.insert(robot, self.bus.publisher(&name)?);
        }
        match self.relays.get(&robot) {
            Some(publisher) => {
                send_recorded(&mut self.recording, &name, publisher, schema::POSE, pose, false)
            }
            None => Ok(()),
        }
    }

    /// Publishes a pose from a pose source off the bus (NatNet) on its
    /// robot's pose topic, for the robot's gateway; not recorded again
    /// (the pose sink recorded it), nor encoded again (its sink's bytes,
    /// [`PoseBytes`]).
    pub fn forward_pose(&mut self, pose: &Pose) -> Result<(), BusError> {
        let robot = pose.robot.0;
        if !self.relays.contains_key(&robot) {
            let name = *self.swarm.pose(pose.robot).name();
            self.relays.insert(robot, self.bus.publisher(&name)?);
        }
        let bytes = self.pose_bytes.of(pose)?;
        match self.relays.get(&robot) {
            Some(publisher) => publisher.publish(bytes),
            None => Ok(()),
        }
    }

    /// The next agent report, waiting up to `timeout`: `None` when nothing
    /// came, `Some(None)` when a message came that does not decode or that
    /// names another robot than its topic's (it was recorded, counted and
    /// skipped).
    pub fn recv_report(&mut self, timeout: Duration) -> Result<Option<Option<FromAgent>>, BusError> {
        let (topics, fan_in) = &self.reports;
        let got = match timeout.is_zero() {
            true => fan_in.try_recv_into(&mut self.buf),
            false => fan_in.recv_timeout_into(&mut self.buf, timeout),
        };
        let n = match got {
            Ok(None) => return Ok(None),
            Ok(Some(n)) => n,
            Err(e) => {
                let name = topics.first().map(|t| t.doorbell());
                let what = name.as_ref().map_or("from_agent", |t| t.as_str());
                return match self.traffic.absorb(WHO, what, e) {
                    None => Ok(Some(None)),
                    Some(fatal) => Err(fatal),
                };
            }
        };
        let Some((index, payload)) = untag(self.buf.get(..n).unwrap_or_default()) else {
            return Ok(Some(None));
        };
        let Some(name) = topics.get(index) else {
            return Ok(Some(None));
        };
        let topic_robot = index as u32 + 1;
        let report: Option<FromAgent> = receive_recorded(
            &mut self.recording,
            &mut self.traffic,
            name,
            schema::FROM_AGENT,
            Ok(Some(payload.len())),
            payload,
        )?;
        if let Some(r) = &report {
            if r.robot().0 != topic_robot {
                let text = format!("a report of robot {} on robot {topic_robot}'s topic", r.robot().0);
                self.traffic.count(WHO, BadKind::UnknownRobot, &text);
                return Ok(Some(None));
            }
            self.observers.iter_mut().for_each(|o| o.report(r));
        }
        Ok(Some(report))
    }

    /// Shows a pose the launch core applied (`Output::Moved`) to everything
    /// that shows the run: recorded on `core/moved` (what `draw` and
    /// `record export --ros2` read), handed to the recording's scene and
    /// trace and to the observers (the live view, ROS 2). The one way a pose
    /// reaches a view: one the core refused, ignored or held back never
    /// does (the bus's pose topics still record every pose as it came).
    pub fn show_moved(&mut self, robot: u32, pose: &Pose) {
        if pose.robot.0 != robot {
            return;
        }
        if self.recording.is_on() {
            match self.pose_bytes.of(pose) {
                Ok(bytes) => {
                    let topic = schema::Topics::new(self.swarm.as_str()).moved();
                    self.recording.bytes(&topic, schema::MOVED, bytes);
                }
                Err(e) => tracing::warn!(robot, "an applied pose not recorded: {e}"),
            }
        }
        self.recording.seen(Seen::Pose(*pose));
        self.observers.iter_mut().for_each(|o| o.pose(pose));
    }

    /// Shows that robot `robot`'s beacon stands at `at` (the launch
    /// core's beacon table changed, `Output::Beacon`) to everything that
    /// shows the run, as [`Ports::show_moved`] shows poses: recorded on
    /// `core/beacon` (what `draw` and `record export --ros2` read), handed
    /// to the recording's scene and trace and to the observers.
    pub fn show_beacon(&mut self, beacon: BeaconAt) {
        let BeaconAt { robot, at } = beacon;
        if self.recording.is_on() {
            let beacon = ToAgent::Beacon(Beacon { robot: RobotId(robot), x: at.x, y: at.y, seq: 0 });
            let mut buf = [0u8; MAX_MESSAGE_LEN];
            match encode(&beacon, &mut buf) {
                Ok(bytes) => {
                    let topic = schema::Topics::new(self.swarm.as_str()).beacon();
                    self.recording.bytes(&topic, schema::BEACON, bytes);
                }
                Err(e) => tracing::warn!(robot, "a beacon not recorded: {e}"),
            }
        }
        self.recording.seen(Seen::Beacon(beacon));
        self.observers.iter_mut().for_each(|o| o.beacon(robot, at));
    }

    /// Shows that robot `robot`'s state changed to `state` (the launch
    /// core's slot, `Output::State`) to everything that shows the run, as
    /// [`Ports::show_beacon`] shows beacons: recorded on `core/state` (what
    /// `record export --ros2` reads), handed to the recording's scene and
    /// to the observers.
    pub fn show_state(&mut self, change: StateChange) {
        let StateChange { robot, state } = change;
        let topic = schema::Topics::new(self.swarm.as_str()).state();
        let slot = bycoms_record::scene::json::RobotSlot { robot, state };
        self.recording.json(&topic, schema::CORE_STATE, &slot);
        self.recording.seen(Seen::State(change));
        self.observers.iter_mut().for_each(|o| o.state(robot, state));
    }

    /// Hands the observers what the run's scene produced since the last
    /// call (the recording fed it as the messages were recorded).
    pub fn show_scene(&mut self) {
        let outs = self.recording.take_scene();
        if !outs.is_empty() {
            self.observers.iter_mut().for_each(|o| o.scene(&outs));
        }
    }

    /// Removes what dead nodes left in shared memory (agents that had to be
    /// killed cannot remove their own node).
    pub fn cleanup_dead_nodes(&self) {
        self.bus.cleanup_dead_nodes();
    }

    /// Counts a decoded but unacceptable message.
    pub fn count(&mut self, kind: BadKind, what: &dyn std::fmt::Display) {
        self.traffic.count(WHO, kind, what);
    }
}

/// Publishes `msg` and records it; `more`: another message on this topic
/// follows at once and wakes its readers ([`Publish::publish_quietly`]).
fn send_recorded<M: Message>(
    recording: &mut Recording,
    topic: &TopicName,
    publisher: &Pub,
    schema: &str,
    msg: &M,
    more: bool,
) -> Result<(), BusError> {
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    let bytes = encode(msg, &mut buf)?;
    recording.bytes(topic.as_str(), schema, bytes);
    match more {
        true => publisher.publish_quietly(bytes),
        false => publisher.publish(bytes),
    }
}

fn receive_recorded(
    recording: &mut Recording,
    traffic: &mut Traffic,
    topic: &TopicName,
    schema: &str,
    got: Result<Option<usize>, BusError>,
    buf: &[u8],
) -> Result<Option<FromAgent>, BusError> {
    let n = match got {
        Ok(Some(n)) => n,
        Ok(None) => return Ok(None),
        Err(e) => {
            return match traffic.absorb(WHO, topic.as_str(), e) {
                None => Ok(None),
                Some(fatal) => Err(fatal),
            }
        }
    };
    let bytes = buf.get(..n).unwrap_or_default();
    recording.bytes(topic.as_str(), schema, bytes);
    match decode::<FromAgent>(bytes) {
        Ok(report) => Ok(Some(report)),
        Err(e) => {
            let _ = traffic.absorb(WHO, topic.as_str(), BusError::Codec(e));
            Ok(None)
        }
    }
}
