//! What a launch reports: the summary on the terminal and as `--json`.
//!
//! Why positions twice: `x`/`y` are for people and plots; `x_bits`/`y_bits`
//! are the exact IEEE-754 bits, so the parity test (and anyone comparing a
//! launch with `simulate`) can check "bit for bit" without trusting a
//! decimal round trip.

use bycoms_sim::agent_process::Traffic;
use bycoms_sim::Vec2;
use serde::Serialize;
use std::collections::BTreeMap;

/// Why the launch ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
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

/// How one robot's part in the run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RobotEnd {
    /// Never deployed (the run ended first, or its agent was lost before).
    NotDeployed,
    /// Stopped away from the goal: a beacon.
    Stuck,
    /// Reached the goal.
    Arrived,
    /// Its agent died while it moved: a beacon where it was last seen.
    Died,
    /// Still moving when the run ended.
    Moving,
}

/// A supervision event about one agent.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Death {
    /// Why it is gone.
    pub reason: String,
    /// When the orchestrator noticed, ms since the Unix epoch.
    pub noticed_unix_ms: u64,
}

/// One robot.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RobotSummary {
    /// Robot id (deployment order).
    pub id: u32,
    /// Its agent's pid.
    pub pid: Option<u32>,
    /// How it ended.
    pub end: RobotEnd,
    /// Last known position (deployed robots).
    pub x: Option<f64>,
    /// Last known position (deployed robots).
    pub y: Option<f64>,
    /// `x.to_bits()`.
    pub x_bits: Option<u64>,
    /// `y.to_bits()`.
    pub y_bits: Option<u64>,
    /// Active control periods (the runner's `RobotRun::steps`).
    pub steps: u64,
    /// Lockstep tick of its first step (or its start frame in real time).
    pub deployed_tick: Option<u64>,
    /// Tick (frame) at which the gate decided it had stopped.
    pub decided_tick: Option<u64>,
    /// Controller mode last reported.
    pub mode: u8,
    /// Gate reaction: from the decision that the previous robot stopped to
    /// this robot's first pose, µs.
    pub gate_reaction_us: Option<u64>,
    /// Set when its agent died.
    pub death: Option<Death>,
}

/// The recording, when one was made.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RecordingSummary {
    /// The file.
    pub path: String,
    /// Messages written.
    pub messages: u64,
    /// Messages per topic.
    pub counts: BTreeMap<String, u64>,
}

/// Everything `launch` reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// Swarm name.
    pub swarm: String,
    /// Where the terrain came from.
    pub terrain: String,
    /// ε.
    pub eps: f64,
    /// Sensing noise on.
    pub noise: bool,
    /// Run seed.
    pub seed: u64,
    /// `lockstep` or `realtime`.
    pub clock: String,
    /// Real-time speed-up (real time only).
    pub speed: Option<f64>,
    /// Why it ended.
    pub outcome: Outcome,
    /// A robot arrived.
    pub success: bool,
    /// The error that ended it, if any.
    pub error: Option<String>,
    /// Robots deployed.
    pub robots_used: u32,
    /// Active control periods of all robots (the runner's `steps`).
    pub steps: u64,
    /// `steps × dt`, simulated s (the runner's `time`).
    pub time_s: f64,
    /// Lockstep ticks run, including the gate's dwell and settle ticks.
    pub ticks: u64,
    /// Wall-clock duration, s.
    pub wall_s: f64,
    /// Simulated seconds per wall second: over the whole launch in lockstep
    /// (ticks × dt / wall), the nominal speed-up in real time.
    pub sim_speed: f64,
    /// Positions of the beacons (stuck and dead robots), in robot order.
    pub beacons: Vec<Vec2>,
    /// Every robot.
    pub robots: Vec<RobotSummary>,
    /// Bad messages received by the orchestrator.
    pub bad_traffic: Traffic,
    /// The recording.
    pub recording: Option<RecordingSummary>,
}

impl Summary {
    /// The one-line verdict, like `simulate`'s.
    pub fn line(&self) -> String {
        let beacons = self.beacons.len();
        let plural = if beacons == 1 { "" } else { "s" };
        match self.outcome {
            Outcome::Arrived => format!(
                "robot {} arrived after {:.1} s ({beacons} beacon{plural})",
                self.robots_used, self.time_s
            ),
            Outcome::RobotsExhausted => {
                format!(
                    "all {} robots stopped short of the goal after {:.1} s",
                    self.robots_used, self.time_s
                )
            }
            Outcome::TimeLimit => format!(
                "no robot arrived within {:.0} s ({} robots, {beacons} beacon{plural})",
                self.time_s, self.robots_used
            ),
            Outcome::Interrupted => {
                format!("interrupted after {:.1} s ({} robots deployed)", self.time_s, self.robots_used)
            }
            Outcome::Error => format!("error: {}", self.error.as_deref().unwrap_or("unknown")),
        }
    }

    /// The human-readable summary: the verdict, then one line per robot.
    pub fn text(&self) -> String {
        let mut out = format!(
            "launch {} on {}, ε = {}, noise {}, {} clock: {}\n",
            self.swarm,
            self.terrain,
            self.eps,
            if self.noise { "on" } else { "off" },
            self.clock,
            self.line()
        );
        for r in &self.robots {
            let at = match (r.x, r.y) {
                (Some(x), Some(y)) => format!("at ({x:.2}, {y:.2})"),
                _ => String::new(),
            };
            let died = r.death.as_ref().map(|d| format!(" — {}", d.reason)).unwrap_or_default();
            out.push_str(&format!("  robot {}: {:?} {at} after {} steps{died}\n", r.id, r.end, r.steps));
        }
        out.push_str(&match self.speed {
            None => format!(
                "  {} ticks in {:.2} s wall ({:.0} simulated s per wall s)",
                self.ticks, self.wall_s, self.sim_speed
            ),
            Some(speed) => format!("  {:.2} s wall at {speed}× real time", self.wall_s),
        });
        if self.bad_traffic.total() > 0 {
            out.push_str(&format!("\n  bad messages: {:?}", self.bad_traffic));
        }
        if let Some(rec) = &self.recording {
            out.push_str(&format!("\n  recorded {} messages to {}", rec.messages, rec.path));
        }
        out
    }
}
