//! What the agent seam tells the core of an agent: gone, and why
//! ([`Gone`]); and the core's own word for an agent reachable no more or
//! again ([`Reach`]), which its timers decide.
//!
//! Why here and not in the seam: `Gone` is the core's input
//! (`Input::Gone`) and its log records it (`log.rs`), so the core owns it;
//! the agent sources (`bycoms_launch::agents`) report it and re-export it
//! at its old path.

use std::process::ExitStatus;

/// Why an agent is gone.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Gone {
    /// The process exited (or was killed by a signal).
    Exited(#[serde(with = "raw_status")] ExitStatus),
    /// Registered, alive, but silent past the heartbeat timeout (ended:
    /// killed, or dropped from the launch when not ours to kill).
    Silent,
    /// Never registered within the registration timeout (ended).
    NeverRegistered,
    /// Did not answer a lockstep tick in time (ended).
    NoTickReply,
    /// Did not report its start pose in time after `Deploy` (ended).
    NoStartPose,
    /// Its link to the orchestrator was lost (a remote agent or gateway).
    Disconnected,
    /// No contact with it (its link was lost, or it fell silent) for longer
    /// than the launch's link grace (`supervision.unreachable_grace`, seconds ×
    /// 1000): it was unreachable and did not come back.
    Unreachable {
        /// The grace it had, in milliseconds.
        grace_ms: u64,
    },
    /// A real robot's own link (robot ↔ gateway) was lost: its gateway
    /// reported `Link { up: false }`; the gateway was ended.
    RobotLinkLost,
    /// Its thread (an in-memory launch's agent) ended.
    ThreadEnded,
}

impl Gone {
    /// What happened, and what the launch did about it. An agent that
    /// missed a deadline is ended: `killed` when it is a process of this
    /// host (`ours`), else (a remote agent, a gateway on a bridge host,
    /// a thread) only dropped from the launch — a process on another host
    /// is not ours to kill, and it was not.
    pub fn said(&self, ours: bool) -> String {
        let ended = if ours { "and was killed" } else { "and was dropped from the launch" };
        match self {
            Self::Exited(status) => format!("its process ended ({status})"),
            Self::Silent => format!("it fell silent (no heartbeat) {ended}"),
            Self::NeverRegistered => format!("it did not register in time {ended}"),
            Self::NoTickReply => format!("it did not answer a lockstep tick in time {ended}"),
            Self::NoStartPose => {
                format!("it did not report its start pose in time after being deployed {ended}")
            }
            Self::Disconnected => "its link to the orchestrator was lost".into(),
            Self::Unreachable { grace_ms } => format!(
                "its link to the orchestrator was lost and did not come back within the {} s link grace",
                *grace_ms as f64 / 1000.0
            ),
            Self::RobotLinkLost => "the robot's link to its gateway was lost".into(),
            Self::ThreadEnded => "its agent thread ended".into(),
        }
    }
}

/// As [`Gone::said`] of an agent that is a process of this host.
impl std::fmt::Display for Gone {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.said(true))
    }
}

/// An exit status as its raw `wait` status (the launch core's input log,
/// `log.rs`, records it).
mod raw_status {
    use serde::{Deserialize, Deserializer, Serializer};
    use std::os::unix::process::ExitStatusExt;
    use std::process::ExitStatus;

    pub fn serialize<S: Serializer>(status: &ExitStatus, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_i32(status.into_raw())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<ExitStatus, D::Error> {
        i32::deserialize(d).map(ExitStatus::from_raw)
    }
}

/// A change in whether an agent can be reached, as the core's timers
/// decide it (`timers.rs`): what it notes, counts as an outage and re-sends
/// on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Reach {
    /// No contact any more (liveliness token gone, or silent past the
    /// heartbeat timeout): the engine holds the robot until it is back or
    /// the grace is over.
    Lost,
    /// Heard from again within the grace.
    Back,
}
