//! A bus message as the launch decoded it: the one typed form the
//! recording's scene and the picture's trace are folded from.
//!
//! Why a type of its own: the launch decodes every pose, gate event and
//! agent report it receives or sends anyway; handing that form to the
//! recording along with the bytes means nobody decodes them again (the
//! writer thread used to, and the picture's trace a third time), and the
//! scene and the trace see exactly what the launch saw.

use bycoms_protocol::msg::{FromAgent, GateEvent, Pose};

/// A decoded bus message the recording's projections take in.
#[derive(Clone, Debug, PartialEq)]
pub enum Seen {
    /// A robot's pose, as motion capture reported it (or the launch relayed it).
    Pose(Pose),
    /// A gate decision, as published.
    Gate(GateEvent),
    /// An agent's report.
    Report(FromAgent),
}
