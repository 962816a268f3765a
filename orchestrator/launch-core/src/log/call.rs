//! One call a shell made on the core, as the current version of the log
//! records it: a file of its own, so that the log (`log.rs`) and the
//! upgrades from older versions (`log/v1.rs`) both name it, neither
//! through the other.

use crate::Input;
use serde::{Deserialize, Serialize};

/// One call a shell made on the core.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Call {
    /// [`LaunchCore::handle`](crate::LaunchCore::handle) at this launch time (µs).
    Handle(u64, Input),
    /// [`LaunchCore::advance`](crate::LaunchCore::advance) at this launch time (µs).
    Advance(u64),
    /// [`LaunchCore::handle`](crate::LaunchCore::handle) of a pose that the recording holds already.
    /// A pose is stored once: the log names it, `log::resolve` reads it back.
    HandleRecordedPose {
        /// The launch time (µs).
        at: u64,
        /// The robot the pose source saw it for ([`Input::Pose`]'s `topic`).
        topic: u32,
        /// Its number (from 0) among the messages recorded on that robot's
        /// pose topic.
        number: u32,
        /// `log::fingerprint` of the pose: a pose on the record that is not
        /// the one the core was handed (changed, or another) is caught.
        fingerprint: u32,
    },
}
