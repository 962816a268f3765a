//! The core's bookkeeping of inputs: what each report, pose, death and
//! change of reach means for the robots' slots.
//!
//! Decisions taken here are only those that follow from one input alone
//! (the list is in `mod.rs`: refusals of a registration or a pose, a start
//! pose accepted, the dead-robot policy of a reported death, a withdrawn
//! token without a grace, reachability lost or back). Nothing that depends
//! on time or on other inputs of the same pass: timers, verdicts in
//! deployment order, the tick, the phase machine and the ending are
//! `advance`'s (`steps.rs`, `timers.rs`), so a shell can hand in everything
//! that arrived together before the core acts on it.

use super::held::Held;
use super::*;

/// How far from its `Deploy`'s position a simulated robot's start pose may
/// lie, units: its agent puts it there exactly.
const START_TOLERANCE: f64 = 1e-6;

impl LaunchCore {
    pub(super) fn on_started(&mut self, now: u64, id: u32, pid: Option<u32>, how: &str) {
        if let Some(slot) = self.slot(id) {
            slot.pid = pid;
            slot.alive = true;
            // A late joiner is expected again after it registered.
            let state = if slot.registered_before_tick.is_some() {
                SlotState::Registered
            } else {
                SlotState::Spawned
            };
            self.set_state(id, state);
        }
        self.watch_started(now, id);
        self.note(format!("robot {id}: {how}"));
        self.event(id, EventKind::Spawned, pid, None);
    }

    pub(super) fn on_report(&mut self, now: u64, msg: FromAgent) {
        let id = msg.robot().0;
        let Some(registered) = self.admit(now, &msg) else { return };
        self.outputs.push_back(Output::Heard(id));
        self.watch_heard(now, id);
        let current = self.tick.as_ref().map(|t| t.step);
        match msg {
            // A repeat: the agent had not heard from us yet when it sent it.
            FromAgent::Register(_) if registered => {}
            FromAgent::Register(r) => self.on_register(now, id, r.instance),
            FromAgent::Heartbeat(_) => {}
            // Of a step after the tick in flight (an agent that ran
            // ahead): held until that tick (`ahead.rs`).
            FromAgent::Status(s) => {
                if !self.held_back(id, s.step, Held::Mode(s.mode)) {
                    self.take_mode(id, s.mode);
                }
            }
            FromAgent::Parked(p) => {
                if !self.held_back(id, p.step, Held::Parked) {
                    self.take_parked(id);
                }
            }
            FromAgent::TickDone(t) => {
                if let Some(tick) = self.tick.as_mut().filter(|_| Some(t.step) == current) {
                    tick.awaiting.remove(&id);
                }
            }
            // A real robot's telemetry and a ROS 2 robot's commands are for
            // recorders and monitors; a clock offset was kept when the
            // report was admitted.
            FromAgent::Telemetry(_) | FromAgent::Commanded(_) | FromAgent::Clock(_) => {}
            FromAgent::Link(l) => {
                if !l.up {
                    tracing::warn!(robot = id, silent_ms = l.silent_ms, "robot {id}'s link is lost");
                }
                self.watch_robot_link(now, id, l.up);
            }
            FromAgent::Failsafe(f) => self.on_failsafe(id, f.silent_ms),
            FromAgent::StopDone(d) => self.on_stop_done(now, id, d.on_link),
        }
    }

    /// Whether a report is taken (`Some`), and whether its agent had
    /// registered before it. A report of an unknown robot is bad traffic;
    /// a clock offset is kept even before its agent registers (to judge
    /// the registration by it); until its `Register` arrives an agent is
    /// not heard from: a registration that was lost must not be hidden by
    /// heartbeats (the agent repeats it with every heartbeat until it is
    /// answered, and the registration timeout still applies).
    fn admit(&mut self, now: u64, msg: &FromAgent) -> Option<bool> {
        let id = msg.robot().0;
        let known = self.slot_ref(id).is_some_and(|s| s.state != SlotState::Waiting);
        if !known {
            self.outputs
                .push_back(Output::Bad(BadKind::UnknownRobot, format!("{msg:?} from an unknown robot")));
            return None;
        }
        if let FromAgent::Clock(c) = msg {
            self.on_clock(now, c);
        }
        let registered = self.slot_ref(id)?.registered_before_tick.is_some();
        match msg {
            FromAgent::Register(r) => {
                let taken = self.register_taken(id, r, registered);
                (taken && (registered || self.may_register(id))).then_some(registered)
            }
            // An agent started but not registered yet was told a stop
            // `now` too: its answer counts, though it is not heard from.
            FromAgent::StopDone(d) if !registered => {
                self.on_stop_done(now, id, d.on_link);
                None
            }
            _ => registered.then_some(true),
        }
    }

    /// Whether a `Register` is taken: of our protocol version (anyone may
    /// send anything on a bus: counted, never fatal; the robot is still
    /// awaited and, should its own agent never register, its death says
    /// why), not a second agent for a registered robot, and not refused.
    fn register_taken(&mut self, id: u32, r: &Register, registered: bool) -> bool {
        let Some(slot) = self.slot(id) else { return false };
        let kept = slot.instance;
        if r.protocol_version != PROTOCOL_VERSION {
            let v = r.protocol_version;
            if !registered {
                slot.foreign_version = Some(v);
            }
            let text = format!("robot {id} registers with protocol {v}");
            self.outputs.push_back(Output::Bad(BadKind::WrongVersion, text));
            return false;
        }
        if registered && kept != Some(r.instance) {
            self.refuse(id, r.instance, Refusal::Duplicate);
            return false;
        }
        if !registered {
            if let Some(why) = self.refusal_of(r).or_else(|| self.clock_refusal(id)) {
                self.refuse(id, r.instance, why);
                return false;
            }
        }
        true
    }

    /// An agent's first `Register` taken: it speaks for its robot from now
    /// on; an agent that was given up for lost joins late, for the next turn.
    fn on_register(&mut self, now: u64, id: u32, instance: u64) {
        let (ticks_started, all_at_once) = (self.ticks_started, self.setup.agents.all_at_once);
        let Some(slot) = self.slot(id) else { return };
        slot.instance = Some(instance);
        slot.parked = false;
        slot.registered_before_tick = Some(ticks_started);
        slot.registered_at = Some(now);
        let was = slot.state;
        if matches!(was, SlotState::Spawned | SlotState::Absent) {
            self.set_state(id, SlotState::Registered);
        }
        if was == SlotState::Absent {
            let Some(slot) = self.slot(id) else { return };
            slot.late = true;
            slot.death = None;
            self.late.push_back(id);
            // Expected again: its source supervises it from now on.
            self.outputs.push_back(Output::Start(id));
            self.note(format!("robot {id}: registered late; it takes the next turn"));
            self.event(id, EventKind::JoinedLate, None, None);
        } else if all_at_once {
            self.note(format!("robot {id}: agent registered (instance {instance:016x})"));
        }
    }

    /// An agent's failsafe stopped its robot: said when it fires and again
    /// whenever the agent hears us after that, recorded once.
    fn on_failsafe(&mut self, id: u32, silent_ms: u32) {
        let Some(slot) = self.slot(id) else { return };
        if slot.failsafe_fired {
            return;
        }
        slot.failsafe_fired = true;
        self.note(format!(
            "robot {id}: its agent's failsafe stopped it (the orchestrator was gone for {silent_ms} ms)"
        ));
        let why = Some(format!("orchestrator gone for {silent_ms} ms"));
        self.event(id, EventKind::FailsafeFired, None, why);
    }

    /// Why an agent's first `Register` must be refused, if it must: run
    /// settings other than the launch's, or a failsafe that would stop its
    /// robot for good while the launch still waits for it.
    fn refusal_of(&self, r: &Register) -> Option<Refusal> {
        if r.settings != 0 && self.setup.settings != 0 && r.settings != self.setup.settings {
            return Some(Refusal::Settings { launch: self.setup.settings });
        }
        let launch_ms = least_failsafe_grace_ms(self.setup.supervision.unreachable_grace_us);
        (r.failsafe_grace_ms != 0 && r.failsafe_grace_ms < launch_ms).then_some(Refusal::Grace { launch_ms })
    }

    /// An agent (instance `instance`) that registers for robot `id` is
    /// refused: a second agent for a robot that already has one (the first
    /// stays), or one that cannot run this launch (`why`). Counted and told
    /// to leave.
    pub(super) fn refuse(&mut self, id: u32, instance: u64, why: Refusal) {
        let text = match why {
            Refusal::Duplicate => {
                let kept = self.slot_ref(id).and_then(|s| s.instance).unwrap_or_default();
                format!("robot {id} registered again by another agent (instance {instance:016x}, kept {kept:016x})")
            }
            _ => format!("robot {id}'s agent (instance {instance:016x}) refused: {why}"),
        };
        let kind = match why {
            Refusal::Duplicate => BadKind::Duplicate,
            _ => BadKind::Refused,
        };
        tracing::warn!(robot = id, instance = format_args!("{instance:016x}"), "{text}");
        self.outputs.push_back(Output::Bad(kind, text));
        self.outputs
            .push_back(Output::Send(id, ToAgent::Refused(Refused { robot: RobotId(id), instance, why })));
    }

    pub(super) fn on_pose(&mut self, now: u64, topic: u32, pose: Pose) {
        self.pose_heard = true;
        if pose.robot.0 != topic {
            let got = pose.robot;
            self.outputs.push_back(Output::Bad(
                BadKind::UnknownRobot,
                format!("pose of {got} on robot {topic}'s topic"),
            ));
            return;
        }
        let lockstep = self.setup.lockstep;
        let Some(slot) = self.slot_ref(topic) else { return };
        if !slot.alive || matches!(slot.state, SlotState::Waiting | SlotState::Spawned | SlotState::Lost) {
            // Our own relay of a dead robot, or a stray sample.
            return;
        }
        let state = slot.state;
        if self.held_back(topic, pose.step, Held::Pose(pose)) {
            return;
        }
        let clock = self.pose_clock(now, topic);
        let judged = match state {
            SlotState::Registered | SlotState::Absent => {
                return self.on_pose_before_deployment(topic, pose, clock)
            }
            SlotState::Deploying => {
                self.anchors.accept_start(topic, &pose, clock, self.start_at()).map(|()| true)
            }
            _ => self.anchors.accept(topic, &pose, clock),
        };
        match judged {
            Ok(true) => {}
            // A repeat or a late sample: nothing new (the gate has seen it).
            Ok(false) => return,
            Err(why) => return self.refuse_pose(topic, &pose, why),
        }
        if self.forwards_poses_to(topic) {
            self.outputs.push_back(Output::Forward(pose));
        }
        if self.is_beacon(topic) {
            // A beacon that moves on (a robot judged stuck that creeps).
            self.beacon_at(topic, &pose);
        }
        let Some(slot) = self.slot(topic) else { return };
        slot.last_pose = Some(pose);
        if !lockstep && state != SlotState::Deploying {
            slot.frames.observe(pose.step);
        }
        self.moved(topic, pose);
        if state == SlotState::Deploying && self.referee.watched().is_none() {
            self.deployed(now, topic, pose);
        } else if self.referee.watched() == Some(topic) {
            if let Some(tick) = self.tick.as_mut().filter(|t| t.pose_of == Some(topic) && pose.step >= t.step)
            {
                tick.pose_of = None;
            }
            if let Some(v) = self.referee.observe(topic, pose) {
                self.queue.push_back(Pending::Verdict(topic, v));
            }
        } else {
            return;
        }
        if !lockstep && self.queue.is_empty() {
            self.send_bearing(topic, &pose, pose.step + 1);
        }
    }

    /// The clock robot `topic`'s pose is judged against: the tick in
    /// flight in lockstep, the launch's time at the robot's speed-up in
    /// real time (a mixed swarm's simulated members run faster,
    /// [`Members::speed_up`]).
    fn pose_clock(&self, now: u64, topic: u32) -> plausible::PoseClock {
        if self.setup.lockstep {
            let newest_step = self.tick.as_ref().map_or(self.ticks, |t| t.step);
            plausible::PoseClock::Lockstep { newest_step }
        } else {
            let speed = self.setup.speed * self.setup.members.speed_up(topic);
            plausible::PoseClock::Realtime { now_us: now, speed }
        }
    }

    /// Robot `topic`'s start pose, accepted: it is deployed and under the
    /// gate's watch from there.
    fn deployed(&mut self, now: u64, topic: u32, pose: Pose) {
        let start = self.referee.open(topic, pose, self.ticks);
        let reaction = self.decided_at.map(|d| now.saturating_sub(d));
        self.set_state(topic, SlotState::Moving);
        let Some(slot) = self.slot(topic) else { return };
        slot.deployed_tick = Some(start.step + 1);
        slot.reaction_us = reaction;
        self.first_moving_us.get_or_insert(now);
        let event =
            GateEvent { robot: pose.robot, kind: GateKind::Deployed, x: pose.x, y: pose.y, step: start.step };
        self.outputs.push_back(Output::Gate(event));
        self.note(format!("robot {topic}: deployed at ({:.2}, {:.2})", pose.x, pose.y));
    }

    /// A pose of robot `id` before its deployment: it anchors nothing,
    /// starts nothing and is not shown (`moved.rs`). While an operator
    /// places the robot, the placement check reads it (if it is plausible
    /// on its own); otherwise a robot on
    /// motion capture is seen standing by (nothing to do), and a simulated
    /// robot has no pose before it is deployed: someone else's.
    fn on_pose_before_deployment(&mut self, id: u32, pose: Pose, clock: plausible::PoseClock) {
        let placing = matches!(self.phase, Phase::Placing(placed, _) if placed == id);
        if !placing {
            if self.setup.agents.placement.is_none() {
                let text =
                    format!("pose of robot {id} at step {} refused: robot {id} is not deployed", pose.step);
                self.outputs.push_back(Output::Bad(BadKind::Refused, text));
            }
            return;
        }
        if let Err(why) = self.anchors.check_alone(&pose, clock) {
            return self.refuse_pose(id, &pose, why);
        }
        if self.forwards_poses_to(id) {
            self.outputs.push_back(Output::Forward(pose));
        }
        if let Some(slot) = self.slot(id) {
            slot.last_pose = Some(pose);
        }
    }

    /// Whether robot `id`'s agent is handed the poses the launch sees: a
    /// real robot's, when they do not come over the bus (a simulated
    /// member of a mixed swarm is its own motion capture).
    fn forwards_poses_to(&self, id: u32) -> bool {
        self.setup.agents.forward_poses && !self.setup.members.is_simulated(id)
    }

    fn refuse_pose(&mut self, id: u32, pose: &Pose, why: Implausible) {
        let text = format!("pose of robot {id} at step {} refused: {why}", pose.step);
        self.outputs.push_back(Output::Bad(BadKind::Refused, text));
    }

    /// Where a robot is put at its deployment, and how far from there its
    /// start pose may lie: a simulated robot is put exactly at the
    /// `Deploy`'s position; a real one was checked within the placement
    /// radius of the start before it was enabled.
    pub(super) fn start_at(&self) -> plausible::StartAt {
        let start = self.setup.start;
        let tolerance = self.setup.agents.placement.map_or(START_TOLERANCE, |p| p.radius);
        plausible::StartAt { x: start.x, y: start.y, tolerance }
    }

    /// Sends robot `id` its goal bearing from `pose` (the runner's function).
    pub(super) fn send_bearing(&mut self, id: u32, pose: &Pose, step: u64) {
        let bearing = Vec2::new(pose.x, pose.y).bearing_to(self.setup.goal);
        let msg = GoalBearing { robot: RobotId(id), bearing, step };
        self.last_bearing = Some(msg);
        self.outputs.push_back(Output::Send(id, ToAgent::GoalBearing(msg)));
    }

    /// Robot `id`'s agent is gone: the dead-robot policy.
    pub(super) fn on_death(&mut self, now: u64, id: u32, gone: Gone) {
        self.watch_stop(id);
        if let Some(tick) = self.tick.as_mut() {
            tick.awaiting.remove(&id);
            if tick.pose_of == Some(id) {
                tick.pose_of = None;
            }
        }
        let abort = self.setup.on_death == OnDeath::Abort;
        let noticed_unix_ms = self.unix_ms(now);
        let Some(slot) = self.slot(id) else { return };
        if !slot.alive && slot.death.is_some() {
            return;
        }
        // Ended by a kill only when it is a process started here.
        let mut reason = gone.said(slot.pid.is_some());
        if let Some(words) = slot.last_error.take() {
            reason.push_str(&format!("; it said: {words}"));
        }
        if let Some(v) = slot.foreign_version.filter(|_| slot.state == SlotState::Spawned) {
            reason.push_str(&format!(
                " (a registration with protocol version {v} was seen for it; this orchestrator speaks {PROTOCOL_VERSION})"
            ));
        }
        slot.alive = false;
        slot.death = Some(Death { reason: reason.clone(), noticed_unix_ms });
        slot.gone = Some(gone);
        let state = slot.state;
        let seen = slot.last_pose.is_some();
        self.note(format!("robot {id}: agent lost — {reason}"));
        self.event(id, EventKind::AgentLost, None, Some(reason.clone()));
        if self.gone_while_stopping(id) {
            return;
        }
        let fatal = match state {
            SlotState::Spawned => self.never_registered(id, gone, reason),
            SlotState::Registered | SlotState::Deploying => {
                self.set_state(id, SlotState::Lost);
                let when = DiedWhen::BeforeDeployment;
                abort.then_some(Fault::Died { robot: id, when, why: gone, reason })
            }
            SlotState::Moving => {
                self.queue.push_back(Pending::Died(id));
                abort.then_some(Fault::Died { robot: id, when: DiedWhen::Moving, why: gone, reason })
            }
            _ => {
                (abort && seen).then_some(Fault::Died { robot: id, when: DiedWhen::After, why: gone, reason })
            }
        };
        if let Some(f) = fatal {
            self.fatal.get_or_insert(f);
        }
    }

    /// Robot `id`'s agent is gone without ever registering: with
    /// `Missing::Fail` the launch ends (the error, naming it); otherwise a
    /// process started here that ended is started once more, and a robot
    /// that still has no agent is absent: skipped at its turn.
    pub(super) fn never_registered(&mut self, id: u32, gone: Gone, reason: String) -> Option<Fault> {
        if self.setup.missing == Missing::Fail {
            return Some(Fault::NeverRegistered { robot: id, why: gone, reason });
        }
        let slot = self.slot(id)?;
        // A process that ended may have met a passing trouble; one that hung
        // for a whole registration timeout is not started again.
        if slot.pid.is_some() && slot.restarts == 0 && matches!(gone, Gone::Exited(_)) {
            slot.restarts += 1;
            slot.death = None;
            slot.gone = None;
            self.set_state(id, SlotState::Waiting);
            self.note(format!("robot {id}: its agent is gone before it registered; starting it once more"));
            return None;
        }
        self.set_state(id, SlotState::Absent);
        self.note(format!("robot {id}: absent — its agent never registered: {reason}"));
        self.event(id, EventKind::Absent, None, Some(reason));
        None
    }

    /// Whether a first `Register` for robot `id` is taken: an absent
    /// robot's agent that exists on its own (a remote agent, not a process
    /// started here) may join late; otherwise the robot's agent must be
    /// started and not gone.
    pub(super) fn may_register(&self, id: u32) -> bool {
        self.slot_ref(id).is_some_and(|s| match s.state {
            SlotState::Absent => s.pid.is_none() && self.setup.agents.all_at_once,
            _ => true,
        })
    }

    pub(super) fn on_reach(&mut self, now: u64, id: u32, change: Reach) {
        let grace = self.setup.supervision.unreachable_grace_us as f64 / 1e6;
        let at = self.unix_ms(now);
        let Some(slot) = self.slot(id) else { return };
        let (kind, text) = match change {
            Reach::Lost => {
                slot.outages.push(Outage { lost_unix_ms: at, back_unix_ms: None });
                tracing::warn!(robot = id, grace_s = grace, "robot {id}'s agent is unreachable");
                (
                    EventKind::Unreachable,
                    format!("robot {id}: link lost — waiting up to {grace} s for it to return"),
                )
            }
            Reach::Back => {
                let Some(outage) = slot.outages.last_mut().filter(|o| o.back_unix_ms.is_none()) else {
                    return;
                };
                outage.back_unix_ms = Some(at);
                let after = at.saturating_sub(outage.lost_unix_ms);
                tracing::info!(robot = id, after_ms = after, "robot {id}'s agent is back");
                (EventKind::Reachable, format!("robot {id}: link back after {after} ms"))
            }
        };
        self.note(text);
        self.event(id, kind, None, None);
        if change == Reach::Back {
            self.resend(&[id]);
        }
    }

    /// Whether robot `id`'s agent is alive but unreachable now.
    pub(super) fn unreachable(&self, id: u32) -> bool {
        self.slot_ref(id)
            .filter(|s| s.alive)
            .and_then(|s| s.outages.last())
            .is_some_and(|o| o.back_unix_ms.is_none())
    }

    /// Sends robots `ids` again what they may have missed: the pending
    /// `Deploy`; for a robot whose answer to the tick in flight is awaited,
    /// that tick's bearing (to the moving robot), the relays and the `Tick`.
    /// Agents answer a repeated `Tick` without stepping and a repeated
    /// `Deploy` with their pose, and the gate ignores poses it has seen.
    pub(super) fn resend(&mut self, ids: &[u32]) {
        let mut relayed = false;
        for &id in ids {
            if let Some(deploy) = self.pending_deploy.filter(|d| d.robot.0 == id) {
                self.outputs.push_back(Output::Send(id, ToAgent::Deploy(deploy)));
                self.resends += 1;
            }
            let owes = |t: &&TickWait| t.awaiting.contains(&id) || t.pose_of == Some(id);
            let Some(t) = self.tick.as_ref().filter(owes).map(|t| t.step) else {
                continue;
            };
            if let Some(bearing) = self.last_bearing.filter(|b| b.robot.0 == id && b.step == t) {
                self.outputs.push_back(Output::Send(id, ToAgent::GoalBearing(bearing)));
            }
            if !relayed {
                self.relay_dead(t, t * self.setup.params.period_us);
                relayed = true;
            }
            self.resend_beacons(id, t);
            self.outputs.push_back(Output::Send(id, self.tick_command(id, t)));
            self.resends += 1;
        }
    }

    /// Republishes the last pose of every dead beacon.
    pub(super) fn relay_dead(&mut self, step: u64, time_us: u64) {
        let dead: Vec<Pose> = self
            .slots
            .iter()
            .filter(|s| !s.alive && matches!(s.state, SlotState::Stuck | SlotState::Died))
            .filter_map(|s| s.last_pose)
            .collect();
        for mut pose in dead {
            pose.step = step;
            pose.time_us = time_us;
            self.beacon_at(pose.robot.0, &pose);
            self.outputs.push_back(Output::Relay(pose));
        }
    }
}
