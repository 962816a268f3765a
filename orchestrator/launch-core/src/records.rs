//! What the launch core records for the summary as the launch runs: how
//! it ended, an agent's death and outages, a robot revoked, a stop and its
//! answers, and the summary's point.
//!
//! Why a file of its own: the core fills these as it goes and the summary
//! (`mod.rs`) reads the core at the end; kept here, below both, the core
//! needs nothing of the summary above it.

use schemars::JsonSchema;
use serde::Serialize;

/// A position as the summary writes it (the schema of `bycoms_sim::Vec2`).
#[derive(JsonSchema)]
#[allow(dead_code)]
pub struct Point {
    /// x, grid cells.
    pub x: f64,
    /// y, grid cells.
    pub y: f64,
}

/// Why the launch ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// A robot reached the goal.
    Arrived,
    /// Every robot was deployed and none arrived.
    RobotsExhausted,
    /// The time budget ran out.
    TimeLimit,
    /// Ctrl-C.
    Interrupted,
    /// An error ended the launch (see `error`).
    Error,
}

/// A supervision event about one agent.
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
pub struct Death {
    /// Why it is gone.
    pub reason: String,
    /// When the orchestrator noticed, ms since the Unix epoch.
    pub noticed_unix_ms: u64,
}

/// A time a remote agent could not be reached (its link cut, or silent):
/// the launch held the robot until it was back, or until the link grace
/// was over and it was treated as dead.
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
pub struct Outage {
    /// When the orchestrator noticed, ms since the Unix epoch.
    pub lost_unix_ms: u64,
    /// When it was heard from again (none: it never was).
    pub back_unix_ms: Option<u64>,
}

/// A robot revoked while the launch ran, as the summary and the status
/// record it (`orchestrator/launch-core/src/revoke.rs`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, serde::Deserialize, JsonSchema)]
pub struct RevokedSummary {
    /// The robot.
    pub robot: u32,
    /// Who revoked it.
    pub who: String,
    /// Why, as the asker said it (may be empty).
    pub why: String,
    /// When the launch took it in, ms since the Unix epoch.
    pub unix_ms: u64,
    /// Its reports dropped since (registrations included, each refused).
    pub dropped: u64,
}

/// A stop asked of the launch from outside, as the summary records it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, JsonSchema)]
pub struct StopSummary {
    /// `--now`: every running robot was told `Stop` before the end.
    pub now: bool,
    /// Who asked.
    pub who: String,
    /// Why, as the asker said it (may be empty).
    pub why: String,
    /// When it was taken in, ms since the Unix epoch.
    pub unix_ms: u64,
    /// The robots told `Stop`, all in one step (empty for a graceful stop).
    pub told: Vec<u32>,
    /// The robots that answered it (`StopDone`), in the order they did.
    pub answered: Vec<StopAnswer>,
    /// The robots told that did not answer within the stop's wait (or whose
    /// agent ended first).
    pub unanswered: Vec<u32>,
}

/// A robot's answer to a stop `now`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, JsonSchema)]
pub struct StopAnswer {
    /// The robot.
    pub robot: u32,
    /// From the stop taken in to its answer, µs.
    pub after_us: u64,
    /// Its robot link's stop frame went out (a gateway's real robot).
    pub on_link: bool,
}
