//! What the views show, as outputs: the poses the core applies
//! ([`Output::Moved`]), the changes of its beacon table
//! ([`Output::Beacon`]) and of its robots' states ([`Output::State`]),
//! beside its gate events. Every view folds these into one
//! [`crate::view::RunView`] (issue 53).
//!
//! Why an output: what shows the run (the live view, ROS 2, the
//! recording's scene and `core/moved`, the `--svg` trace, and the bag
//! `record export --ros2` makes) used to be handed every pose the pose
//! source delivered, before the core judged it. So a robot revoked by
//! `orchestrator revoke` went on moving in Foxglove and on ROS 2, and a
//! forged pose at the goal, refused by the core, was drawn there (issue
//! 53). The core knows which poses it applies; it says so once, for each
//! pose it makes a robot's latest, and the driver shows only those. A pose
//! refused as implausible (`plausible.rs`), of another robot's topic, a
//! repeat or a late sample, one held back for a later tick (`ahead.rs`, it
//! is moved when its tick comes), or of a robot dead, revoked or not
//! deployed yet is never moved. Not even while an operator places it: the
//! placement check reads those poses, but with no start pose to judge
//! them against the core cannot tell the robot's own from a forger's at
//! the goal; a robot is shown from its start pose on. The bus's
//! pose topics are still recorded byte for byte: `orchestrator replay`
//! hands the core the poses it was handed (`log.rs`).
//!
//! Why beacons and states too: each view kept its own map of beacons from
//! the gate events (the scene's never crept; ROS 2 restated the core's
//! creep rule) and decided states on its own. The core owns both facts
//! (its beacon table, `beacon_table.rs`; its slots, `slot.rs`), so it says
//! each change as it makes it, in the order it makes them.

use super::*;
use bycoms_gate::view::{BeaconAt, StateChange};

impl LaunchCore {
    /// Robot `id`'s `pose` was applied: the views show it.
    pub(super) fn moved(&mut self, id: u32, pose: Pose) {
        self.outputs.push_back(Output::Moved { robot: id, pose });
    }

    /// Robot `id`'s beacon now stands at `pose` (the table changed).
    pub(super) fn shown_beacon(&mut self, id: u32, pose: &Pose) {
        self.outputs.push_back(Output::Beacon(BeaconAt { robot: id, at: Vec2::new(pose.x, pose.y) }));
    }

    /// Robot `id`'s state becomes `state`; said when it changes.
    pub(super) fn set_state(&mut self, id: u32, state: SlotState) {
        let Some(slot) = self.slot(id) else { return };
        if slot.state != state {
            slot.state = state;
            self.outputs.push_back(Output::State(StateChange { robot: id, state }));
        }
    }
}
