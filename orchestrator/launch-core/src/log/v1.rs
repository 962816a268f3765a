//! Version 1 of the log's schema, frozen, and its upgrade to the current
//! version: every recording made before the schema had versions.
//!
//! What version 1 is: the core's types of that time, postcard,
//! positionally. Its setup is the setup's own fields, then each later
//! addition appended as it came (the supervision settings, the clock
//! limits, the command properties, the starts ahead, the simulated members,
//! their speed-up): a setup recorded before an addition ends before it,
//! and the addition takes its default. Its calls are [`Call`]s of its
//! [`Input`]s, numbered as postcard numbers enum variants.
//!
//! Why frozen here and not read by the core's types: those changed (and
//! will again); a recording made by an older core must read the same for
//! ever. The types below are the version-1 shapes of what changed since;
//! the parts that did not change since (the gate's parameters, an agent's
//! reports, a pose) are read by the current types, and the golden test of
//! the current version (`harness/tests/log.rs`) says when one of them
//! would change: that is a new version.
//!
//! The upgrade, rule by rule:
//! - **A setup from before the core kept the supervision timers** (no
//!   supervision appended, or one that says `on: false`): its seams decided
//!   every verdict, recorded as inputs. It is upgraded to timers that never
//!   expire (registration, heartbeat, quiet), with its unreachable grace
//!   held as its remote seam held it.
//! - **`Input::Reach`** (only such logs hold it: the seams said when an
//!   agent became unreachable and when it was back): `Lost` is the token
//!   withdrawn ([`crate::Input::Token`]), which the core holds for the
//!   grace as the seam did; `Back` is left out: the core says it when the
//!   agent is next heard, as the seam did (it said `Back` on hearing it).
//! - **The unreachable grace** was kept twice, as seconds (the setting) and
//!   as µs (zero unless the agents were held); it is now one value in µs
//!   and a flag ([`Supervision::held`]).
//! - **The starts ahead** of a setup from before them (0) is 1, as they ran.

use crate::gate::GateParams;
use crate::{
    AgentTraits, ClockLimits, Commands, Gone, Members, Missing, OnDeath, Revoke, Starts, Stop, Supervision,
};
use bycoms_protocol::msg::{FromAgent, Pose};
use bycoms_sim::Vec2;
use serde::{Deserialize, Serialize};

use super::call::Call as Current;

/// A version-1 setup's own fields, in their order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Setup {
    pub robots: u32,
    pub lockstep: bool,
    pub params: GateParams,
    pub step_limit: u64,
    pub wall_period_us: u64,
    pub speed: f64,
    pub tick_timeout_us: u64,
    pub on_death: OnDeath,
    pub missing: Missing,
    pub prespawn: bool,
    pub start: Vec2,
    pub goal: Vec2,
    pub max_speed: f64,
    /// The unreachable grace as set, s.
    pub unreachable_grace_s: f64,
    pub register_timeout_s: f64,
    pub agents: AgentTraits,
    pub unix_base_ms: u64,
    pub settings: u64,
}

/// A version-1 setup with what was appended to it (each absent from a
/// setup recorded before it).
#[derive(Clone, Debug, PartialEq)]
pub struct Recorded {
    pub setup: Setup,
    pub supervision: Option<SupervisionV1>,
    pub clocks: ClockLimits,
    pub commands: Commands,
    pub starts: Starts,
    pub members: Members,
}

/// The version-1 supervision settings.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SupervisionV1 {
    /// Whether the core kept the timers.
    pub on: bool,
    pub register_timeout_us: u64,
    pub heartbeat_timeout_us: u64,
    /// The grace in µs when the agents were held, else 0.
    pub unreachable_grace_us: u64,
    pub quiet_us: u64,
    pub robot_link_grace_us: Option<u64>,
}

/// A change of an agent's reach, as a version-1 seam said it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Reach {
    Lost,
    Back,
}

/// A version-1 input, its variants in their order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Input {
    Started { robot: u32, pid: Option<u32>, how: String },
    Failed(String),
    Report(FromAgent),
    Pose { topic: u32, pose: Pose },
    Gone(u32, Gone),
    Reach(u32, Reach),
    Interrupt,
    Said(u32, String),
    Stop(Stop),
    Token(u32, bool),
    Revoke(Revoke),
}

/// A version-1 call.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Call {
    Handle(u64, Input),
    Advance(u64),
    HandleRecordedPose { at: u64, topic: u32, number: u32, fingerprint: u32 },
}

/// Reads a version-1 setup and what was appended to it.
pub fn decode_setup(bytes: &[u8]) -> Result<Recorded, postcard::Error> {
    let (setup, rest): (Setup, &[u8]) = postcard::take_from_bytes(bytes)?;
    let (supervision, rest) = appended::<SupervisionV1>(rest)?;
    let (clocks, rest) = appended(rest)?;
    let (commands, rest) = appended(rest)?;
    let (starts, rest) = appended(rest)?;
    let (simulated, rest) = appended(rest)?;
    let (sim_speed, _) = appended::<f64>(rest)?;
    let members = Members { simulated: simulated.unwrap_or_default(), sim_speed: sim_speed.unwrap_or(1.0) };
    Ok(Recorded {
        setup,
        supervision,
        clocks: clocks.unwrap_or_default(),
        commands: commands.unwrap_or_default(),
        starts: starts.unwrap_or_default(),
        members,
    })
}

/// The value appended next in `rest`, unless `rest` is empty (recorded
/// before it existed); what follows it.
fn appended<T: serde::de::DeserializeOwned>(rest: &[u8]) -> Result<(Option<T>, &[u8]), postcard::Error> {
    if rest.is_empty() {
        return Ok((None, rest));
    }
    let (value, rest) = postcard::take_from_bytes(rest)?;
    Ok((Some(value), rest))
}

/// A version-1 setup's bytes: its own fields, then each addition that is
/// present, in order (what a version-1 launch wrote; the upgrade tests
/// make old recordings with it).
pub fn encode_setup(recorded: &Recorded) -> Vec<u8> {
    let mut bytes = postcard::to_allocvec(&recorded.setup).unwrap_or_default();
    let Some(supervision) = recorded.supervision else { return bytes };
    bytes.extend(postcard::to_allocvec(&supervision).unwrap_or_default());
    bytes.extend(postcard::to_allocvec(&recorded.clocks).unwrap_or_default());
    bytes.extend(postcard::to_allocvec(&recorded.commands).unwrap_or_default());
    bytes.extend(postcard::to_allocvec(&recorded.starts).unwrap_or_default());
    bytes.extend(postcard::to_allocvec(&recorded.members.simulated).unwrap_or_default());
    bytes.extend(postcard::to_allocvec(&recorded.members.sim_speed).unwrap_or_default());
    bytes
}

/// A version-1 setup as the current core's (see the module's docs).
pub fn upgrade_setup(recorded: Recorded) -> crate::Setup {
    let Recorded { setup: s, supervision, clocks, commands, starts, members } = recorded;
    let grace_us = (s.unreachable_grace_s * 1e6).round() as u64;
    let supervision = match supervision.filter(|v| v.on) {
        Some(v) => Supervision {
            register_timeout_us: v.register_timeout_us,
            heartbeat_timeout_us: v.heartbeat_timeout_us,
            unreachable_grace_us: grace_us,
            held: v.unreachable_grace_us > 0,
            quiet_us: v.quiet_us,
            robot_link_grace_us: v.robot_link_grace_us,
        },
        None => Supervision { held: true, ..Supervision::never(grace_us) },
    };
    crate::Setup {
        robots: s.robots,
        lockstep: s.lockstep,
        params: s.params,
        step_limit: s.step_limit,
        wall_period_us: s.wall_period_us,
        speed: s.speed,
        tick_timeout_us: s.tick_timeout_us,
        on_death: s.on_death,
        missing: s.missing,
        prespawn: s.prespawn,
        start: s.start,
        goal: s.goal,
        max_speed: s.max_speed,
        register_timeout_s: s.register_timeout_s,
        agents: s.agents,
        unix_base_ms: s.unix_base_ms,
        settings: s.settings,
        supervision,
        clocks,
        commands,
        starts: Starts { ahead: starts.ahead.max(1) },
        members,
    }
}

/// Version-1 calls as the current core's (see the module's docs).
pub fn upgrade_calls(calls: Vec<Call>) -> Vec<Current> {
    calls.into_iter().filter_map(upgrade_call).collect()
}

fn upgrade_call(call: Call) -> Option<Current> {
    Some(match call {
        Call::Handle(at, input) => Current::Handle(at, upgrade_input(input)?),
        Call::Advance(at) => Current::Advance(at),
        Call::HandleRecordedPose { at, topic, number, fingerprint } => {
            Current::HandleRecordedPose { at, topic, number, fingerprint }
        }
    })
}

fn upgrade_input(input: Input) -> Option<crate::Input> {
    use crate::Input as Now;
    Some(match input {
        Input::Started { robot, pid, how } => Now::Started { robot, pid, how },
        Input::Failed(e) => Now::Failed(e),
        Input::Report(r) => Now::Report(r),
        Input::Pose { topic, pose } => Now::Pose { topic, pose },
        Input::Gone(id, gone) => Now::Gone(id, gone),
        Input::Reach(id, Reach::Lost) => Now::Token(id, false),
        Input::Reach(_, Reach::Back) => return None,
        Input::Interrupt => Now::Interrupt,
        Input::Said(id, text) => Now::Said(id, text),
        Input::Stop(stop) => Now::Stop(stop),
        Input::Token(id, present) => Now::Token(id, present),
        Input::Revoke(revoke) => Now::Revoke(revoke),
    })
}
