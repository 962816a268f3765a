//! A mixed swarm's poses: motion capture for the real robots, the bus for
//! the simulated ones.
//!
//! Why a source of its own: in a lab, the real robots are seen by its
//! motion capture (NatNet, a ROS 2 driver), which does not see the
//! simulated members of a mixed swarm; those are their own motion capture
//! and publish their poses on the bus, as every simulated robot does. The
//! engine holds one [`PoseSource`]; this one hands robot `k`'s poses from
//! the source that sees it, robots in id order across both, and records
//! each as its own source would: the motion capture's poses decoded, the
//! bus's messages byte for byte.

use super::bus::BusPoses;
use super::{PoseError, PoseSink, PoseSource};

/// Motion capture for the real robots, the bus for `simulated`.
pub struct MergedPoses {
    mocap: Box<dyn PoseSource>,
    bus: BusPoses,
    simulated: Vec<u32>,
}

impl MergedPoses {
    /// The poses of robots `simulated` (sorted here) from `bus`, every
    /// other robot's from `mocap`.
    pub fn new(mocap: Box<dyn PoseSource>, bus: BusPoses, mut simulated: Vec<u32>) -> Self {
        simulated.sort_unstable();
        Self { mocap, bus, simulated }
    }

    fn is_simulated(&self, id: u32) -> bool {
        self.simulated.binary_search(&id).is_ok()
    }
}

impl PoseSource for MergedPoses {
    fn kind(&self) -> &'static str {
        "mixed"
    }

    /// Not on the bus as a whole: the motion capture's poses are recorded
    /// decoded by the sink; the bus's part records its raw bytes itself
    /// ([`PoseSink::on_the_bus`]).
    fn on_the_bus(&self) -> bool {
        false
    }

    fn open_robot(&mut self, id: u32) -> Result<(), PoseError> {
        match self.is_simulated(id) {
            true => self.bus.open_robot(id),
            false => self.mocap.open_robot(id),
        }
    }

    fn drain(&mut self, sink: &mut PoseSink<'_>) -> Result<(), PoseError> {
        let first = sink.handed();
        self.mocap.drain(sink)?;
        sink.on_the_bus(|sink| self.bus.drain(sink))?;
        sink.in_robot_order_from(first);
        Ok(())
    }

    fn carried(&mut self, id: u32, by_hand: bool) {
        if !self.is_simulated(id) {
            self.mocap.carried(id, by_hand);
        }
    }
}
