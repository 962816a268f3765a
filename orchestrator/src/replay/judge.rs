//! The gate, re-run over a recording's poses.
//!
//! Why re-derive the deployments too: a deployment is the launch acting on
//! an earlier decision (robot k stopped → robot k+1 goes), so the replay
//! opens the gate exactly as the launch does — robot k's first pose after
//! its `Deploy` command is its start pose, counted in lockstep from the
//! last tick sent (`launch::engine`'s `on_pose`) — and compares the
//! `Deployed` events as well. From the start pose on, the robot's poses go
//! through the launch's own [`Watch`] and time-budget rule
//! (`launch::decide`'s `budget_spent`). An agent's death is not a pose: a
//! recorded `Died` event is taken as given (the watch closes there).

use super::read::{Entry, Recorded};
use crate::launch::gate::{GateParams, Verdict, Watch};
use crate::launch::Clock;
use bycoms_protocol::msg::{GateEvent, GateKind, Pose, ToAgent};
use bycoms_protocol::RobotId;

/// The gate parameters and step budget of a recorded run.
pub fn gate_params(recorded: &Recorded) -> (GateParams, u64) {
    let cfg = &recorded.run.config;
    let params = GateParams {
        goal: recorded.run.goal,
        goal_radius: cfg.goal_radius,
        stop_speed: cfg.gate.stop_speed,
        stop_turn_rate: cfg.gate.stop_turn_rate,
        dwell_us: (cfg.gate.dwell * 1e6).round() as u64,
        period_us: cfg.dt_us(),
    };
    let mut run = bycoms_sim::RunConfig::paper(cfg.eps);
    run.time_limit = cfg.time_limit;
    (params, run.step_limit())
}

/// The gate events a replay reaches from `recorded`'s poses, in order.
pub fn rejudge(recorded: &Recorded) -> Vec<GateEvent> {
    let (params, limit) = gate_params(recorded);
    let mut gate = ReplayGate {
        params,
        limit,
        lockstep: recorded.run.config.clock == Clock::Lockstep,
        ticks: 0,
        deploying: None,
        watch: None,
        spent: 0,
        out: Vec::new(),
    };
    for entry in &recorded.entries {
        gate.on_entry(entry);
    }
    gate.out
}

struct ReplayGate {
    params: GateParams,
    limit: u64,
    lockstep: bool,
    /// Lockstep ticks sent so far (all completed when a start pose comes).
    ticks: u64,
    deploying: Option<RobotId>,
    watch: Option<(RobotId, Watch)>,
    spent: u64,
    out: Vec<GateEvent>,
}

impl ReplayGate {
    fn on_entry(&mut self, entry: &Entry) {
        match entry {
            Entry::Command { robot, command: ToAgent::Deploy(_) } if self.watch.is_none() => {
                self.deploying = Some(*robot);
            }
            Entry::Command { command: ToAgent::Tick(t), .. } => self.ticks = self.ticks.max(t.step),
            Entry::Command { command: ToAgent::GoalBearing(b), .. } if self.lockstep => {
                self.ticks = self.ticks.max(b.step);
            }
            Entry::Command { .. } | Entry::MocapFrame(_) | Entry::MocapModelDef(_) => {}
            Entry::Pose(pose) => self.on_pose(*pose),
            Entry::Gate(event) if event.kind == GateKind::Died => {
                // Not a pose decision: taken from the recording.
                if self.watch.as_ref().is_some_and(|(id, _)| *id == event.robot) {
                    if let Some((_, watch)) = self.watch.take() {
                        self.spent += watch.active_steps();
                        self.emit(GateKind::Died, &watch.last());
                    }
                }
            }
            Entry::Gate(_) => {}
        }
    }

    fn on_pose(&mut self, pose: Pose) {
        let robot = pose.robot;
        if self.deploying == Some(robot) && self.watch.is_none() {
            self.deploying = None;
            let mut start = pose;
            if self.lockstep {
                start.step = self.ticks;
            }
            self.watch = Some((robot, Watch::new(self.params, start)));
            self.emit(GateKind::Deployed, &start);
            return;
        }
        let Some((_, watch)) = self.watch.as_mut().filter(|(id, _)| *id == robot) else { return };
        match watch.observe(pose) {
            Some(verdict) => {
                let steps = watch.active_steps();
                self.spent += steps;
                self.watch = None;
                let (kind, at) = match verdict {
                    Verdict::Arrived(p) => (GateKind::Stopped { arrived: true }, p),
                    Verdict::Stuck(p) => (GateKind::Stopped { arrived: false }, p),
                };
                self.emit(kind, &at);
            }
            None => self.check_budget(),
        }
    }

    /// `launch::decide`'s `budget_spent`, rule for rule.
    fn check_budget(&mut self) {
        let Some((_, watch)) = &self.watch else { return };
        let budget = self.limit.saturating_sub(self.spent);
        let steps = watch.active_steps();
        if steps <= budget {
            return;
        }
        let pose = if steps == budget + 1 { watch.previous() } else { watch.last() };
        self.watch = None;
        self.spent += budget;
        self.emit(GateKind::Timeout, &pose);
    }

    fn emit(&mut self, kind: GateKind, pose: &Pose) {
        self.out.push(GateEvent { robot: pose.robot, kind, x: pose.x, y: pose.y, step: pose.step });
    }
}
