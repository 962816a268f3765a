//! One of the launch core's inputs or outputs, as the driver handed or
//! carried it: the one stream the recording's scene and the picture's
//! trace are folded from.
//!
//! Why a type of its own: the run has one model, the core, and what else
//! shows the run (the scene, and through it the live view; the `--svg`
//! trace) is a projection of what the core was handed (poses, agent
//! reports) and what it published (gate events, a dead robot's relayed
//! pose). The driver hands each to the recording as it hands it to the
//! core or carries it out, already decoded: nobody decodes the recorded
//! bytes again (the writer thread used to, and the trace a third time),
//! and a report the core never took (another robot's, on the wrong topic)
//! shows nowhere.

use crate::core::view::{BeaconAt, StateChange};
use bycoms_protocol::msg::{FromAgent, GateEvent, Pose};

/// A core input or output the recording's projections take in.
#[derive(Clone, Debug, PartialEq)]
pub enum Seen {
    /// A robot's pose the core was handed, or a dead robot's it relayed.
    Pose(Pose),
    /// A gate decision the core published.
    Gate(GateEvent),
    /// An agent's report the core was handed.
    Report(FromAgent),
    /// The core's beacon table changed (`Output::Beacon`).
    Beacon(BeaconAt),
    /// A robot's state changed in the core (`Output::State`).
    State(StateChange),
}
