//! Starting agents and opening the gate to the next robot.
//!
//! Why a settle step before deploying: an agent's field comes from the
//! other robots' poses, and the bus keeps no history, so a new agent knows a
//! beacon only once that beacon has published after the agent subscribed.
//! Stopped agents republish their pose every period (and the orchestrator
//! republishes dead robots'), so it is enough that one full period has run
//! since the new agent registered: in lockstep one tick started after its
//! registration (always exactly one settle tick per deployment, so tick
//! numbers do not depend on how fast an agent starts), in real time two
//! periods of wall time. With `prespawn`
//! (the default) the next agent registers while the current robot moves,
//! so by the time the gate opens this has long happened and deploying costs
//! one `Deploy` and one pose.

use super::config::Clock;
use super::engine::{Launch, SlotState, SLICE};
use super::supervise::Gone;
use anyhow::Result;
use bycoms_protocol::msg::{Deploy, ToAgent};
use bycoms_protocol::RobotId;
use serde_json::json;
use std::time::{Duration, Instant};

/// What [`Launch::deploy_next`] achieved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Next {
    /// A robot is deployed and under the gate's watch.
    Deployed,
    /// Every robot has been used.
    NoneLeft,
    /// Ctrl-C or a fatal error came first.
    Ended,
}

impl Launch {
    /// Starts robot `id`'s agent (its ports are opened first).
    pub fn spawn(&mut self, id: u32) -> Result<()> {
        self.ports.open_robot(id)?;
        let mut args = self.template.clone();
        args.robot = id;
        let pid = self.sup.spawn(id, &args.to_flags(), &self.world.terrain_text)?;
        if let Some(slot) = self.slot(id) {
            slot.pid = Some(pid);
            slot.alive = true;
            slot.state = SlotState::Spawned;
        }
        self.progress.event(&format!("robot {id}: agent started (pid {pid})"));
        let topic = format!("bycoms/{}/events", self.template.swarm);
        self.ports.recording.json(
            &topic,
            "bycoms.LaunchEvent",
            &json!({ "robot": id, "event": "spawned", "pid": pid }),
        );
        Ok(())
    }

    /// Deploys the next robot that can be deployed.
    pub fn deploy_next(&mut self) -> Result<Next> {
        loop {
            if self.must_end() {
                return Ok(Next::Ended);
            }
            let id = self.next;
            let Some(state) = self.slot(id).map(|s| s.state) else {
                return Ok(Next::NoneLeft);
            };
            match state {
                SlotState::Lost => {
                    self.next += 1;
                    continue;
                }
                SlotState::Waiting => self.spawn(id)?,
                _ => {}
            }
            match self.await_registration(id)? {
                Some(true) => {}
                Some(false) => continue,
                None => return Ok(Next::Ended),
            }
            self.settle(id)?;
            if self.must_end() {
                return Ok(Next::Ended);
            }
            if self.open_gate(id)? {
                self.next = id + 1;
                if self.cfg.gate.prespawn && self.slot(id + 1).is_some_and(|s| s.state == SlotState::Waiting)
                {
                    self.spawn(id + 1)?;
                }
                return Ok(Next::Deployed);
            }
        }
    }

    /// Waits until robot `id` is registered: `Some(true)`; its agent was
    /// lost (try the next robot): `Some(false)`; the launch must end: `None`.
    fn await_registration(&mut self, id: u32) -> Result<Option<bool>> {
        loop {
            match self.slot(id).map(|s| s.state) {
                Some(SlotState::Registered) => return Ok(Some(true)),
                Some(SlotState::Spawned) => {}
                _ => {
                    self.next = id + 1;
                    return Ok(Some(false));
                }
            }
            if self.must_end() {
                return Ok(None);
            }
            self.pump(SLICE)?;
        }
    }

    /// Makes sure robot `id` has heard every beacon (see the module docs).
    fn settle(&mut self, id: u32) -> Result<()> {
        let Some(slot) = self.slot(id) else { return Ok(()) };
        let registered_at = slot.registered_at;
        match self.cfg.clock {
            // Always exactly one tick, even when a prespawned agent has
            // long heard every beacon: whether it registered in time depends
            // on the machine, and the tick numbers a launch prints (and
            // records) must not. The tick moves no robot.
            Clock::Lockstep => self.tick()?,
            Clock::Realtime => {
                let period = Duration::from_secs_f64(0.1 / self.cfg.speed);
                let ready = registered_at.map(|t| t + 2 * period).unwrap_or_else(Instant::now);
                while Instant::now() < ready && !self.must_end() {
                    self.pump(SLICE.min(ready.saturating_duration_since(Instant::now())))?;
                }
            }
        }
        Ok(())
    }

    /// Sends `Deploy` and waits for the robot's start pose. Returns false if
    /// its agent was lost instead.
    fn open_gate(&mut self, id: u32) -> Result<bool> {
        let (start, goal) = (self.world.start, self.world.goal);
        let deploy = Deploy { robot: RobotId(id), x: start.x, y: start.y, heading: start.bearing_to(goal) };
        self.ports.send(id, &ToAgent::Deploy(deploy))?;
        if let Some(slot) = self.slot(id) {
            slot.state = SlotState::Deploying;
        }
        let deadline = Instant::now() + Duration::from_secs_f64(self.cfg.supervision.tick_timeout);
        loop {
            match self.slot(id).map(|s| s.state) {
                Some(SlotState::Deploying) => {}
                Some(SlotState::Moving) => return Ok(true),
                _ => return Ok(false),
            }
            if self.must_end() {
                return Ok(false);
            }
            let now = Instant::now();
            if now >= deadline {
                self.sup.kill(id);
                self.on_death(id, Gone::NoStartPose);
                return Ok(false);
            }
            self.pump(SLICE.min(deadline - now))?;
        }
    }
}
