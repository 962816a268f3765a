//! Poses from the bus: the agents' own simulated motion capture.
//!
//! Why this is a pose source like any other: a simulated agent is its
//! robot *and* the motion capture that sees it, so it publishes its pose on
//! `bycoms/<swarm>/robot/<id>/pose` (where later agents read their beacons
//! too). This source subscribes to those topics — one subscriber per robot,
//! opened before the robot's agent starts, since the bus keeps no history —
//! and records every message byte for byte before decoding it.

use super::{PoseError, PoseSink, PoseSource};
use crate::launch::transport::{AnySubscriber, SharedBus};
use bycoms_protocol::bus::BusError;
use bycoms_protocol::msg::Pose;
use bycoms_protocol::{decode, RobotId, Swarm, TopicName};
use std::collections::BTreeMap;

/// The pose topics of the opened robots.
pub struct BusPoses {
    bus: SharedBus,
    swarm: Swarm,
    topics: BTreeMap<u32, (TopicName, AnySubscriber)>,
    buf: Vec<u8>,
}

impl BusPoses {
    /// A source on `bus` for `swarm`; no robot opened yet.
    pub fn new(bus: SharedBus, swarm: Swarm) -> Self {
        let buf = vec![0u8; bus.limits().max_payload];
        Self { bus, swarm, topics: BTreeMap::new(), buf }
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
        if !self.topics.contains_key(&id) {
            let name = *self.swarm.pose(RobotId(id)).name();
            self.topics.insert(id, (name, self.bus.subscriber(&name)?));
        }
        Ok(())
    }

    fn drain(&mut self, sink: &mut PoseSink<'_>) -> Result<(), PoseError> {
        for (&robot, (name, sub)) in &self.topics {
            loop {
                let n = match sub.try_recv_into(&mut self.buf) {
                    Ok(Some(n)) => n,
                    Ok(None) => break,
                    Err(e) => {
                        sink.bad(name.as_str(), e)?;
                        continue;
                    }
                };
                let bytes = self.buf.get(..n).unwrap_or_default();
                sink.raw(name.as_str(), bytes);
                match decode::<Pose>(bytes) {
                    Ok(pose) => sink.pose(robot, pose),
                    Err(e) => sink.bad(name.as_str(), BusError::Codec(e))?,
                }
            }
        }
        Ok(())
    }
}
