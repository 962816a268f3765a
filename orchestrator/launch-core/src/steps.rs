//! The core's decisions: the phase machine that [`LaunchCore::advance`] runs —
//! choosing, registration, settling, placement, deployment, the lockstep
//! tick, the verdicts in deployment order, the budget and the ending.

use super::*;

impl LaunchCore {
    /// Takes every decision due at `now`.
    pub fn advance(&mut self, now: u64) {
        self.supervise(now);
        loop {
            if self.ending.is_some() {
                return;
            }
            // First: what else went wrong then (robots lost, a fatal
            // error) followed from it.
            if let Some(gone) = self.mocap_gone(now, None) {
                return self.end(Outcome::Error, Some(gone));
            }
            if let Some(e) = self.fatal.clone() {
                self.name_the_missing();
                let error = self.fatal.take().unwrap_or(e);
                return self.end(Outcome::Error, Some(error));
            }
            if self.interrupted {
                return self.end(Outcome::Interrupted, None);
            }
            if self.stop_answers(now) {
                return;
            }
            if self.stop_due() {
                return self.stop_all(now);
            }
            if !self.setup.lockstep && self.phase != Phase::Begin && now >= self.relay_at {
                self.relay_frame += 1;
                let sim_us = (now as f64 * self.setup.speed) as u64;
                self.relay_dead(self.relay_frame, sim_us);
                self.send_beacons(now);
                self.relay_at = now + self.setup.wall_period_us.max(1);
            }
            if let Some(tick) = self.tick.as_mut() {
                if tick.open() {
                    let owing = tick.owing();
                    let held = owing.iter().any(|&id| {
                        let s = &self.slots[id as usize - 1];
                        s.alive && s.outages.last().is_some_and(|o| o.back_unix_ms.is_none())
                    });
                    let resend = tick.wait.resend_due(now, held);
                    let expired = tick.wait.expired(now);
                    if resend {
                        self.resend(&owing);
                    }
                    if !expired {
                        return;
                    }
                    for id in owing {
                        self.outputs.push_back(Output::Kill(id));
                        self.on_death(now, id, Gone::NoTickReply);
                    }
                    continue;
                }
                self.tick_answered(now);
            }
            if !self.step_phase(now) {
                return;
            }
        }
    }

    /// The open tick was answered in full at `now`: timed, and done.
    fn tick_answered(&mut self, now: u64) {
        if let Some(step) = self.tick.as_ref().map(|t| t.step) {
            // Before the tick is over: its poses are judged against it.
            self.release_held(now, step);
        }
        let Some(tick) = self.tick.take() else { return };
        self.answer_time.answered(&tick.wait, now);
        // A settling agent's beacons sent with the last tick again
        // (`sync_beacons`) are not a tick of their own.
        if tick.wait.resent() == 0 && tick.step > self.ticks {
            let took = now.saturating_sub(tick.wait.since());
            self.tick_time.0 += took;
            self.tick_time.1 += 1;
            if tick.quiet && !self.agent_starting() {
                self.quiet_tick_time.0 += took;
                self.quiet_tick_time.1 += u64::from(tick.agents);
            }
        }
        self.ticks = tick.step;
    }

    /// One step of the phase machine; false when it must wait.
    pub(super) fn step_phase(&mut self, now: u64) -> bool {
        match self.phase {
            Phase::Begin => self.step_begin(),
            Phase::AwaitingEveryone => {
                let waiting =
                    self.slots.iter().any(|s| matches!(s.state, SlotState::Spawned | SlotState::Waiting));
                if !waiting {
                    self.phase = Phase::Choosing;
                }
                !waiting
            }
            Phase::Choosing | Phase::Watching => self.step_watching(now),
            Phase::AwaitingRegistration(id) => self.step_registration(id, now),
            Phase::Settling(id, until) => self.step_settling(id, until, now),
            Phase::Placing(id, placing) => self.step_placing(id, placing, now),
            Phase::AwaitingStartPose(id, wait) => self.step_start_pose(id, wait, now),
            Phase::Finished => false,
        }
    }

    /// The launch begins: with every agent at once (remote agents, real
    /// robots) they are all started, and awaited when each one is needed.
    fn step_begin(&mut self) -> bool {
        if !self.setup.agents.all_at_once {
            self.phase = Phase::Choosing;
            return true;
        }
        for id in 1..=self.setup.robots {
            self.start_agent(id);
        }
        // Robots are needed when their turn comes, unless every one is.
        self.phase =
            if self.setup.missing == Missing::Fail { Phase::AwaitingEveryone } else { Phase::Choosing };
        // Starting is carried out by the shell before the core goes on.
        false
    }

    /// Robot `id`'s agent was started for its turn: settle it once it
    /// registered, start it again if it died first, skip it when it is gone.
    fn step_registration(&mut self, id: u32, now: u64) -> bool {
        match self.slot_ref(id).map(|s| s.state) {
            Some(SlotState::Registered) => {
                self.settle(id, now);
                true
            }
            Some(SlotState::Spawned) => false,
            Some(SlotState::Waiting) => {
                // Started once more (it died before it registered).
                self.start_agent(id);
                false
            }
            _ => {
                self.next = self.next.max(id + 1);
                self.phase = Phase::Choosing;
                true
            }
        }
    }

    /// Robot `id` settles: its beacons are sent before it is deployed.
    fn step_settling(&mut self, id: u32, until: Option<u64>, now: u64) -> bool {
        if until.is_some_and(|u| now < u) {
            return false;
        }
        if !self.beacons_held(id, now) && self.slot_ref(id).is_some_and(|s| s.alive) {
            // More beacons than one send holds, or sent just now: lockstep
            // sends the rest with the last tick again, real time waits for
            // the next period's send.
            if self.setup.lockstep {
                self.sync_beacons(id, now);
                return true;
            }
            return false;
        }
        self.settled(id, now);
        true
    }

    /// Robot `id` was told `Deploy`: re-send it while unanswered, give up
    /// when its start pose never comes, watch it once it moves.
    fn step_start_pose(&mut self, id: u32, mut wait: AnswerWait, now: u64) -> bool {
        match self.slot_ref(id).map(|s| s.state) {
            Some(SlotState::Deploying) => {
                if wait.resend_due(now, self.unreachable(id)) {
                    self.resend(&[id]);
                }
                if wait.expired(now) {
                    self.pending_deploy = None;
                    self.outputs.push_back(Output::Kill(id));
                    self.on_death(now, id, Gone::NoStartPose);
                    self.phase = Phase::Choosing;
                    return true;
                }
                self.phase = Phase::AwaitingStartPose(id, wait);
                false
            }
            Some(SlotState::Moving) => {
                self.pending_deploy = None;
                self.next = self.next.max(id + 1);
                if self.setup.prespawn {
                    self.start_ahead();
                }
                self.phase = Phase::Watching;
                true
            }
            _ => {
                self.pending_deploy = None;
                self.phase = Phase::Choosing;
                true
            }
        }
    }

    /// A robot under watch, or none: verdicts, the budget, the next tick or
    /// the next deployment.
    pub(super) fn step_watching(&mut self, now: u64) -> bool {
        if let Some(outcome) = self.settle_verdicts(now) {
            self.end(outcome, None);
            return false;
        }
        let lockstep = self.setup.lockstep;
        if self.referee.watched().is_some() {
            if self.budget_spent() {
                self.end(Outcome::TimeLimit, None);
                return false;
            }
            if lockstep {
                self.start_tick(now);
                return true;
            }
            return false;
        }
        self.phase = Phase::Choosing;
        // A robot that joined late goes before the next one in order.
        let late = self.late.front().copied();
        let id = late.unwrap_or(self.next);
        if self.slot_ref(id).is_none() {
            match self.none_registered() {
                Some(error) => self.end(Outcome::Error, Some(error)),
                None => self.end(Outcome::RobotsExhausted, None),
            }
            return false;
        }
        if self.budget_spent() {
            self.end(Outcome::TimeLimit, None);
            return false;
        }
        if late.is_some() {
            self.late.pop_front();
        }
        match self.slot_ref(id).map(|s| s.state) {
            Some(SlotState::Lost | SlotState::Absent) => {
                if late.is_none() {
                    self.next += 1;
                }
                return true;
            }
            Some(SlotState::Waiting) => {
                self.start_agent(id);
                self.phase = Phase::AwaitingRegistration(id);
                // The shell starts it before the core goes on.
                return false;
            }
            _ => {}
        }
        self.phase = Phase::AwaitingRegistration(id);
        true
    }

    /// The robot before `next` moves: the agents of the next robots
    /// ([`Starts::ahead`](super::Starts::ahead) of them) are started while
    /// it does, each once (one that died before its turn is started again
    /// at its turn).
    fn start_ahead(&mut self) {
        let ahead = self.setup.starts.ahead.max(1);
        for next in self.next..self.next.saturating_add(ahead) {
            if self.slot_ref(next).is_some_and(|s| s.state == SlotState::Waiting && s.restarts == 0) {
                self.start_agent(next);
            }
        }
    }

    /// Asks the shell to start robot `id`'s agent; from now on it is
    /// starting, so no second start is asked for it. Why at once: a shell
    /// carries the start out after `advance`, and at a high speed-up a robot
    /// deployed and judged in one `advance` had its prespawned successor
    /// started twice (the successor still looked not started).
    pub(super) fn start_agent(&mut self, id: u32) {
        if self.is_revoked(id) {
            return;
        }
        self.outputs.push_back(Output::Start(id));
        if self.slot_ref(id).is_some_and(|s| s.state == SlotState::Waiting) {
            self.set_state(id, SlotState::Spawned);
        }
    }

    /// Makes sure robot `id` hears every beacon before it moves: an agent's
    /// field comes from the other robots' poses and the bus keeps no
    /// history, so one full period must run after it registered. In
    /// lockstep always exactly one tick (so tick numbers do not depend on
    /// how fast an agent starts; the tick moves no robot); in real time two
    /// periods of wall time after its registration.
    pub(super) fn settle(&mut self, id: u32, now: u64) {
        if self.setup.lockstep {
            self.phase = Phase::Settling(id, None);
            self.start_tick(now);
        } else {
            let registered = self.slot_ref(id).and_then(|s| s.registered_at).unwrap_or(now);
            self.phase = Phase::Settling(id, Some(registered + 2 * self.setup.wall_period_us));
        }
    }

    /// Robot `id` has settled: placed by the operator if it must be, then
    /// told to deploy.
    pub(super) fn settled(&mut self, id: u32, now: u64) {
        // Lost while it settled: the next robot.
        if !self.slot_ref(id).is_some_and(|s| s.alive) {
            self.phase = Phase::Choosing;
            return;
        }
        let Some(config) = self.placement_of(id) else {
            return self.open_gate(id, now);
        };
        let start = self.setup.start;
        self.outputs.push_back(Output::Carried(id, true));
        self.note(format!(
            "OPERATOR: place robot {id} at the start ({:.2}, {:.2}) — it is enabled once motion capture sees it there",
            start.x, start.y
        ));
        tracing::info!(
            robot = id,
            x = start.x,
            y = start.y,
            "operator asked to place the robot at the start"
        );
        self.outputs.push_back(Output::AskOperator(self.deploy_of(id)));
        self.placement = Some(PlacementWatch::new(RobotId(id), start, config));
        self.phase =
            Phase::Placing(id, Placing { since: now, reminded: now, seen_us: None, said_no_pose: false });
    }

    /// How robot `id` is placed by an operator: none for a simulated
    /// member of a mixed swarm (its `Deploy` puts it at the start).
    pub(super) fn placement_of(&self, id: u32) -> Option<PlacementConfig> {
        self.setup.agents.placement.filter(|_| !self.setup.members.is_simulated(id))
    }

    pub(super) fn placement_timeout_us(&self) -> u64 {
        self.setup.agents.placement.map_or(u64::MAX, |c| (c.timeout * 1e6) as u64)
    }

    pub(super) fn step_placing(&mut self, id: u32, mut placing: Placing, now: u64) -> bool {
        if self.slot_ref(id).is_none_or(|s| s.state != SlotState::Registered) {
            self.outputs.push_back(Output::Carried(id, false));
            self.phase = Phase::Choosing;
            return true;
        }
        let pose = self.slot_ref(id).and_then(|s| s.last_pose);
        if let Some(p) = pose.filter(|p| placing.seen_us != Some(p.time_us)) {
            placing.seen_us = Some(p.time_us);
            if self.placement.as_mut().is_some_and(|w| w.observe(&p)) {
                self.outputs.push_back(Output::Carried(id, false));
                self.note(format!("robot {id}: at the start ({:.2}, {:.2}), enabling it", p.x, p.y));
                self.open_gate(id, now);
                return true;
            }
        }
        if now >= placing.since.saturating_add(self.placement_timeout_us()) {
            let start = self.setup.start;
            let last = self.placement.as_ref().and_then(|w| w.last()).map(|p| (p.x, p.y));
            let timeout_s = self.setup.agents.placement.map_or(0.0, |c| c.timeout);
            self.outputs.push_back(Output::Carried(id, false));
            self.fatal.get_or_insert(Fault::NotPlaced {
                robot: id,
                start: (start.x, start.y),
                timeout_s,
                last,
            });
            return true;
        }
        if now >= placing.reminded.saturating_add(REMIND_EVERY_US) {
            placing.reminded = now;
            self.outputs.push_back(Output::AskOperator(self.deploy_of(id)));
            tracing::info!(robot = id, "still waiting for the robot at the start");
            self.say_no_pose(&mut placing, now);
        }
        self.phase = Phase::Placing(id, placing);
        false
    }

    /// Issue 49: a lab launch with no motion capture running asked for
    /// placement every second for 600 s. Once, a few seconds in, it says
    /// that no pose of any robot came (placing never ends without one).
    fn say_no_pose(&mut self, placing: &mut Placing, now: u64) {
        if self.pose_heard || placing.said_no_pose || now < placing.since.saturating_add(NO_POSE_AFTER_US) {
            return;
        }
        placing.said_no_pose = true;
        let waited = now.saturating_sub(placing.since) as f64 * 1e-6;
        let text = format!(
            "no motion-capture pose of any robot has arrived in {waited:.0} s: is the motion capture \
             running and streaming to this host ([mocap] in the config)?"
        );
        tracing::info!(waited_s = waited, "no motion-capture pose of any robot has arrived");
        self.note(text);
    }

    pub(super) fn deploy_of(&self, id: u32) -> Deploy {
        let (start, goal) = (self.setup.start, self.setup.goal);
        Deploy { robot: RobotId(id), x: start.x, y: start.y, heading: start.bearing_to(goal) }
    }

    /// Sends `Deploy` to robot `id`; its start pose is awaited next.
    pub(super) fn open_gate(&mut self, id: u32, now: u64) {
        // A robot whose agent is gone is never deployed.
        if !self.slot_ref(id).is_some_and(|s| s.alive) {
            self.phase = Phase::Choosing;
            return;
        }
        let deploy = self.deploy_of(id);
        self.outputs.push_back(Output::Send(id, ToAgent::Deploy(deploy)));
        self.set_state(id, SlotState::Deploying);
        // Deploying puts the robot at the start: its start pose is judged by
        // where it was put, not by any pose of it from before.
        self.anchors.forget(id);
        self.pending_deploy = Some(deploy);
        self.phase = Phase::AwaitingStartPose(id, self.answer_wait(now));
    }

    /// One lockstep tick: the moving robot's bearing, the relays, `Tick` to
    /// every live agent; its answers are awaited in `advance`.
    pub(super) fn start_tick(&mut self, now: u64) {
        let t = self.ticks + 1;
        let period = self.setup.params.period_us;
        // Everything of tick t is logged at its simulated time t × dt.
        self.outputs.push_back(Output::SimTime(t * period * 1000));
        if let Some((id, pose)) = self.referee.last() {
            self.send_bearing(id, &pose, t);
        }
        self.relay_dead(t, t * period);
        // Before the `Tick`: an agent that answers it holds them.
        self.send_beacons(t);
        self.ticks_started += 1;
        // A parked robot will never move again: its last pose stands, and
        // only the robot the gate watches needs a pose every step. A robot
        // not deployed yet steps nothing: its agent is ticked only while it
        // settles (its answer says it holds the beacons sent before, and
        // its tick count is the launch's when it is deployed); else it
        // costs the tick nothing. A robot that creeps once judged may run
        // several ticks ahead (`ahead.rs`).
        let watched = self.referee.watched();
        let settling = match self.phase {
            Phase::Settling(id, _) => Some(id),
            _ => None,
        };
        let live: Vec<u32> = self
            .slots
            .iter()
            .filter(|s| s.alive && s.registered_before_tick.is_some() && s.state != SlotState::Lost)
            .filter(|s| !s.parked || watched == Some(s.id))
            .filter(|s| s.state != SlotState::Registered || settling == Some(s.id))
            .map(|s| s.id)
            .collect();
        self.ticked_agents += live.len() as u64;
        let mut awaiting = BTreeSet::new();
        for &id in &live {
            let runs = self.slot_ref(id).is_some_and(|s| self.runs_ahead(s));
            let command = if runs { self.run_from(id, t) } else { Some(ToAgent::Tick(Tick { step: t })) };
            if let Some(command) = command {
                self.outputs.push_back(Output::Send(id, command));
                awaiting.insert(id);
            }
        }
        let wait = self.answer_wait(now);
        let pose_of = watched.filter(|id| live.contains(id));
        let (agents, quiet) = (live.len() as u32, !self.agent_starting());
        self.tick = Some(TickWait { step: t, awaiting, pose_of, wait, agents, quiet });
    }

    /// A wait for answers from `now`: up to the tick timeout, re-sending
    /// first after the answer time seen so far.
    pub(super) fn answer_wait(&self, now: u64) -> AnswerWait {
        // Nothing is lost on the way to an agent on this host: its answer
        // is late, and a re-send would only pile up (`Commands::kept`).
        if self.setup.commands.kept {
            return AnswerWait::without_resends(now, self.setup.tick_timeout_us);
        }
        AnswerWait::new(now, self.setup.tick_timeout_us, self.answer_time.first_resend_us())
    }

    /// Acts on every queued verdict; the outcome if the run is won.
    pub(super) fn settle_verdicts(&mut self, now: u64) -> Option<Outcome> {
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
            let Some(closed) = self.referee.close(id) else { continue };
            let pose = pose.unwrap_or(closed.pose);
            self.decided_at = Some(now);
            let running = self.is_running(id);
            self.set_state(id, state);
            if let Some(slot) = self.slot(id) {
                slot.steps = closed.steps;
                slot.last_pose = Some(pose);
                slot.decided_tick = Some(pose.step);
            }
            self.announce(id, kind, &pose, closed.steps);
            if matches!(state, SlotState::Stuck | SlotState::Died) {
                self.beacon_at(id, &pose);
            }
            // A stuck real robot would keep pushing against what holds it:
            // motors off; it stays a beacon.
            if state == SlotState::Stuck && self.setup.agents.stop_when_stuck && running {
                self.outputs.push_back(Output::Send(id, ToAgent::Stop));
            }
            if state == SlotState::Arrived {
                if running {
                    self.outputs.push_back(Output::Send(id, ToAgent::Stop));
                }
                return Some(Outcome::Arrived);
            }
        }
        None
    }

    /// Whether the budget is used up (a robot past it is unfinished).
    pub(super) fn budget_spent(&mut self) -> bool {
        match self.referee.budget_spent() {
            Ok(spent) => spent,
            Err(closed) => {
                let id = closed.robot;
                self.set_state(id, SlotState::Unfinished);
                if let Some(slot) = self.slot(id) {
                    slot.steps = closed.steps;
                    slot.last_pose = Some(closed.pose);
                }
                self.announce(id, GateKind::Timeout, &closed.pose, closed.steps);
                true
            }
        }
    }

    /// Publishes a gate event and notes it, with the robot's own `steps`
    /// (its active steps, the summary's). Why not the pose's step: it is
    /// the lockstep tick of the whole run in lockstep and the robot's own
    /// count in real time, and the line went down from robot 2 to robot 3.
    pub(super) fn announce(&mut self, id: u32, kind: GateKind, pose: &Pose, steps: u64) {
        let event = GateEvent { robot: pose.robot, kind, x: pose.x, y: pose.y, step: pose.step };
        self.outputs.push_back(Output::Gate(event));
        let what = match kind {
            GateKind::Stopped { arrived: true } => "arrived at the goal",
            GateKind::Stopped { arrived: false } => "stopped short of the goal: stuck, now a beacon",
            GateKind::Died => "lost while moving: a beacon where it was last seen",
            GateKind::Timeout => "still moving at the time limit",
            GateKind::Deployed => "deployed",
        };
        self.note(format!(
            "robot {id}: {what} at ({:.2}, {:.2}), {steps} steps after its deployment",
            pose.x, pose.y
        ));
    }

    /// When every robot was tried and no agent ever registered, the launch
    /// did not run at all (a broken agent executable, a wrong protocol):
    /// an error naming the first robot and why, not "robots exhausted".
    pub(super) fn none_registered(&self) -> Option<Fault> {
        if self.slots.iter().any(|s| s.registered_before_tick.is_some()) {
            return None;
        }
        let first = self.slots.iter().find(|s| s.death.is_some())?;
        let reason = first.death.as_ref().map(|d| d.reason.clone()).unwrap_or_default();
        Some(Fault::NoneRegistered { robot: first.id, why: first.gone, reason })
    }

    /// While every agent is awaited at the start, one error names every
    /// robot whose agent never came.
    pub(super) fn name_the_missing(&mut self) {
        if self.phase != Phase::AwaitingEveryone {
            return;
        }
        let never: Vec<u32> = self
            .slots
            .iter()
            .filter(|s| s.state == SlotState::Spawned && s.death.is_some())
            .map(|s| s.id)
            .collect();
        if !never.is_empty() {
            self.fatal = Some(Fault::NeverCame {
                robots: never,
                kind: self.setup.agents.kind.clone(),
                timeout_s: self.setup.register_timeout_s,
                hint: self.setup.agents.start_hint.clone(),
            });
        }
    }

    /// The launch is over: a robot still under watch is unfinished.
    pub(super) fn end(&mut self, outcome: Outcome, error: Option<Fault>) {
        if let Some(closed) = self.referee.watched().and_then(|id| self.referee.close(id)) {
            self.set_state(closed.robot, SlotState::Unfinished);
            if let Some(slot) = self.slot(closed.robot) {
                slot.steps = closed.steps;
                slot.last_pose = Some(closed.pose);
            }
        }
        self.tick = None;
        self.close_stop();
        self.phase = Phase::Finished;
        self.ending = Some(Ending { outcome, error });
    }
}
