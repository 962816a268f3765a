//! The core's calls, as a launch made them: what `replay` feeds the same
//! core.
//!
//! Why a log of calls and not of messages: the core is deterministic, so
//! its decisions follow from the inputs it was handed *and* from when the
//! shell asked it to decide (`advance`): a shell hands in everything that
//! arrived together (a tick's answers and its poses) before the core acts,
//! and a replay that advanced after every input could decide earlier than
//! the launch did. So the driver records every [`Call`] with its launch
//! time — [`Call::Handle`] and [`Call::Advance`] — and the setup the core
//! was made with; [`replay`] makes a new core from that setup, makes the
//! same calls in the same order, and hands back the gate events it
//! publishes, which `orchestrator replay` compares with the recorded ones.
//! A recording made before this log existed is re-judged from its poses
//! (`replay::judge`), with the launch's own referee.
//!
//! The log is postcard (the bus's own encoding), one recording message per
//! pass of the driver's loop, on `bycoms/<swarm>/core/calls`; the setup is
//! one message on `bycoms/<swarm>/core/setup`.

use super::{Ending, Input, LaunchCore, Output, Setup};
use bycoms_protocol::msg::{GateEvent, Pose};
use serde::{Deserialize, Serialize};

// Their schema names in a recording are `record::schema::{CORE_SETUP,
// CORE_CALLS}` (postcard of [`Setup`], of `Vec<Call>`), the one list of a
// recording's schema names.

/// One call a shell made on the core. New kinds go at the end: a
/// recording's log is postcard, which numbers them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Call {
    /// [`LaunchCore::handle`] at this launch time (µs).
    Handle(u64, Input),
    /// [`LaunchCore::advance`] at this launch time (µs).
    Advance(u64),
    /// [`LaunchCore::handle`] of a pose that the recording holds already.
    /// A pose is stored once: the log names it, [`resolve`] reads it back.
    HandleRecordedPose {
        /// The launch time (µs).
        at: u64,
        /// The robot the pose source saw it for ([`Input::Pose`]'s `topic`).
        topic: u32,
        /// Its number (from 0) among the messages recorded on that robot's
        /// pose topic.
        number: u32,
        /// [`fingerprint`] of the pose: a pose on the record that is not
        /// the one the core was handed (changed, or another) is caught.
        fingerprint: u32,
    },
}

/// A 32-bit fingerprint of a pose's every bit (FNV-1a over its fields):
/// enough to tell the pose the core was handed from any other on the
/// record, in 4 bytes instead of the pose's 30 or so. Written here (ten
/// lines) rather than pulled in as a hashing crate: it must never change,
/// and it hashes six numbers.
pub fn fingerprint(pose: &Pose) -> u32 {
    let words = [
        u64::from(pose.robot.0),
        pose.step,
        pose.time_us,
        pose.x.to_bits(),
        pose.y.to_bits(),
        pose.heading.to_bits(),
    ];
    words
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .fold(0x811c_9dc5, |h, b| (h ^ u32::from(b)).wrapping_mul(0x0100_0193))
}

/// The calls of a log with every recorded pose they name put back
/// ([`Call::HandleRecordedPose`] → [`Call::Handle`] of an
/// [`Input::Pose`]), `pose(robot, n)` being the `n`-th message recorded on
/// robot's pose topic; the first pose the recording does not hold as it
/// was handed (missing, or not the fingerprinted one), if any, as (robot,
/// number): the log is no evidence then, and the calls up to it are
/// returned.
pub fn resolve<'a>(
    calls: impl IntoIterator<Item = &'a Call>,
    mut pose: impl FnMut(u32, u32) -> Option<Pose>,
) -> (Vec<Call>, Option<(u32, u32)>) {
    let mut out = Vec::new();
    for call in calls {
        match call {
            Call::HandleRecordedPose { at, topic, number, fingerprint: f } => {
                match pose(*topic, *number).filter(|p| fingerprint(p) == *f) {
                    Some(pose) => out.push(Call::Handle(*at, Input::Pose { topic: *topic, pose })),
                    None => return (out, Some((*topic, *number))),
                }
            }
            other => out.push(other.clone()),
        }
    }
    (out, None)
}

/// The setup's bytes in a recording: the setup, then its supervision
/// settings, its clock limits, its command properties, its starts ahead
/// and its members (the simulated ones, then their speed-up; each
/// appended, so a setup recorded before it existed decodes).
pub fn encode_setup(setup: &Setup) -> Vec<u8> {
    let mut bytes = postcard::to_allocvec(setup).unwrap_or_default();
    bytes.extend(postcard::to_allocvec(&setup.supervision).unwrap_or_default());
    bytes.extend(postcard::to_allocvec(&setup.clocks).unwrap_or_default());
    bytes.extend(postcard::to_allocvec(&setup.commands).unwrap_or_default());
    bytes.extend(postcard::to_allocvec(&setup.starts).unwrap_or_default());
    bytes.extend(postcard::to_allocvec(&setup.members).unwrap_or_default());
    bytes
}

/// A recorded setup. One recorded before the core kept the supervision
/// timers has none after it: it decodes with them off, and its log's
/// recorded verdicts (`Input::Gone`, `Input::Reach`) replay as they ran.
/// Each later addition is likewise absent from a setup recorded before it,
/// and decodes as its default.
pub fn decode_setup(bytes: &[u8]) -> Result<Setup, postcard::Error> {
    let (mut setup, rest): (Setup, &[u8]) = postcard::take_from_bytes(bytes)?;
    let rest = appended(rest, &mut setup.supervision)?;
    let rest = appended(rest, &mut setup.clocks)?;
    let rest = appended(rest, &mut setup.commands)?;
    let rest = appended(rest, &mut setup.starts)?;
    // The members' fields one by one: `sim_speed` came after `simulated`.
    let rest = appended(rest, &mut setup.members.simulated)?;
    appended(rest, &mut setup.members.sim_speed)?;
    Ok(setup)
}

/// The value appended next in `rest` into `into`, unless `rest` is empty
/// (a setup recorded before the value existed keeps the default); what
/// follows it.
fn appended<'a, T: serde::de::DeserializeOwned>(
    rest: &'a [u8],
    into: &mut T,
) -> Result<&'a [u8], postcard::Error> {
    if rest.is_empty() {
        return Ok(rest);
    }
    let (value, rest) = postcard::take_from_bytes(rest)?;
    *into = value;
    Ok(rest)
}

/// A batch of calls' bytes in a recording.
pub fn encode_calls(calls: &[Call]) -> Vec<u8> {
    postcard::to_allocvec(calls).unwrap_or_default()
}

/// A recorded batch of calls.
pub fn decode_calls(bytes: &[u8]) -> Result<Vec<Call>, postcard::Error> {
    postcard::from_bytes(bytes)
}

/// A core whose calls are logged: the driver's core.
pub struct Logged {
    core: LaunchCore,
    calls: Vec<Call>,
    on: bool,
}

impl Logged {
    /// A new core for `setup`; calls are kept only when `on` (a recording).
    pub fn new(setup: Setup, on: bool) -> Self {
        Self { core: LaunchCore::new(setup), calls: Vec::new(), on }
    }

    /// [`LaunchCore::handle`], logged.
    pub fn handle(&mut self, now: u64, input: Input) {
        if self.on {
            self.calls.push(Call::Handle(now, input.clone()));
        }
        self.core.handle(now, input);
    }

    /// [`LaunchCore::handle`] of robot `topic`'s pose, logged by reference
    /// when the recording holds it as the `recorded`-th message of the
    /// robot's pose topic ([`Call::HandleRecordedPose`]).
    pub fn handle_pose(&mut self, now: u64, topic: u32, pose: Pose, recorded: Option<u32>) {
        match recorded {
            Some(number) if self.on => {
                let fingerprint = fingerprint(&pose);
                self.calls.push(Call::HandleRecordedPose { at: now, topic, number, fingerprint });
                self.core.handle(now, Input::Pose { topic, pose });
            }
            _ => self.handle(now, Input::Pose { topic, pose }),
        }
    }

    /// [`LaunchCore::advance`], logged.
    pub fn advance(&mut self, now: u64) {
        if self.on {
            self.calls.push(Call::Advance(now));
        }
        self.core.advance(now);
    }

    /// [`LaunchCore::poll_output`].
    pub fn poll_output(&mut self) -> Option<Output> {
        self.core.poll_output()
    }

    /// The calls made since the last time they were taken.
    pub fn take_calls(&mut self) -> Vec<Call> {
        std::mem::take(&mut self.calls)
    }
}

impl std::ops::Deref for Logged {
    type Target = LaunchCore;
    fn deref(&self) -> &LaunchCore {
        &self.core
    }
}

/// What a core made from `setup` does when given `calls`: the gate events
/// it publishes, in order, and how it ends (none: the calls end first, as
/// in a recording cut short).
pub fn replay<'a>(
    setup: Setup,
    calls: impl IntoIterator<Item = &'a Call>,
) -> (Vec<GateEvent>, Option<Ending>) {
    let mut core = LaunchCore::new(setup);
    let mut gates = Vec::new();
    let mut drain = |core: &mut LaunchCore| {
        while let Some(out) = core.poll_output() {
            if let Output::Gate(event) = out {
                gates.push(event);
            }
        }
    };
    for call in calls {
        match call {
            Call::Handle(now, input) => core.handle(*now, input.clone()),
            Call::Advance(now) => core.advance(*now),
            // Resolved first ([`resolve`]); one that is not names no pose.
            Call::HandleRecordedPose { .. } => continue,
        }
        drain(&mut core);
    }
    (gates, core.ending().cloned())
}
