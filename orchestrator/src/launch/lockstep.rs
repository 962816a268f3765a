//! The lockstep driver: the orchestrator is the clock.
//!
//! Why it reproduces the in-process runner exactly: per tick `t` the moving
//! robot gets its goal bearing for `t` — computed from its pose after `t−1`
//! with the runner's own `Vec2::bearing_to` — and then every live agent gets
//! `Tick(t)`. The moving robot steps (the runner's `SimRobot::step`, same
//! beacons in the same order, same noise stream); stopped robots republish
//! their frozen pose; idle ones just answer. The orchestrator waits for
//! every `TickDone(t)` before judging the poses of `t`, so simulated time
//! never runs ahead of the gate. The ticks the gate spends watching a still
//! robot (the dwell) and settle ticks move no robot and are not charged to
//! the runner's step count (see `gate`).

use super::agents::Gone;
use super::deploy::Next;
use super::engine::{Launch, SlotState};
use super::partition::AnswerWait;
use super::summary::Outcome;
use anyhow::Result;
use bycoms_protocol::msg::{Tick, ToAgent};
use std::time::{Duration, Instant};

impl Launch {
    /// Runs the launch on the lockstep clock until it ends.
    pub fn run_lockstep(&mut self) -> Result<Outcome> {
        loop {
            if self.must_end() {
                return Ok(Outcome::Interrupted);
            }
            if let Some(outcome) = self.settle_verdicts()? {
                return Ok(outcome);
            }
            if self.watch.is_none() {
                if self.slot(self.next).is_none() {
                    return Ok(Outcome::RobotsExhausted);
                }
                if self.budget_spent()? {
                    return Ok(Outcome::TimeLimit);
                }
                match self.deploy_next()? {
                    Next::Deployed => {}
                    Next::NoneLeft => return Ok(Outcome::RobotsExhausted),
                    Next::Ended => continue,
                }
            }
            self.tick()?;
            if let Some(outcome) = self.settle_verdicts()? {
                return Ok(outcome);
            }
            if self.budget_spent()? {
                return Ok(Outcome::TimeLimit);
            }
        }
    }

    /// One lockstep tick: bearing, relays, `Tick` to every live agent, and
    /// the wait for all their answers (an agent that does not answer within
    /// `tick_timeout` is killed and treated as dead; what is unanswered is
    /// re-sent every [`RESEND`](super::partition::RESEND), and an unreachable agent is waited for,
    /// see `partition`).
    pub fn tick(&mut self) -> Result<()> {
        let t = self.ticks + 1;
        // Everything of tick t is logged at its simulated time t × dt.
        let dt = self.template.run_config().kinematics.dt;
        self.ports.recording.set_simulated_time((t as f64 * dt * 1e9).round() as u64);
        if let Some((id, pose)) = self.watch.as_ref().map(|(id, w)| (*id, w.last())) {
            self.send_bearing(id, &pose, t)?;
        }
        self.relay_dead(t, t * self.cfg.dt_us())?;
        self.current_tick = t;
        self.ticks_started += 1;
        self.awaiting.clear();
        let live: Vec<u32> = self
            .slots
            .iter()
            .filter(|s| s.alive && s.registered_before_tick.is_some() && s.state != SlotState::Lost)
            .map(|s| s.id)
            .collect();
        for id in live {
            self.ports.send(id, &ToAgent::Tick(Tick { step: t }))?;
            self.awaiting.insert(id);
        }
        let mut wait = AnswerWait::new(Duration::from_secs_f64(self.cfg.supervision.tick_timeout));
        while !self.awaiting.is_empty() && !self.must_end() {
            let now = Instant::now();
            // An unreachable agent is held, not timed out (`partition`):
            // the tick's deadline runs only while every awaited one is there.
            if wait.resend_due(now, self.any_unreachable(self.awaiting.iter().copied())) {
                let ids: Vec<u32> = self.awaiting.iter().copied().collect();
                self.resend(&ids)?;
            }
            if wait.expired(now) {
                let late: Vec<u32> = self.awaiting.iter().copied().collect();
                for id in late {
                    self.agents.kill(id);
                    self.on_death(id, Gone::NoTickReply);
                }
                break;
            }
            self.pump(wait.slice(now))?;
        }
        // Every answer is in, so every pose of tick t is in its queue.
        self.pump(Duration::ZERO)?;
        self.ticks = t;
        Ok(())
    }
}
