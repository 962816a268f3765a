//! The launch's referee, fed a recording's poses.
//!
//! Why the launch's own referee (`launch::core::Referee`) and no copy of
//! its rules: a replay must reach the launch's decisions by the same rules,
//! and a copy drifts. What is left here is only how a recording becomes the
//! referee's inputs: a deployment is the launch acting on an earlier
//! decision (robot k stopped → robot k+1 goes), so robot k's first pose
//! after its `Deploy` command is its start pose (in lockstep counted from
//! the last tick sent); from then on its poses go to the referee, whose
//! verdicts and budget rule give the gate events. An agent's death is not a
//! pose: a recorded `Died` event is taken as given (the watch closes there).

use super::read::{Entry, Recorded};
use bycoms_launch::core::{Closed, Referee};
use bycoms_launch::Clock;
use bycoms_protocol::msg::{GateEvent, GateKind, Pose, ToAgent};
use bycoms_protocol::RobotId;
use bycoms_study::gate::{GateParams, Verdict};

/// The gate parameters and step budget of a recorded run.
pub fn gate_params(recorded: &Recorded) -> (GateParams, u64) {
    let cfg = &recorded.run.config;
    let params = bycoms_launch::setup::gate_params(cfg, recorded.run.goal);
    let mut run = bycoms_sim::RunConfig::paper(cfg.eps);
    run.time_limit = cfg.time_limit;
    (params, run.step_limit())
}

/// The gate events a replay reaches from `recorded`'s poses, in order.
pub fn rejudge(recorded: &Recorded) -> Vec<GateEvent> {
    let (params, limit) = gate_params(recorded);
    let lockstep = recorded.run.config.clock == Clock::Lockstep;
    let mut feed = Feed {
        lockstep,
        referee: Referee::new(params, limit, lockstep),
        ticks: 0,
        deploying: None,
        out: Vec::new(),
    };
    for entry in &recorded.entries {
        feed.on_entry(entry);
    }
    feed.out
}

struct Feed {
    lockstep: bool,
    referee: Referee,
    /// Lockstep ticks sent so far (all completed when a start pose comes).
    ticks: u64,
    deploying: Option<RobotId>,
    out: Vec<GateEvent>,
}

impl Feed {
    fn on_entry(&mut self, entry: &Entry) {
        match entry {
            Entry::Command { robot, command: ToAgent::Deploy(_) } if self.referee.watched().is_none() => {
                self.deploying = Some(*robot);
            }
            Entry::Command { command: ToAgent::Tick(t), .. } => self.ticks = self.ticks.max(t.step),
            // A run of ticks is sent at its first tick.
            Entry::Command { command: ToAgent::Ticks(t), .. } => self.ticks = self.ticks.max(t.step),
            Entry::Command { command: ToAgent::GoalBearing(b), .. } if self.lockstep => {
                self.ticks = self.ticks.max(b.step);
            }
            Entry::Command { .. }
            | Entry::MocapFrame(_)
            | Entry::MocapModelDef(_)
            | Entry::CoreSetup(_)
            | Entry::CoreCalls(_) => {}
            Entry::Pose(pose) => self.on_pose(*pose),
            Entry::Gate(event) if event.kind == GateKind::Died => {
                // Not a pose decision: taken from the recording.
                if let Some(closed) = self.referee.close(event.robot.0) {
                    self.emit(GateKind::Died, &closed.pose);
                }
            }
            Entry::Gate(_) => {}
        }
    }

    fn on_pose(&mut self, pose: Pose) {
        let robot = pose.robot;
        if self.deploying == Some(robot) && self.referee.watched().is_none() {
            self.deploying = None;
            let start = self.referee.open(robot.0, pose, self.ticks);
            self.emit(GateKind::Deployed, &start);
            return;
        }
        match self.referee.observe(robot.0, pose) {
            Some(verdict) => {
                self.referee.close(robot.0);
                let (kind, at) = match verdict {
                    Verdict::Arrived(p) => (GateKind::Stopped { arrived: true }, p),
                    Verdict::Stuck(p) => (GateKind::Stopped { arrived: false }, p),
                };
                self.emit(kind, &at);
            }
            None => {
                if let Err(Closed { pose, .. }) = self.referee.budget_spent() {
                    self.emit(GateKind::Timeout, &pose);
                }
            }
        }
    }

    fn emit(&mut self, kind: GateKind, pose: &Pose) {
        self.out.push(GateEvent { robot: pose.robot, kind, x: pose.x, y: pose.y, step: pose.step });
    }
}
