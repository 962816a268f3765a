//! Acting on the gate's verdicts: close a robot's deployment, open the
//! gate for the next one, or end the run.
//!
//! Why here and not in the gate: the gate ([`super::gate`]) only judges
//! poses; ending a deployment means telling the agent (`Stop`), publishing
//! the gate event, charging the robot's active steps to the time budget and
//! noting when the decision was taken (the gate-reaction benchmark's start).

use super::engine::{Launch, Pending, SlotState};
use super::gate::Verdict;
use super::summary::Outcome;
use anyhow::Result;
use bycoms_protocol::msg::{GateEvent, GateKind, Pose, ToAgent};
use std::time::Instant;

impl Launch {
    /// Acts on every queued verdict. Returns the outcome if the run is won.
    pub fn settle_verdicts(&mut self) -> Result<Option<Outcome>> {
        while let Some(p) = self.queue.pop_front() {
            let (id, state, kind, pose) = match p {
                Pending::Verdict(id, Verdict::Arrived(pose)) => {
                    (id, SlotState::Arrived, GateKind::Stopped { arrived: true }, Some(pose))
                }
                Pending::Verdict(id, Verdict::Stuck(pose)) => {
                    (id, SlotState::Stuck, GateKind::Stopped { arrived: false }, Some(pose))
                }
                Pending::Died(id) => (id, SlotState::Died, GateKind::Died, None),
            };
            let Some((watched, watch)) = self.watch.take() else { continue };
            if watched != id {
                self.watch = Some((watched, watch));
                continue;
            }
            let pose = pose.unwrap_or_else(|| watch.last());
            let steps = watch.active_steps();
            self.spent += steps;
            self.decided_at = Some(Instant::now());
            if let Some(slot) = self.slot(id) {
                slot.state = state;
                slot.steps = steps;
                slot.last_pose = Some(pose);
                slot.decided_tick = Some(pose.step);
            }
            self.announce(id, kind, &pose)?;
            // A stuck real robot would keep pushing against what holds it:
            // motors off; it stays a beacon (its speaker keeps playing).
            let real = self.cfg.agents.source == super::config::AgentsKind::Real;
            if state == SlotState::Stuck && real && self.agents.is_running(id) {
                self.ports.send(id, &ToAgent::Stop)?;
            }
            if state == SlotState::Arrived {
                if self.agents.is_running(id) {
                    self.ports.send(id, &ToAgent::Stop)?;
                }
                return Ok(Some(Outcome::Arrived));
            }
        }
        Ok(None)
    }

    /// Whether the moving robot has used up the time budget (then it is
    /// marked unfinished and the run ends).
    ///
    /// A robot whose active steps exactly reach the budget may have stopped
    /// on its very last period (the runner then counts it stuck, a beacon):
    /// the gate keeps watching it, without charging anything, until it
    /// either changes pose once more (it was still moving: unfinished, at
    /// its pose at the limit) or is judged stopped.
    pub fn budget_spent(&mut self) -> Result<bool> {
        let mut run = self.template.run_config();
        run.time_limit = self.cfg.time_limit;
        let limit = run.step_limit();
        let Some((id, watch)) = &self.watch else {
            return Ok(self.spent >= limit);
        };
        let budget = limit.saturating_sub(self.spent);
        let (id, steps) = (*id, watch.active_steps());
        if steps <= budget {
            return Ok(false);
        }
        // One change past the budget: the pose at the limit is the one before.
        let pose = if steps == budget + 1 { watch.previous() } else { watch.last() };
        let steps = budget;
        self.watch = None;
        self.spent += steps;
        if let Some(slot) = self.slot(id) {
            slot.state = SlotState::Unfinished;
            slot.steps = steps;
            slot.last_pose = Some(pose);
        }
        self.announce(id, GateKind::Timeout, &pose)?;
        Ok(true)
    }

    /// Publishes a gate event and prints it.
    pub fn announce(&mut self, id: u32, kind: GateKind, pose: &Pose) -> Result<()> {
        let event = GateEvent { robot: pose.robot, kind, x: pose.x, y: pose.y, step: pose.step };
        self.ports.publish_gate(&event)?;
        let what = match kind {
            GateKind::Stopped { arrived: true } => "arrived at the goal",
            GateKind::Stopped { arrived: false } => "stopped short of the goal: stuck, now a beacon",
            GateKind::Died => "lost while moving: a beacon where it was last seen",
            GateKind::Timeout => "still moving at the time limit",
            GateKind::Deployed => "deployed",
        };
        self.progress
            .event(&format!("robot {id}: {what} at ({:.2}, {:.2}), step {}", pose.x, pose.y, pose.step));
        Ok(())
    }
}
