//! The orchestrator's ports on the bus, with recording and bad-traffic
//! counting built in.
//!
//! Why raw byte ports under the typed messages: the recording must hold
//! every message exactly as it crossed the bus — including garbage that
//! does not decode — so bytes are recorded first and decoded second. Every
//! message the orchestrator sends is encoded once, recorded, published.
//!
//! Ports to a robot (its command topic, its pose topic) are opened before
//! its agent is spawned, so nothing the agent publishes after it starts can
//! be missed (the bus keeps no history).

use super::recording::Recording;
use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::bus::{Bus, BusError, Publish, Subscribe};
use bycoms_protocol::msg::{FromAgent, GateEvent, Pose, ToAgent};
use bycoms_protocol::{decode, encode, Message, RobotId, Swarm, TopicName, MAX_MESSAGE_LEN};
use bycoms_sim::agent_process::{BadKind, Traffic};
use std::collections::BTreeMap;
use std::time::Duration;

type Pub = <IpcBus as Bus>::Publisher;
type Sub = <IpcBus as Bus>::Subscriber;

const WHO: &str = "launch";

/// Schema names in the recording.
pub mod schema {
    /// Orchestrator → agent commands.
    pub const TO_AGENT: &str = "bycoms.ToAgent";
    /// Agent → orchestrator reports.
    pub const FROM_AGENT: &str = "bycoms.FromAgent";
    /// Motion capture.
    pub const POSE: &str = "bycoms.Pose";
    /// Gate decisions.
    pub const GATE: &str = "bycoms.GateEvent";
}

/// Every port the orchestrator uses, and what it counted.
pub struct Ports {
    bus: IpcBus,
    swarm: Swarm,
    to_agent: BTreeMap<u32, (TopicName, Pub)>,
    poses: BTreeMap<u32, (TopicName, Sub)>,
    relays: BTreeMap<u32, Pub>,
    from_agents: (TopicName, Sub),
    gate: (TopicName, Pub),
    /// The recording everything goes into.
    pub recording: Recording,
    /// Bad messages seen.
    pub traffic: Traffic,
    buf: Vec<u8>,
}

impl Ports {
    /// Opens the shared ports on `bus`.
    pub fn open(bus: IpcBus, swarm: Swarm, recording: Recording) -> Result<Self, BusError> {
        let from = *swarm.from_agents().name();
        let gate = *swarm.gate().name();
        let from_agents = (from, bus.subscriber(&from)?);
        let gate = (gate, bus.publisher(&gate)?);
        let buf = vec![0u8; bus.limits().max_payload];
        Ok(Self {
            bus,
            swarm,
            to_agent: BTreeMap::new(),
            poses: BTreeMap::new(),
            relays: BTreeMap::new(),
            from_agents,
            gate,
            recording,
            traffic: Traffic::default(),
            buf,
        })
    }

    /// Opens robot `robot`'s command and pose ports (before its agent starts).
    pub fn open_robot(&mut self, robot: u32) -> Result<(), BusError> {
        let id = RobotId(robot);
        if !self.to_agent.contains_key(&robot) {
            let name = *self.swarm.to_agent(id).name();
            self.to_agent.insert(robot, (name, self.bus.publisher(&name)?));
        }
        if !self.poses.contains_key(&robot) {
            let name = *self.swarm.pose(id).name();
            self.poses.insert(robot, (name, self.bus.subscriber(&name)?));
        }
        Ok(())
    }

    /// Sends a command to robot `robot` (whose ports are open).
    pub fn send(&mut self, robot: u32, msg: &ToAgent) -> Result<(), BusError> {
        let Some((name, publisher)) = self.to_agent.get(&robot) else {
            return Err(BusError::InvalidConfig("command to a robot whose ports are not open"));
        };
        send_recorded(&mut self.recording, name, publisher, schema::TO_AGENT, msg)
    }

    /// Publishes a gate event.
    pub fn publish_gate(&mut self, event: &GateEvent) -> Result<(), BusError> {
        let (name, publisher) = &self.gate;
        send_recorded(&mut self.recording, name, publisher, schema::GATE, event)?;
        // The same event as JSON, for people and Foxglove (the bytes above
        // are what crossed the bus).
        let json_topic = format!("{}/json", name.as_str());
        self.recording.json(&json_topic, schema::GATE, event);
        Ok(())
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
            Some(publisher) => send_recorded(&mut self.recording, &name, publisher, schema::POSE, pose),
            None => Ok(()),
        }
    }

    /// The next agent report, waiting up to `timeout`: `None` when nothing
    /// came, `Some(None)` when a message came that does not decode (it was
    /// recorded, counted and skipped).
    pub fn recv_report(&mut self, timeout: Duration) -> Result<Option<Option<FromAgent>>, BusError> {
        let (name, sub) = &self.from_agents;
        let got = match timeout.is_zero() {
            true => sub.try_recv_into(&mut self.buf),
            false => sub.recv_timeout_into(&mut self.buf, timeout),
        };
        if matches!(got, Ok(None)) {
            return Ok(None);
        }
        receive_recorded(&mut self.recording, &mut self.traffic, name, schema::FROM_AGENT, got, &self.buf)
            .map(Some)
    }

    /// Takes every pending pose of every open pose topic, in robot order,
    /// and hands each (with its topic's robot) to `f`.
    pub fn drain_poses(&mut self, mut f: impl FnMut(u32, Pose)) -> Result<(), BusError> {
        for (&robot, (name, sub)) in &self.poses {
            loop {
                let got = sub.try_recv_into(&mut self.buf);
                let idle = matches!(got, Ok(None));
                if let Some(pose) = receive_recorded(
                    &mut self.recording,
                    &mut self.traffic,
                    name,
                    schema::POSE,
                    got,
                    &self.buf,
                )? {
                    f(robot, pose);
                } else if idle {
                    break;
                }
            }
        }
        Ok(())
    }

    /// Removes what dead nodes left in shared memory (agents that had to be
    /// killed cannot remove their own node).
    pub fn cleanup_dead_nodes(&self) {
        let report = self.bus.cleanup_dead_nodes();
        if report.failed > 0 {
            tracing::debug!(failed = report.failed, "some dead iceoryx2 nodes could not be cleaned");
        }
    }

    /// Counts a decoded but unacceptable message.
    pub fn count(&mut self, kind: BadKind, what: &dyn std::fmt::Display) {
        self.traffic.count(WHO, kind, what);
    }
}

fn send_recorded<M: Message>(
    recording: &mut Recording,
    topic: &TopicName,
    publisher: &Pub,
    schema: &str,
    msg: &M,
) -> Result<(), BusError> {
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    let bytes = encode(msg, &mut buf)?;
    recording.bytes(topic.as_str(), schema, bytes);
    publisher.publish(bytes)
}

fn receive_recorded<M: Message>(
    recording: &mut Recording,
    traffic: &mut Traffic,
    topic: &TopicName,
    schema: &str,
    got: Result<Option<usize>, BusError>,
    buf: &[u8],
) -> Result<Option<M>, BusError> {
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
    match decode::<M>(bytes) {
        Ok(msg) => Ok(Some(msg)),
        Err(e) => {
            let _ = traffic.absorb(WHO, topic.as_str(), BusError::Codec(e));
            Ok(None)
        }
    }
}
