//! Poses from the bus: the agents' own simulated motion capture.
//!
//! Why this is a pose source like any other: a simulated agent is its
//! robot *and* the motion capture that sees it, so it publishes its pose on
//! `bycoms/<swarm>/robot/<id>/pose`. This source reads every robot's pose
//! topic through one fan-in (`Bus::fan_in`), opened when the source is
//! made, before any agent starts, since the bus keeps no history; poses of
//! robots not opened yet are dropped unseen, as before they were never
//! subscribed. Why a fan-in and not a subscriber per robot: over iceoryx2 a
//! subscriber with a wake-up of its own is about ten open files in the
//! orchestrator, and a drain would look at every topic; the fan-in shares
//! one wake-up and reads only the topics that rang. A drain still hands
//! over robots in id order (it sorts what it read, stably), and records
//! every message byte for byte before decoding it.

use super::{PoseError, PoseSink, PoseSource};
use crate::transport::{AnySubscriber, SharedBus};
use bycoms_protocol::bus::{untag, BusError, FAN_IN_TAG};
use bycoms_protocol::msg::Pose;
use bycoms_protocol::{decode, RobotId, Swarm, TopicName};

/// The pose topics of robots 1..=n, read through one fan-in.
pub struct BusPoses {
    /// Robot k's pose topic at k − 1.
    topics: Vec<TopicName>,
    fan_in: AnySubscriber,
    /// Whether robot k is opened, at k − 1.
    opened: Vec<bool>,
    buf: Vec<u8>,
    /// What one drain read: (robot, where its bytes are in `read`).
    pending: Vec<(u32, std::ops::Range<usize>)>,
    read: Vec<u8>,
}

impl BusPoses {
    /// A source on `bus` for robots 1..=`robots` of `swarm`; no robot
    /// opened yet.
    pub fn new(bus: SharedBus, swarm: Swarm, robots: u32) -> Result<Self, PoseError> {
        let topics: Vec<TopicName> = (1..=robots.max(1)).map(|k| *swarm.pose(RobotId(k)).name()).collect();
        let fan_in = bus.fan_in(&topics)?;
        let buf = vec![0u8; bus.limits().max_payload + FAN_IN_TAG];
        let opened = vec![false; topics.len()];
        Ok(Self { topics, fan_in, opened, buf, pending: Vec::new(), read: Vec::new() })
    }
}

impl PoseSource for BusPoses {
    fn kind(&self) -> &'static str {
        "bus"
    }

    fn on_the_bus(&self) -> bool {
        true
    }

    fn open_robot(&mut self, id: u32) -> Result<(), PoseError> {
        match id.checked_sub(1).and_then(|i| self.opened.get_mut(i as usize)) {
            Some(opened) => {
                *opened = true;
                Ok(())
            }
            None => Err(PoseError::Bus(BusError::InvalidConfig("a robot beyond the launch's robots"))),
        }
    }

    fn drain(&mut self, sink: &mut PoseSink<'_>) -> Result<(), PoseError> {
        self.pending.clear();
        self.read.clear();
        loop {
            let n = match self.fan_in.try_recv_into(&mut self.buf) {
                Ok(Some(n)) => n,
                Ok(None) => break,
                Err(e) => {
                    let bell = self.topics.first().map(TopicName::doorbell);
                    sink.bad(bell.as_ref().map_or("pose", TopicName::as_str), e)?;
                    continue;
                }
            };
            let Some((index, payload)) = untag(self.buf.get(..n).unwrap_or_default()) else { continue };
            if self.opened.get(index) != Some(&true) {
                continue;
            }
            let start = self.read.len();
            self.read.extend_from_slice(payload);
            self.pending.push((index as u32 + 1, start..self.read.len()));
        }
        // Robots in id order, each robot's poses in arrival order.
        self.pending.sort_by_key(|(robot, _)| *robot);
        for (robot, range) in &self.pending {
            let Some(name) = self.topics.get(*robot as usize - 1) else { continue };
            let bytes = self.read.get(range.clone()).unwrap_or_default();
            sink.raw(name.as_str(), bytes);
            match decode::<Pose>(bytes) {
                Ok(pose) => sink.pose(*robot, pose),
                Err(e) => sink.bad(name.as_str(), BusError::Codec(e))?,
            }
        }
        Ok(())
    }
}
