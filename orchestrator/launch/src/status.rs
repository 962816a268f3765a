//! Where a running launch stands, as `orchestrator status` shows it: a
//! projection of the launch core's slots and phase, nothing else.
//!
//! Why a pure function over the core: the status must say what the launch
//! itself believes (never a guess from its logs), and must be testable
//! without processes. [`of`] reads the core at launch time `now` and the
//! few facts only the driver knows ([`Facts`]); the driver answers
//! `status` questions with it (`orchestrator/launch/src/control.rs`).

use super::core::shown;
use super::core::{LaunchCore, Phase, SlotState};
use super::summary::{ClockSummary, RevokedSummary};
use bycoms_runtime::words::signed;
use serde::{Deserialize, Serialize};

/// What only the driver knows about its launch.
#[derive(Clone, Debug, PartialEq)]
pub struct Facts {
    /// The swarm.
    pub swarm: String,
    /// `lockstep` or `realtime`.
    pub clock: String,
    /// `ipc`, `zenoh` or `memory`.
    pub transport: String,
    /// The recording's file, when it records.
    pub recording: Option<String>,
    /// The launch's pid.
    pub pid: u32,
    /// Wall seconds since the launch began.
    pub uptime_s: f64,
}

/// One robot in a status.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotStatus {
    /// Its id.
    pub id: u32,
    /// Where it is in the launch, in words (`deploying`, `moving`,
    /// `stuck`, `arrived`, `lost`, …).
    pub state: String,
    /// Its agent runs.
    pub running: bool,
    /// Its last pose (x, y, heading), once it has one.
    pub pose: Option<[f64; 3]>,
    /// Seconds since motion capture last handed over its pose.
    pub pose_age_s: Option<f64>,
    /// Its host's clock offset to the orchestrator's, as last measured
    /// (agents over zenoh).
    #[serde(default)]
    pub clock: Option<ClockSummary>,
}

/// A running launch's status.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaunchStatus {
    /// The swarm.
    pub swarm: String,
    /// `lockstep` or `realtime`.
    pub clock: String,
    /// The bus.
    pub transport: String,
    /// What the launch does now, in words.
    pub phase: String,
    /// What it waits for, if it waits for an agent.
    pub waiting: Option<String>,
    /// Lockstep ticks completed.
    pub ticks: u64,
    /// The recording's file, when it records.
    pub recording: Option<String>,
    /// The launch's pid.
    pub pid: u32,
    /// Wall seconds since it began.
    pub uptime_s: f64,
    /// A stop was asked (and by whom), if one was.
    pub stopping: Option<String>,
    /// Every robot, in id order.
    pub robots: Vec<RobotStatus>,
    /// Robots revoked (`orchestrator revoke`), with their reports dropped
    /// since.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub revoked: Vec<RevokedSummary>,
}

/// The phase in words.
pub fn phase_words(phase: Phase) -> String {
    match phase {
        Phase::Begin => "starting".into(),
        Phase::AwaitingEveryone => "awaiting every robot's registration".into(),
        Phase::Choosing => "choosing the next robot".into(),
        Phase::AwaitingRegistration(k) => format!("awaiting robot {k}'s registration"),
        Phase::Settling(k, _) => format!("robot {k} settling"),
        Phase::Placing(k, _) => format!("robot {k} being placed by the operator"),
        Phase::AwaitingStartPose(k, _) => format!("robot {k} deploying"),
        Phase::Watching => "watching the moving robot".into(),
        Phase::Finished => "finished".into(),
    }
}

/// The status of the launch `core` at launch time `now` (µs).
pub fn of(core: &LaunchCore, now: u64, facts: &Facts) -> LaunchStatus {
    let robots = core
        .slots()
        .iter()
        .map(|s| RobotStatus {
            id: s.id(),
            state: s.state().words().into(),
            running: s.alive(),
            pose: s.last_pose().map(|p| [p.x, p.y, p.heading]),
            pose_age_s: core.pose_heard(s.id()).map(|t| now.saturating_sub(t) as f64 / 1e6),
            clock: s.clock().map(|c| ClockSummary::of(core, c)),
        })
        .collect();
    let stopping = core.stopped().map(|s| {
        let how = if s.now { "stop now" } else { "stop" };
        format!(
            "{how} asked by {}{}",
            s.who,
            if s.why.is_empty() { String::new() } else { format!(": {}", s.why) }
        )
    });
    LaunchStatus {
        swarm: facts.swarm.clone(),
        clock: facts.clock.clone(),
        transport: facts.transport.clone(),
        phase: phase_words(core.phase()),
        waiting: core.waiting().map(|w| w.what),
        ticks: core.ticks(),
        recording: facts.recording.clone(),
        pid: facts.pid,
        uptime_s: facts.uptime_s,
        stopping,
        robots,
        revoked: core.revoked().to_vec(),
    }
}

/// The status as lines for the terminal.
pub fn text(s: &LaunchStatus) -> String {
    let mut out = format!(
        "swarm {} (pid {}): {} clock over {}, up {:.1} s, {}\n",
        s.swarm, s.pid, s.clock, s.transport, s.uptime_s, s.phase
    );
    if let Some(w) = &s.waiting {
        out.push_str(&format!("  waiting for {w}\n"));
    }
    // Who asked and why came from a client, maybe a foreign one: escaped.
    if let Some(stop) = &s.stopping {
        out.push_str(&format!("  {}\n", shown(stop)));
    }
    out.push_str(&format!("  recording: {}\n", s.recording.as_deref().unwrap_or("none")));
    for r in s.robots.iter().filter(|r| r.state != SlotState::Waiting.words()) {
        let pose = r.pose.map(|[x, y, _]| format!(" at ({x:.2}, {y:.2})")).unwrap_or_default();
        let age = r.pose_age_s.map(|a| format!(", seen {a:.1} s ago")).unwrap_or_default();
        let run = if r.running { "" } else { " (agent not running)" };
        let clock = r
            .clock
            .map(|c| format!(", clock {} ms (round trip {:.1} ms)", signed(c.offset_ms, 1), c.round_trip_ms))
            .unwrap_or_default();
        out.push_str(&format!("  robot {}: {}{pose}{age}{clock}{run}\n", r.id, r.state));
    }
    let idle = s.robots.iter().filter(|r| r.state == SlotState::Waiting.words()).count();
    if idle > 0 {
        out.push_str(&format!("  {} not started yet\n", bycoms_study::runs::count(idle as u64, "robot")));
    }
    for r in &s.revoked {
        let why = if r.why.is_empty() { String::new() } else { format!(" ({})", shown(&r.why)) };
        let dropped = bycoms_study::runs::count(r.dropped, "report");
        out.push_str(&format!(
            "  robot {} revoked by {}{why}: {dropped} of it dropped since\n",
            r.robot,
            shown(&r.who)
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::{Input, Output, Revoke, Stop};
    use crate::harness::{self, Case, Schedule};
    use crate::summary::StopAnswer;
    use bycoms_protocol::msg::Pose;
    use bycoms_protocol::msg::{FromAgent, Heartbeat, StopDone};
    use bycoms_protocol::RobotId;

    fn facts() -> Facts {
        Facts {
            swarm: "lab".into(),
            clock: "lockstep".into(),
            transport: "ipc".into(),
            recording: Some("run.mcap".into()),
            pid: 42,
            uptime_s: 2.5,
        }
    }

    /// The status says what the core holds: its phase and wait, each
    /// robot's state, whether its agent runs, how old its last pose is,
    /// the robots revoked and, once asked, who stops the launch.
    #[test]
    fn a_status_is_a_projection_of_the_core() {
        let case = Case::small(3);
        let mut core = LaunchCore::new(harness::setup(&case, &Schedule::clean(3, case.robots)));
        core.advance(0);
        while let Some(out) = core.poll() {
            if let Output::Start(robot) = out {
                core.handle(0, Input::Started { robot, pid: Some(7), how: "started".into() });
            }
        }
        core.advance(0);
        let pose = Pose { robot: RobotId(1), x: 1.0, y: 2.0, heading: 0.5, step: 0, time_us: 0 };
        core.handle(1_000_000, Input::Pose { topic: 1, pose });
        let s = of(&core, 1_500_000, &facts());
        assert_eq!(s.phase, "awaiting robot 1's registration");
        assert_eq!(s.waiting.as_deref(), Some("robot 1's agent to register"));
        assert_eq!((s.robots[0].state.as_str(), s.robots[0].running), ("starting", true));
        assert_eq!(s.robots[0].pose_age_s, Some(0.5));
        assert_eq!(s.robots[0].pose, None, "a pose of a robot not deployed is not believed");
        assert_eq!((s.robots[1].state.as_str(), s.robots[1].running), ("waiting", false));
        assert_eq!((s.swarm.as_str(), s.pid, s.stopping.as_deref()), ("lab", 42, None));
        let shown = text(&s);
        assert!(shown.contains("robot 1: starting, seen 0.5 s ago"), "{shown}");
        assert!(shown.contains("recording: run.mcap"), "{shown}");

        // A revoked robot: listed with its reports dropped since.
        core.handle(1_800_000, Input::Revoke(Revoke { robot: 2, who: "me".into(), why: "lost".into() }));
        core.handle(1_900_000, Input::Report(FromAgent::Heartbeat(Heartbeat { robot: RobotId(2), seq: 1 })));
        let s = of(&core, 1_900_000, &facts());
        assert_eq!((s.revoked.len(), s.revoked[0].robot, s.revoked[0].dropped), (1, 2, 1));
        assert_eq!(s.robots[1].state, "lost");
        let shown = text(&s);
        assert!(shown.contains("robot 2 revoked by me (lost): 1 report of it dropped since"), "{shown}");

        let stop = Stop { now: true, who: "me".into(), why: "a test".into() };
        core.handle(2_000_000, Input::Stop(stop));
        core.advance(2_000_000);
        let s = of(&core, 2_000_000, &facts());
        assert_ne!(s.phase, "finished", "robot 1's answer is awaited");
        assert_eq!(s.stopping.as_deref(), Some("stop now asked by me: a test"));
        assert_eq!(core.stopped().map(|s| s.told.clone()), Some(vec![1]), "robot 1's agent ran");
        let done = StopDone { robot: RobotId(1), on_link: false };
        core.handle(2_000_500, Input::Report(FromAgent::StopDone(done)));
        core.advance(2_000_500);
        let s = of(&core, 2_000_500, &facts());
        assert_eq!(s.phase, "finished");
        let answered = core.stopped().map(|s| s.answered.clone()).unwrap_or_default();
        assert_eq!(answered, [StopAnswer { robot: 1, after_us: 500, on_link: false }]);
    }

    /// A status from a launch that kept a foreign client's words raw (or
    /// any launch): printed with their control characters escaped.
    #[test]
    fn who_and_why_are_printed_escaped() {
        let case = Case::small(3);
        let core = LaunchCore::new(harness::setup(&case, &Schedule::clean(3, case.robots)));
        let mut s = of(&core, 0, &facts());
        s.stopping = Some("stop asked by x\u{1b}[2J: y\u{7}\nz".into());
        s.revoked.push(RevokedSummary {
            robot: 2,
            who: "a\rb".into(),
            why: "c\u{1b}d".into(),
            unix_ms: 0,
            dropped: 0,
        });
        let shown = text(&s);
        assert!(shown.contains("  stop asked by x\\u{1b}[2J: y\\u{7}\\nz\n"), "{shown}");
        assert!(shown.contains("robot 2 revoked by a\\rb (c\\u{1b}d)"), "{shown}");
        assert!(!shown.chars().any(|c| c.is_control() && c != '\n'), "{shown:?}");
    }
}
