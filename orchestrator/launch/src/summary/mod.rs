//! What a launch reports: the summary on the terminal and as `--json`.
//!
//! Why positions twice: `x`/`y` are for people and plots; `x_bits`/`y_bits`
//! are the exact IEEE-754 bits, so the parity test (and anyone comparing a
//! launch with `simulate`) can check "bit for bit" without trusting a
//! decimal round trip.

/// What the launch core records for the summary (`records.rs` of the core crate, owned there).
pub use bycoms_launch_core::records::{
    Death, Outage, Outcome, Point, RevokedSummary, StopAnswer, StopSummary,
};

use super::core::shown;
use super::core::view::RunView;
use super::core::{ClockReading, Ending, LaunchCore, Slot, SlotState};
use bycoms_runtime::words::signed;
use bycoms_runtime::Traffic;
use bycoms_sim::Vec2;
use bycoms_study::runs::{count, verdict as verdict_line};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// How one robot's part in the run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, JsonSchema)]
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
    /// Skipped at its turn: its agent never registered (see `death`).
    Absent,
    /// Moving when `orchestrator stop --now` told it `Stop`, which it
    /// answered: it stands where it stopped, a beacon.
    Stopped,
}

impl RobotEnd {
    /// How it ended, in words for the terminal.
    pub fn words(self) -> &'static str {
        match self {
            Self::NotDeployed => "not deployed",
            Self::Stuck => "stuck",
            Self::Arrived => "arrived",
            Self::Died => "lost (agent died)",
            Self::Moving => "still moving",
            Self::Absent => "absent",
            Self::Stopped => "stopped (told Stop)",
        }
    }
}

/// How faithful a real-time run was: control periods the agents stepped
/// and the ones they were too late for (as their poses' frame numbers
/// show), over the deployed robots.
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
pub struct RealtimeReport {
    /// Periods stepped (poses seen).
    pub periods: u64,
    /// Periods skipped because an agent was late.
    pub missed_periods: u64,
    /// Simulated seconds actually computed per wall second:
    /// `speed × periods / (periods + missed_periods)`; 0 when no period ran
    /// (nothing was computed, so no speed-up is claimed).
    pub achieved_speed: f64,
    /// Whether at most [`FAITHFUL_MISS`] of the periods were missed; a run
    /// that was not faithful skipped control steps, so its motion (and its
    /// `time_s`, which counts frames) is not what the speed-up promises.
    pub faithful: bool,
}

/// Largest share of missed periods of a faithful real-time run (1 %).
pub const FAITHFUL_MISS: f64 = 0.01;

impl RealtimeReport {
    /// The report for `periods` stepped and `missed` skipped at `speed`.
    pub fn new(speed: f64, periods: u64, missed: u64) -> Self {
        let all = periods + missed;
        let share = if all == 0 { 0.0 } else { missed as f64 / all as f64 };
        Self {
            periods,
            missed_periods: missed,
            achieved_speed: if all == 0 { 0.0 } else { speed * (1.0 - share) },
            faithful: share <= FAITHFUL_MISS,
        }
    }
}

/// One robot.
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
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
    /// Times its agent was unreachable (remote agents), in order.
    pub outages: Vec<Outage>,
    /// Its host's clock against the orchestrator's, as its agent last
    /// measured it (agents over zenoh; none: not measured).
    pub clock: Option<ClockSummary>,
    /// A simulated member of a swarm of real robots (a mixed swarm's
    /// `kind = "sim"` robot); absent for every other robot.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub simulated: bool,
}

/// A host's clock offset to the orchestrator's (`orchestrator/launch-core/src/clocks.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ClockSummary {
    /// The host's clock minus the orchestrator's, ms (positive: ahead).
    pub offset_ms: f64,
    /// The round trip of the measurement, ms (the offset is right to
    /// within half of it).
    pub round_trip_ms: f64,
    /// When it was measured (reported), ms since the Unix epoch.
    pub measured_unix_ms: u64,
}

impl ClockSummary {
    /// The summary of `reading`, reported at launch time `at_us` of `core`.
    pub fn of(core: &LaunchCore, reading: ClockReading) -> Self {
        Self {
            offset_ms: reading.offset_us as f64 / 1000.0,
            round_trip_ms: f64::from(reading.round_trip_us) / 1000.0,
            measured_unix_ms: core.unix_ms(reading.at_us),
        }
    }
}

/// The recording, when one was made.
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
pub struct RecordingSummary {
    /// The file.
    pub path: String,
    /// Messages written.
    pub messages: u64,
    /// Messages per topic.
    pub counts: BTreeMap<String, u64>,
}

/// Everything `launch` reports.
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
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
    /// Agents stepped over all ticks: `Tick`s sent (each agent once a tick,
    /// re-sends not counted) and the ticks that a run of ticks sent before
    /// covers (a creeping robot judged stuck, `ToAgent::Ticks`):
    /// `ticked_agents / ticks` agents step in a tick.
    pub ticked_agents: u64,
    /// Mean wall time of a lockstep tick, from its `Tick`s to its last
    /// answer, µs, over the ticks answered without a re-send: what a tick
    /// costs (`wall_s` also holds the agents' start and the wind-down).
    pub tick_us: f64,
    /// Wall time of a lockstep tick per agent that steps in it (ticked, or
    /// covered by a run of ticks), µs, over the
    /// ticks of `tick_us` while no agent was starting: what each agent
    /// that steps adds to a tick (an agent starting takes a core from the
    /// ticks around it, a cost of each robot).
    pub quiet_us_per_agent: f64,
    /// Wall-clock duration, s.
    pub wall_s: f64,
    /// Simulated seconds per wall second: over the whole launch in lockstep
    /// (ticks × dt / wall), the achieved speed-up in real time (see
    /// `realtime`).
    pub sim_speed: f64,
    /// Real time only: periods stepped and missed, achieved speed-up.
    pub realtime: Option<RealtimeReport>,
    /// Positions of the beacons (stuck, dead and stopped robots), in robot order.
    #[schemars(with = "Vec<Point>")]
    pub beacons: Vec<Vec2>,
    /// Every robot.
    pub robots: Vec<RobotSummary>,
    /// Bad messages received by the orchestrator.
    #[schemars(with = "BTreeMap<String, u64>")]
    pub bad_traffic: Traffic,
    /// The recording.
    pub recording: Option<RecordingSummary>,
    /// The SVG picture of the run (`--svg`), for the command to write.
    #[serde(skip)]
    pub picture: Option<String>,
    /// The bus: `ipc` or `zenoh`.
    pub transport: String,
    /// zenoh: the endpoints the orchestrator listened on.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub endpoints: Vec<String>,
    /// Wall seconds from the start of the launch (before the bus opened)
    /// to the first robot's start pose: "launch → first robot moving".
    pub first_moving_s: Option<f64>,
    /// Commands sent again because their answer did not come (a lost
    /// message, an unreachable agent back; `launch/partition.rs`).
    pub resends: u64,
    /// Robots whose agents did not exit within the shutdown grace after
    /// `Shutdown` and were ended (spawned agents killed; remote ones named).
    pub shutdown_killed: Vec<u32>,
    /// A stop asked from outside (`orchestrator stop`, the ROS 2 stop
    /// service): who, why, and which robots were told `Stop`.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub stop: Option<StopSummary>,
    /// Robots revoked while the launch ran (`orchestrator revoke`): who,
    /// why, when, and how many of their reports were dropped since.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub revoked: Vec<RevokedSummary>,
}

impl Summary {
    /// The one-line verdict, the same sentence as `simulate`'s.
    pub fn line(&self) -> String {
        let sim = match self.outcome {
            Outcome::Arrived => bycoms_sim::RunOutcome::Arrived,
            Outcome::RobotsExhausted => bycoms_sim::RunOutcome::RobotsExhausted,
            Outcome::TimeLimit => bycoms_sim::RunOutcome::TimeLimit,
            Outcome::Interrupted => {
                let deployed = count(u64::from(self.robots_used), "robot");
                // (Who asked and why, escaped: a client's words, maybe a foreign one's.)
                let how = match &self.stop {
                    Some(s) if s.why.is_empty() => format!("stopped by {}", shown(&s.who)),
                    Some(s) => format!("stopped by {} ({})", shown(&s.who), shown(&s.why)),
                    None => "interrupted".into(),
                };
                return format!("{how} after {:.1} s ({deployed} deployed)", self.time_s);
            }
            Outcome::Error => return format!("error: {}", self.error.as_deref().unwrap_or("unknown")),
        };
        if let Some(line) = self.exhausted_line().filter(|_| sim == bycoms_sim::RunOutcome::RobotsExhausted) {
            return line;
        }
        let arrived = self.robots.iter().find(|r| r.end == RobotEnd::Arrived).map(|r| r.id);
        verdict_line(sim, self.robots_used, arrived, self.time_s, self.beacons.len())
    }

    /// The headline of a launch whose robots all had their turn and none
    /// arrived, when not every robot got stuck (then it is `simulate`'s
    /// "all 3 robots got stuck"): what became of them, counted,
    /// "no robot arrived after 7.0 s: 2 stuck, 1 absent".
    fn exhausted_line(&self) -> Option<String> {
        let revoked = |id: u32| self.revoked.iter().any(|r| r.robot == id);
        let mut counts: Vec<(&str, u64)> = Vec::new();
        for r in &self.robots {
            let what = match r.end {
                RobotEnd::Died | RobotEnd::NotDeployed if revoked(r.id) => "revoked",
                RobotEnd::Died => "lost (agent died)",
                RobotEnd::NotDeployed => "not deployed",
                end => end.words(),
            };
            match counts.iter_mut().find(|(w, _)| *w == what) {
                Some((_, n)) => *n += 1,
                None => counts.push((what, 1)),
            }
        }
        if let [("stuck", _)] = counts.as_slice() {
            return None;
        }
        let what: Vec<String> = counts.iter().map(|(w, n)| format!("{n} {w}")).collect();
        Some(format!("no robot arrived after {:.1} s: {}", self.time_s, what.join(", ")))
    }

    /// The agents' host clocks in one line: the largest offset (and whose)
    /// and the longest round trip; none when no agent measured one.
    fn clock_line(&self) -> Option<String> {
        let clocks = self.robots.iter().filter_map(|r| r.clock.map(|c| (r.id, c)));
        let (id, worst) =
            clocks.clone().max_by(|a, b| a.1.offset_ms.abs().total_cmp(&b.1.offset_ms.abs()))?;
        let trip = clocks.map(|(_, c)| c.round_trip_ms).fold(0.0, f64::max);
        Some(format!(
            "clock offsets to the orchestrator: at most {} ms (robot {id}), round trips at most {trip:.1} ms",
            signed(worst.offset_ms, 1)
        ))
    }

    /// The human-readable summary: the verdict, one line per deployed
    /// robot, one line for all robots never deployed.
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
        let mut idle = Vec::new();
        for r in &self.robots {
            if r.end == RobotEnd::NotDeployed && r.death.is_none() {
                idle.push(r.id);
                continue;
            }
            let at = match (r.x, r.y) {
                (Some(x), Some(y)) => format!(" at ({x:.2}, {y:.2})"),
                _ => String::new(),
            };
            let died = r.death.as_ref().map(|d| format!(" — {}", d.reason)).unwrap_or_default();
            let steps = count(r.steps, "step");
            out.push_str(&format!("  robot {}: {}{at} after {steps}{died}\n", r.id, r.end.words()));
        }
        if let Some(text) = id_ranges(&idle) {
            let noun = if idle.len() == 1 { "robot" } else { "robots" };
            out.push_str(&format!("  {noun} {text}: not deployed\n"));
        }
        out.push_str(&match (&self.speed, &self.realtime) {
            (Some(speed), Some(rt)) if rt.periods + rt.missed_periods == 0 => {
                format!("  {:.2} s wall at {speed}× real time: no control period ran", self.wall_s)
            }
            (Some(speed), Some(rt)) => {
                let mut line = format!(
                    "  {:.2} s wall at {speed}× real time: achieved {:.1}× ({} of {} missed)",
                    self.wall_s,
                    rt.achieved_speed,
                    rt.missed_periods,
                    count(rt.periods + rt.missed_periods, "period")
                );
                if !rt.faithful {
                    line.push_str(" — not faithful: the agents could not keep up; lower --speed");
                }
                line
            }
            (Some(speed), None) => format!("  {:.2} s wall at {speed}× real time", self.wall_s),
            (None, _) => format!(
                "  {} in {:.2} s wall ({:.0} simulated s per wall s)",
                count(self.ticks, "tick"),
                self.wall_s,
                self.sim_speed
            ),
        });
        if self.bad_traffic.total() > 0 {
            out.push_str(&format!("\n  bad messages: {}", self.bad_traffic));
        }
        for r in &self.revoked {
            let dropped = count(r.dropped, "report");
            out.push_str(&format!(
                "\n  robot {} revoked by {}: {dropped} of it dropped since",
                r.robot,
                shown(&r.who)
            ));
        }
        if let Some(line) = self.clock_line() {
            out.push_str(&format!("\n  {line}"));
        }
        if let Some(rec) = &self.recording {
            out.push_str(&format!("\n  recorded {} to {}", count(rec.messages, "message"), rec.path));
        }
        out
    }
}

/// What a launch decided, as its summary states it: a projection of the
/// core at its end ([`of`]).
///
/// Why one function: "deployed", "success", "robots used" and what a
/// failed recording does to the outcome used to be decided in the driver,
/// where the launch harness could not check them. Here they are decided
/// once; the driver fills the summary with them and the harness checks them
/// on every schedule.
#[derive(Clone, Debug, PartialEq)]
pub struct Decided {
    /// How it ended (and the summary's `success`, `error`).
    pub verdict: Verdict,
    /// Robots deployed: the robots the gate deployed, as the run's view
    /// ([`RunView::robots_used`]) counts them for every renderer.
    pub robots_used: u32,
    /// Every robot.
    pub robots: Vec<RobotSummary>,
    /// Positions of the beacons (stuck and dead robots, where the core's
    /// table has them: the view's), in robot order.
    pub beacons: Vec<Vec2>,
    /// Active control periods charged.
    pub steps: u64,
    /// Lockstep ticks run.
    pub ticks: u64,
    /// Commands sent again.
    pub resends: u64,
    /// Real time: frames seen and missed, over every robot.
    pub frames: (u64, u64),
}

/// The outcome, `success` and `error` of a launch.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    /// Why it ended.
    pub outcome: Outcome,
    /// A robot arrived (and nothing failed after).
    pub success: bool,
    /// The error that ended it.
    pub error: Option<String>,
}

/// The verdict of a launch that ended with `ending`, whose recording
/// failed with `Err(why)` or did not: a failed recording makes any
/// outcome an error (the run cannot be replayed or drawn), keeping an
/// earlier error's words.
pub fn verdict(ending: &Ending, recording: Result<(), &str>) -> Verdict {
    // The core's typed fault, in words: the summary is the edge.
    let words = ending.error.as_ref().map(ToString::to_string);
    let (outcome, error) = match recording {
        Ok(()) => (ending.outcome, words),
        Err(why) => (Outcome::Error, Some(words.unwrap_or_else(|| format!("recording failed: {why}")))),
    };
    Verdict { success: outcome == Outcome::Arrived, outcome, error }
}

/// The summary's figures of `core`, which ended with `ending`, its
/// recording having failed (`Err(why)`) or not; `view` is the run as the
/// views showed it (the core's outputs folded, [`RunView`]), the one owner
/// of the robots used and of where the beacons stand (the `--svg` trace
/// reads the same fold).
pub fn of(core: &LaunchCore, view: &RunView, ending: &Ending, recording: Result<(), &str>) -> Decided {
    let slots = core.slots();
    let robots: Vec<RobotSummary> = slots.iter().map(|s| robot_summary(core, s)).collect();
    let frames = slots.iter().fold((0, 0), |(s, m), slot| (s + slot.frames().seen, m + slot.frames().missed));
    Decided {
        verdict: verdict(ending, recording),
        robots_used: view.robots_used(),
        beacons: beacons(core, view),
        robots,
        steps: core.spent(),
        ticks: core.ticks(),
        resends: core.resends(),
        frames,
    }
}

/// Where the beacons stand, in robot order: the view's (stuck and dead
/// robots, where the core's table has them), and a robot a stop `now`
/// stopped while it moved, where it stopped (it stands there for the run's
/// end, though the core never made it a beacon for the agents).
fn beacons(core: &LaunchCore, view: &RunView) -> Vec<Vec2> {
    let mut at: Vec<(u32, Vec2)> = view.beacons().collect();
    let stopped = core.slots().iter().filter(|s| s.state() == SlotState::Unfinished && stopped_now(core, s));
    at.extend(stopped.filter_map(|s| s.last_pose().map(|p| (s.id(), Vec2::new(p.x, p.y)))));
    at.sort_by_key(|(id, _)| *id);
    at.into_iter().map(|(_, at)| at).collect()
}

/// One robot's line of the summary: a robot is deployed once its slot is
/// past its start (stuck, arrived, died, moving or unfinished); only a
/// deployed robot has a position and a deployment tick.
fn robot_summary(core: &LaunchCore, s: &Slot) -> RobotSummary {
    let end = match s.state() {
        SlotState::Stuck => RobotEnd::Stuck,
        SlotState::Arrived => RobotEnd::Arrived,
        SlotState::Died => RobotEnd::Died,
        SlotState::Unfinished if stopped_now(core, s) => RobotEnd::Stopped,
        SlotState::Unfinished | SlotState::Moving => RobotEnd::Moving,
        SlotState::Absent => RobotEnd::Absent,
        _ => RobotEnd::NotDeployed,
    };
    let deployed = !matches!(end, RobotEnd::NotDeployed | RobotEnd::Absent);
    let pose = s.last_pose().filter(|_| deployed);
    RobotSummary {
        id: s.id(),
        pid: s.pid(),
        end,
        x: pose.map(|p| p.x),
        y: pose.map(|p| p.y),
        x_bits: pose.map(|p| p.x.to_bits()),
        y_bits: pose.map(|p| p.y.to_bits()),
        steps: s.steps(),
        deployed_tick: s.deployed_tick().filter(|_| deployed),
        decided_tick: s.decided_tick(),
        mode: s.mode(),
        gate_reaction_us: s.reaction_us(),
        death: s.death().cloned(),
        outages: s.outages().to_vec(),
        clock: s.clock().map(|c| ClockSummary::of(core, c)),
        simulated: core.is_simulated(s.id()),
    }
}

/// Whether robot `s` was told `Stop` by a stop `now` and answered it.
fn stopped_now(core: &LaunchCore, s: &Slot) -> bool {
    core.stopped().is_some_and(|stop| stop.now && stop.answered.iter().any(|a| a.robot == s.id()))
}

/// "4", "4–6", "4–6, 9": sorted ids as ranges; `None` when empty.
fn id_ranges(ids: &[u32]) -> Option<String> {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < ids.len() {
        let start = ids[i];
        let mut end = start;
        while i + 1 < ids.len() && ids[i + 1] == end + 1 {
            i += 1;
            end = ids[i];
        }
        parts.push(if end == start { start.to_string() } else { format!("{start}–{end}") });
        i += 1;
    }
    (!parts.is_empty()).then(|| parts.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::core::Fault;

    #[test]
    fn a_failed_recording_makes_any_outcome_an_error_keeping_an_earlier_error() {
        let ending =
            |outcome, error: Option<&str>| Ending { outcome, error: error.map(|e| Fault::Failed(e.into())) };
        let arrived = ending(Outcome::Arrived, None);
        assert_eq!(
            verdict(&arrived, Ok(())),
            Verdict { outcome: Outcome::Arrived, success: true, error: None }
        );
        let failed = verdict(&arrived, Err("disk full"));
        assert_eq!(failed.outcome, Outcome::Error);
        assert!(!failed.success);
        assert_eq!(failed.error.as_deref(), Some("recording failed: disk full"));
        let error = ending(Outcome::Error, Some("robot 2's agent died"));
        assert_eq!(verdict(&error, Err("disk full")).error.as_deref(), Some("robot 2's agent died"));
        assert!(!verdict(&ending(Outcome::TimeLimit, None), Ok(())).success);
    }

    fn robot(id: u32, end: RobotEnd, steps: u64) -> RobotSummary {
        let deployed = end != RobotEnd::NotDeployed;
        RobotSummary {
            id,
            pid: None,
            end,
            x: deployed.then_some(1.0),
            y: deployed.then_some(2.0),
            x_bits: None,
            y_bits: None,
            steps,
            deployed_tick: None,
            decided_tick: None,
            mode: 1,
            gate_reaction_us: None,
            death: None,
            outages: Vec::new(),
            clock: None,
            simulated: false,
        }
    }

    fn summary(robots: Vec<RobotSummary>, realtime: Option<RealtimeReport>) -> Summary {
        Summary {
            swarm: "s".into(),
            terrain: "t".into(),
            eps: 3.0,
            noise: false,
            seed: 0,
            clock: if realtime.is_some() { "realtime" } else { "lockstep" }.into(),
            speed: realtime.as_ref().map(|_| 1000.0),
            outcome: Outcome::Arrived,
            success: true,
            error: None,
            robots_used: 2,
            steps: 11,
            time_s: 1.1,
            ticks: 1,
            ticked_agents: 1,
            tick_us: 80.0,
            quiet_us_per_agent: 60.0,
            wall_s: 0.5,
            sim_speed: 2.0,
            realtime,
            beacons: vec![Vec2::new(1.0, 2.0)],
            robots,
            bad_traffic: Traffic { garbage: 2, ..Traffic::default() },
            recording: None,
            picture: None,
            transport: "ipc".into(),
            endpoints: Vec::new(),
            first_moving_s: None,
            resends: 0,
            shutdown_killed: Vec::new(),
            stop: None,
            revoked: Vec::new(),
        }
    }

    #[test]
    fn the_text_speaks_words_and_summarises_undeployed_robots_in_one_line() {
        let mut robots = vec![robot(1, RobotEnd::Stuck, 1), robot(2, RobotEnd::Arrived, 10)];
        robots.extend((3..=159).map(|id| robot(id, RobotEnd::NotDeployed, 0)));
        let text = summary(robots, None).text();
        assert!(text.contains("robot 1: stuck at (1.00, 2.00) after 1 step\n"), "{text}");
        assert!(text.contains("robot 2: arrived at (1.00, 2.00) after 10 steps\n"), "{text}");
        assert!(text.contains("  robots 3–159: not deployed\n"), "{text}");
        assert!(text.contains("1 tick in 0.50 s wall"), "{text}");
        assert!(text.contains("bad messages: 2 undecodable"), "{text}");
        assert!(text.contains("robot 2 arrived after 1.1 s (1 beacon)"), "{text}");
        assert_eq!(text.lines().count(), 6, "{text}");
        for rust in ["NotDeployed", "Traffic", "{", "1 robots", "1 steps", "1 beacons"] {
            assert!(!text.contains(rust), "{rust:?} in {text}");
        }
        assert_eq!(id_ranges(&[1, 2, 3, 5, 7, 8]).as_deref(), Some("1–3, 5, 7–8"));
    }

    #[test]
    fn a_realtime_run_that_missed_periods_says_so() {
        let slow = RealtimeReport::new(1000.0, 726, 44);
        assert!(!slow.faithful);
        assert!((slow.achieved_speed - 1000.0 * 726.0 / 770.0).abs() < 1e-9);
        let text = summary(vec![robot(1, RobotEnd::Arrived, 3)], Some(slow)).text();
        assert!(text.contains("achieved 942.9× (44 of 770 periods missed) — not faithful"), "{text}");
        let fine = RealtimeReport::new(10.0, 1000, 1);
        assert!(fine.faithful);
        let text = summary(vec![robot(1, RobotEnd::Arrived, 3)], Some(fine)).text();
        assert!(text.contains("(1 of 1001 periods missed)") && !text.contains("not faithful"), "{text}");
    }

    #[test]
    fn the_headline_names_the_robot_that_arrived_when_an_earlier_agent_died_undeployed() {
        let mut lost = robot(3, RobotEnd::NotDeployed, 0);
        lost.death = Some(Death { reason: "agent exited (status 1)".into(), noticed_unix_ms: 0 });
        let robots = vec![
            robot(1, RobotEnd::Stuck, 5),
            robot(2, RobotEnd::Stuck, 5),
            lost,
            robot(4, RobotEnd::Arrived, 9),
        ];
        let s = Summary { robots_used: 3, beacons: vec![Vec2::new(1.0, 2.0); 2], ..summary(robots, None) };
        let text = s.text();
        assert!(text.contains("robot 4 arrived after 1.1 s (2 beacons)"), "{text}");
        assert!(text.contains("robot 4: arrived"), "{text}");
        assert!(!text.contains("robot 3 arrived"), "{text}");
    }

    /// Issue 49: the headline of a launch where no robot arrived names
    /// what became of each robot; "all N robots got stuck" only when they
    /// all did.
    #[test]
    fn the_headline_of_robots_exhausted_names_what_happened_to_each() {
        let exhausted = |robots: Vec<RobotSummary>, revoked: &[u32]| {
            let revoked = revoked
                .iter()
                .map(|&robot| RevokedSummary {
                    robot,
                    who: "me".into(),
                    why: String::new(),
                    unix_ms: 0,
                    dropped: 0,
                })
                .collect();
            Summary { outcome: Outcome::RobotsExhausted, success: false, revoked, ..summary(robots, None) }
                .line()
        };
        let all_revoked =
            exhausted(vec![robot(1, RobotEnd::Died, 5), robot(2, RobotEnd::NotDeployed, 0)], &[1, 2]);
        assert_eq!(all_revoked, "no robot arrived after 1.1 s: 2 revoked");
        let one_absent = exhausted(
            vec![robot(1, RobotEnd::Stuck, 5), robot(2, RobotEnd::Absent, 0), robot(3, RobotEnd::Stuck, 6)],
            &[],
        );
        assert_eq!(one_absent, "no robot arrived after 1.1 s: 2 stuck, 1 absent");
        let died = exhausted(vec![robot(1, RobotEnd::Died, 5), robot(2, RobotEnd::Stuck, 5)], &[]);
        assert_eq!(died, "no robot arrived after 1.1 s: 1 lost (agent died), 1 stuck");
        let stuck = exhausted(vec![robot(1, RobotEnd::Stuck, 5), robot(2, RobotEnd::Stuck, 6)], &[]);
        assert_eq!(stuck, "all 2 robots got stuck after 1.1 s");
    }

    #[test]
    fn a_realtime_launch_that_never_ran_claims_no_speed() {
        let never = RealtimeReport::new(5.0, 0, 0);
        assert_eq!((never.achieved_speed, never.faithful), (0.0, true), "nothing computed, nothing missed");
        let text = summary(vec![robot(1, RobotEnd::NotDeployed, 0)], Some(never)).text();
        assert!(!text.contains("achieved"), "{text}");
        assert!(text.contains("no control period ran"), "{text}");
    }

    #[test]
    fn the_text_names_the_largest_clock_offset_and_round_trip() {
        let mut robots = vec![robot(1, RobotEnd::Stuck, 3), robot(2, RobotEnd::Arrived, 4)];
        assert_eq!(summary(robots.clone(), None).clock_line(), None, "none measured: no line");
        let clock = |offset_ms, round_trip_ms| ClockSummary { offset_ms, round_trip_ms, measured_unix_ms: 1 };
        robots[0].clock = Some(clock(-42.5, 0.8));
        robots[1].clock = Some(clock(3.0, 1.6));
        let text = summary(robots, None).text();
        let line =
            "clock offsets to the orchestrator: at most -42.5 ms (robot 1), round trips at most 1.6 ms";
        assert!(text.contains(line), "{text}");
    }

    #[test]
    fn an_offset_that_rounds_to_zero_is_not_said_negative() {
        let mut robots = vec![robot(1, RobotEnd::Stuck, 3)];
        robots[0].clock = Some(ClockSummary { offset_ms: -0.04, round_trip_ms: 0.2, measured_unix_ms: 1 });
        let text = summary(robots, None).text();
        assert!(text.contains("at most +0.0 ms (robot 1)"), "{text}");
        assert!(!text.contains("-0.0"), "{text}");
    }

    #[test]
    fn who_stopped_the_launch_and_why_are_printed_escaped() {
        let mut s = summary(vec![robot(1, RobotEnd::NotDeployed, 0)], None);
        s.outcome = Outcome::Interrupted;
        s.stop = Some(StopSummary {
            now: false,
            who: "me\u{1b}[2J".into(),
            why: "a\nb\u{7}".into(),
            unix_ms: 0,
            told: vec![],
            answered: vec![],
            unanswered: vec![],
        });
        s.revoked.push(RevokedSummary {
            robot: 1,
            who: "x\ry".into(),
            why: String::new(),
            unix_ms: 0,
            dropped: 0,
        });
        let text = s.text();
        assert!(text.contains("stopped by me\\u{1b}[2J (a\\nb\\u{7}) after"), "{text}");
        assert!(text.contains("robot 1 revoked by x\\ry:"), "{text}");
        assert!(!text.chars().any(|c| c.is_control() && c != '\n'), "{text:?}");
    }
}
