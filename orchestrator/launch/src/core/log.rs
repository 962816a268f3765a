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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::Supervision;
    use crate::harness::{self, Case, Schedule};

    /// The harness's launches, logged as the driver logs them, replay to
    /// the same gate events and ending, through the encoding.
    #[test]
    fn a_logged_launch_replays_to_the_same_decisions() {
        for seed in 0..40 {
            let case = Case::small(seed);
            let schedule = Schedule::draw(seed, case.robots, 400);
            let (report, setup, calls) = harness::run_logged(&case, &schedule);
            let bytes = encode_calls(&calls);
            let calls = decode_calls(&bytes).expect("decodes");
            let setup = decode_setup(&encode_setup(&setup)).expect("decodes");
            let (gates, ending) = replay(setup, &calls);
            assert_eq!(gates, report.gates, "seed {seed}");
            assert_eq!(ending, report.ending, "seed {seed}");
        }
    }

    /// A setup recorded before the supervision timers were in the core (no
    /// settings after it) decodes with them off: its log carries the seams'
    /// verdicts as inputs and replays as it ran.
    #[test]
    fn a_setup_recorded_before_the_timers_decodes_with_them_off() {
        let case = Case::small(3);
        let setup = harness::setup(&case, &Schedule::clean(3, case.robots));
        assert!(setup.supervision.on);
        let old = postcard::to_allocvec(&setup).expect("encodes");
        let decoded = decode_setup(&old).expect("an old setup decodes");
        assert_eq!(decoded.supervision, Supervision::default());
        assert!(!decoded.supervision.on);
        let off = Setup {
            supervision: Supervision::default(),
            clocks: Default::default(),
            commands: Default::default(),
            starts: Default::default(),
            ..setup.clone()
        };
        assert_eq!(decoded, off);
        assert_eq!(decode_setup(&encode_setup(&setup)).expect("decodes"), setup);
    }

    /// A setup recorded before the clock limits (the setup and its
    /// supervision only) decodes with them off; one with them keeps them.
    #[test]
    fn a_setup_recorded_before_the_clock_limits_decodes_with_them_off() {
        let case = Case::small(4);
        let mut setup = harness::setup(&case, &Schedule::clean(4, case.robots));
        setup.clocks = crate::core::ClockLimits { warn_us: 100_000, limit_us: 500_000 };
        let mut old = postcard::to_allocvec(&setup).expect("encodes");
        old.extend(postcard::to_allocvec(&setup.supervision).expect("encodes"));
        let decoded = decode_setup(&old).expect("an older setup decodes");
        assert!(!decoded.clocks.on());
        assert_eq!(
            decoded,
            Setup {
                clocks: Default::default(),
                commands: Default::default(),
                starts: Default::default(),
                ..setup.clone()
            }
        );
        assert_eq!(decode_setup(&encode_setup(&setup)).expect("decodes"), setup);
    }

    /// A setup recorded before the agents' command properties (up to its
    /// clock limits) decodes with one `Tick` a period and full re-sends, as
    /// it ran; one with them keeps them.
    #[test]
    fn a_setup_recorded_before_the_command_properties_decodes_as_it_ran() {
        let case = Case::small(4);
        let setup = harness::setup(&case, &Schedule::clean(4, case.robots));
        assert_eq!(
            setup.commands.ticks_at_once,
            crate::agents::TICKS_AT_ONCE,
            "the harness's spawned agents run ahead"
        );
        let mut old = postcard::to_allocvec(&setup).expect("encodes");
        old.extend(postcard::to_allocvec(&setup.supervision).expect("encodes"));
        old.extend(postcard::to_allocvec(&setup.clocks).expect("encodes"));
        let decoded = decode_setup(&old).expect("an older setup decodes");
        assert!(setup.commands.kept, "the harness's spawned agents keep every command");
        assert_eq!(
            decoded,
            Setup { commands: Default::default(), starts: Default::default(), ..setup.clone() }
        );
        assert_eq!(decode_setup(&encode_setup(&setup)).expect("decodes"), setup);
    }

    /// A setup recorded before agents were started more than one ahead (up
    /// to its command properties) decodes with one ahead, as it ran; one
    /// with it keeps it.
    #[test]
    fn a_setup_recorded_before_the_starts_ahead_decodes_as_it_ran() {
        let case = Case::small(5);
        let setup = harness::setup(&case, &Schedule::clean(5, case.robots));
        assert_eq!(setup.starts.ahead, crate::setup::STARTS_AHEAD, "a lockstep launch starts agents ahead");
        let mut old = postcard::to_allocvec(&setup).expect("encodes");
        old.extend(postcard::to_allocvec(&setup.supervision).expect("encodes"));
        old.extend(postcard::to_allocvec(&setup.clocks).expect("encodes"));
        old.extend(postcard::to_allocvec(&setup.commands).expect("encodes"));
        let decoded = decode_setup(&old).expect("an older setup decodes");
        assert_eq!(decoded.starts.ahead, 0, "none recorded: one ahead, as the core reads it");
        assert_eq!(decoded, Setup { starts: Default::default(), ..setup.clone() });
        assert_eq!(decode_setup(&encode_setup(&setup)).expect("decodes"), setup);
    }

    /// A mixed swarm's setup recorded before `--sim-speed` (its members
    /// the last thing on it) decodes at speed-up 1, as it ran; one with a
    /// speed-up keeps it.
    #[test]
    fn a_mixed_setup_recorded_before_the_sim_speed_decodes_at_speed_up_1() {
        let case = Case::small(6);
        let mut setup = harness::setup(&case, &Schedule::clean(6, case.robots));
        setup.members = crate::core::Members { simulated: vec![1, 3], sim_speed: 4.0 };
        let mut old = postcard::to_allocvec(&setup).expect("encodes");
        for part in [
            postcard::to_allocvec(&setup.supervision),
            postcard::to_allocvec(&setup.clocks),
            postcard::to_allocvec(&setup.commands),
            postcard::to_allocvec(&setup.starts),
            postcard::to_allocvec(&setup.members.simulated),
        ] {
            old.extend(part.expect("encodes"));
        }
        let decoded = decode_setup(&old).expect("an older setup decodes");
        assert_eq!(
            (decoded.members.simulated.as_slice(), decoded.members.sim_speed),
            ([1, 3].as_slice(), 1.0)
        );
        assert_eq!(decode_setup(&encode_setup(&setup)).expect("decodes"), setup);
        assert_eq!((setup.members.speed_up(3), setup.members.speed_up(2)), (4.0, 1.0));
    }

    /// A log that names its poses by their number on their robot's pose
    /// topic (as a recording's does) resolves to the log that held them,
    /// in fewer bytes; one naming a pose the record lacks says which.
    #[test]
    fn poses_named_by_their_number_resolve_to_the_same_calls() {
        use std::collections::BTreeMap;
        let case = Case::small(5);
        let (_, _, calls) = harness::run_logged(&case, &Schedule::clean(5, case.robots));
        let mut on: BTreeMap<u32, Vec<Pose>> = BTreeMap::new();
        let named: Vec<Call> = calls
            .iter()
            .map(|c| match c {
                Call::Handle(now, Input::Pose { topic, pose }) => {
                    let list = on.entry(*topic).or_default();
                    list.push(*pose);
                    let (number, fingerprint) = (list.len() as u32 - 1, fingerprint(pose));
                    Call::HandleRecordedPose { at: *now, topic: *topic, number, fingerprint }
                }
                other => other.clone(),
            })
            .collect();
        assert!(on.values().map(Vec::len).sum::<usize>() > 10, "the run hands poses");
        let named = decode_calls(&encode_calls(&named)).expect("decodes");
        assert!(encode_calls(&named).len() < encode_calls(&calls).len());
        let (resolved, missing) = resolve(&named, |robot, n| on.get(&robot)?.get(n as usize).copied());
        assert_eq!((resolved, missing), (calls.clone(), None));
        let (cut, missing) =
            resolve(&named, |robot, n| if robot == 1 { None } else { Some(on[&robot][n as usize]) });
        assert_eq!(missing, Some((1, 0)));
        assert!(cut.len() < calls.len());
        // A pose on the record that is not the one handed: its bits changed.
        let moved = |robot: u32, n: u32| {
            let mut p = on[&robot][n as usize];
            p.x += if robot == 2 && n == 3 { 0.001 } else { 0.0 };
            Some(p)
        };
        assert_eq!(resolve(&named, moved).1, Some((2, 3)));
    }

    /// A replay that is handed other inputs reaches other decisions: the
    /// comparison can fail.
    #[test]
    fn a_changed_input_changes_the_replay() {
        let case = Case::small(3);
        let (report, setup, mut calls) = harness::run_logged(&case, &Schedule::clean(3, case.robots));
        // Drop every pose of robot 1: it is never seen to start.
        calls.retain(|c| !matches!(c, Call::Handle(_, Input::Pose { topic: 1, .. })));
        let (gates, _) = replay(setup, &calls);
        assert_ne!(gates, report.gates);
    }
}
