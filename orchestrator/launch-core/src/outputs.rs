//! What the core asks its shell to do ([`Output`]), and which of it the
//! views show ([`Output::shown`]).
//!
//! Why a file of its own: the outputs are the core's whole contract with
//! its shells (the driver, the harness, replay), read by each of them; the
//! rules that make them live beside the state they change.

use crate::events::LaunchEvent;
use bycoms_gate::view::{self, BeaconAt, StateChange};
use bycoms_protocol::msg::{Deploy, GateEvent, Pose, ToAgent};
use bycoms_runtime::BadKind;

/// Something to do, from [`LaunchCore::poll`].
#[derive(Clone, Debug, PartialEq)]
pub enum Output {
    /// Open robot `.0`'s ports and poses, start its agent, and answer with
    /// [`Input::Started`] (or [`Input::Failed`]).
    Start(u32),
    /// Send a command to robot `.0`'s agent.
    Send(u32, ToAgent),
    /// Republish a dead robot's last pose (motion capture still sees it).
    Relay(Pose),
    /// Pass a pose from off the bus on to the agents.
    Forward(Pose),
    /// Publish a gate event.
    Gate(GateEvent),
    /// Record an event of a robot's agent.
    Event(LaunchEvent),
    /// A line for the terminal.
    Note(String),
    /// Count (and log) bad traffic.
    Bad(BadKind, String),
    /// End robot `.0`'s agent now.
    Kill(u32),
    /// Robot `.0`'s agent was heard from (registered and alive: a source
    /// asks an agent never heard from to end differently at wind-down).
    Heard(u32),
    /// What is sent from now on belongs to this simulated time, ns.
    SimTime(u64),
    /// Ask the operator to place a robot at the start.
    AskOperator(Deploy),
    /// Robot `.0` is being carried by hand (`true`) or was placed (`false`).
    Carried(u32, bool),
    /// Robot `robot`'s pose, applied: the core made it the robot's latest
    /// (it is the robot's own, plausible, newer than the last, of a robot
    /// alive and not revoked, due at the tick in flight). What shows the
    /// run (the live view, ROS 2, the recording's scene and `core/moved`,
    /// the `--svg` trace) shows these poses and no other: a pose refused,
    /// repeated, held back or of a dead or revoked robot is never moved.
    Moved {
        /// The robot.
        robot: u32,
        /// Its pose.
        pose: Pose,
    },
    /// Robot `robot`'s beacon stands at `at`: the beacon table changed (it
    /// became a beacon, judged stuck or lost; or its beacon crept on with
    /// its applied pose). The table never removes a beacon. Kept and said
    /// in every launch, whether or not its agents are sent beacons.
    Beacon(BeaconAt),
    /// Robot `robot`'s state changed to `state` (said on every change of
    /// its slot's state, in the order the core makes them).
    State(StateChange),
}

impl Output {
    /// What this output shows of the run, if anything: the facts every
    /// view folds ([`view::RunView`]).
    pub fn shown(&self) -> Option<view::Shown> {
        Some(match *self {
            Output::Moved { pose, .. } => view::Shown::Moved(pose),
            Output::Beacon(beacon) => view::Shown::Beacon(beacon),
            Output::State(change) => view::Shown::State(change),
            Output::Gate(event) => view::Shown::Gate(event),
            _ => return None,
        })
    }
}
