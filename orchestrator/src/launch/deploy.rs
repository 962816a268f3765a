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

use super::agents::{AgentPlan, Gone, Started};
use super::config::{AgentsKind, Clock};
use super::engine::{Launch, SlotState, SLICE};
use super::events::{EventKind, LaunchEvent, EVENT_SCHEMA};
use super::lab::Placed;
use super::partition::AnswerWait;
use crate::mocap::MocapSource;
use anyhow::Result;
use bycoms_protocol::msg::{Deploy, ToAgent};
use bycoms_protocol::RobotId;
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
    /// Starts robot `id`'s agent (its ports and its poses are opened first).
    pub fn spawn(&mut self, id: u32) -> Result<()> {
        self.ports.open_robot(id)?;
        self.pose_source.open_robot(id)?;
        let mut args = self.template.clone();
        args.robot = id;
        args.zenoh_config = self.cfg.transport.agent_config_of(id);
        let plan = AgentPlan { args: &args, terrain_text: &self.world.terrain_text };
        let started = self.agents.start(id, &plan)?;
        let pid = match started {
            Started::Process { pid } => Some(pid),
            Started::Awaited => None,
        };
        if let Some(slot) = self.slot(id) {
            slot.pid = pid;
            slot.alive = true;
            slot.state = SlotState::Spawned;
        }
        self.progress.event(&format!("robot {id}: {started}"));
        let topic = format!("bycoms/{}/events", self.template.swarm);
        let source = self.agents.kind();
        let event = LaunchEvent {
            robot: id,
            event: EventKind::Spawned,
            pid,
            source: Some(source.to_string()),
            reason: None,
            state: None,
        };
        self.ports.recording.json(&topic, EVENT_SCHEMA, &event);
        Ok(())
    }

    /// For sources whose agents exist on their own (remote agents, robots
    /// behind gateways): expects every robot's agent now and waits until
    /// all have registered. False if the launch must end instead; robots
    /// whose agents never came are named in one error.
    pub fn await_everyone(&mut self) -> Result<bool> {
        if !self.agents.all_at_once() {
            return Ok(true);
        }
        for id in 1..=self.cfg.robots {
            self.spawn(id)?;
        }
        loop {
            if self.slots.iter().all(|s| s.state != SlotState::Spawned) {
                return Ok(true);
            }
            if self.must_end() {
                let never: Vec<String> = self
                    .slots
                    .iter()
                    .filter(|s| s.state == SlotState::Spawned && s.death.is_some())
                    .map(|s| s.id.to_string())
                    .collect();
                if !never.is_empty() {
                    let hint = match self.agents.kind() {
                        "remote" => {
                            " (start each with `sim-agent --transport zenoh --connect ENDPOINT --robot K` \
                             and the launch's swarm, swarm size, terrain and run flags)"
                        }
                        _ => "",
                    };
                    self.fatal = Some(anyhow::anyhow!(
                        "the {} agents of robots {} never registered within {} s{hint}",
                        self.agents.kind(),
                        never.join(", "),
                        self.cfg.supervision.register_timeout
                    ));
                }
                return Ok(false);
            }
            self.pump(SLICE)?;
        }
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
            // Lost while it settled (e.g. unreachable past the link grace):
            // the next robot.
            if !self.slot(id).is_some_and(|s| s.alive) {
                continue;
            }
            // A real robot is enabled only once the operator has put it on
            // the start and motion capture confirms it (`launch::lab`).
            if let Some(placement) = self.placement() {
                match self.place(id, placement)? {
                    Placed::Yes => {}
                    Placed::Lost => continue,
                    Placed::End => return Ok(Next::Ended),
                }
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

    /// How real robots' placement is confirmed; `None` for simulated agents
    /// (they are put at the start by `Deploy` itself).
    fn placement(&self) -> Option<crate::mocap::PlacementConfig> {
        if self.cfg.agents.source != AgentsKind::Real {
            return None;
        }
        let natnet = self.cfg.mocap.natnet.as_ref().filter(|_| self.cfg.mocap.source == MocapSource::Natnet);
        Some(natnet.map_or(self.cfg.agents.placement, |n| n.placement))
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
                let period = self.cfg.wall_period();
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
        // A robot whose agent is gone is never deployed (nor its `Lost`
        // state overwritten).
        if !self.slot(id).is_some_and(|s| s.alive) {
            return Ok(false);
        }
        self.ports.send(id, &ToAgent::Deploy(deploy))?;
        if let Some(slot) = self.slot(id) {
            slot.state = SlotState::Deploying;
        }
        self.pending_deploy = Some(deploy);
        let deployed = self.await_start_pose(id);
        self.pending_deploy = None;
        deployed
    }

    /// Waits for robot `id`'s start pose after `Deploy`: re-sent every
    /// [`RESEND`](super::partition::RESEND), waited for while the agent is unreachable (`partition`).
    fn await_start_pose(&mut self, id: u32) -> Result<bool> {
        let mut wait = AnswerWait::new(Duration::from_secs_f64(self.cfg.supervision.tick_timeout));
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
            if wait.resend_due(now, self.unreachable(id)) {
                self.resend(&[id])?;
            }
            if wait.expired(now) {
                self.agents.kill(id);
                self.on_death(id, Gone::NoStartPose);
                return Ok(false);
            }
            self.pump(wait.slice(now))?;
        }
    }
}
