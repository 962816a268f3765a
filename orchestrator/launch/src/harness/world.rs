//! The virtual-time world a harness launch plays in: the core, the
//! simulated agents and network, and the schedule's events in time order.
//! Nothing here decides what the launch does: the core does; the world only
//! carries out its outputs and delivers what the agents and the network do.

use super::*;
use crate::core::view::{BeaconAt, StateChange};

#[derive(Clone, Debug, PartialEq)]
pub(super) enum Event {
    Crash(u32),
    Tell(Input),
    Forge(Foreign),
    SecondAgent(u32),
    Interrupt,
    /// `orchestrator stop` (`--now` or not).
    Stop(bool),
    /// A partition cuts robot `.0`'s link now (the network drops its
    /// packets; noted for the detection property).
    Cut(u32),
    /// Robot `.0`'s gateway sees the orchestrator's liveliness token
    /// come (`true`) or go.
    Orchestrator(u32, bool),
    /// Robot `.0`'s robot link is cut until `.1` µs.
    RobotCut(u32, u64),
    /// The operator puts robot `.0` down here.
    Place(u32, Vec2),
}

/// How long a cut link's liveliness token outlives it (zenoh's lease,
/// `Liveness::FAST`).
const LEASE_US: u64 = 400_000;

/// A launch in virtual time.
pub(super) struct World<'a> {
    pub(super) case: &'a Case,
    /// The launch as the `orchestrator` would make it (setup, agents).
    pub(super) launch: Launch,
    pub(super) schedule: &'a Schedule,
    pub(super) core: Logged,
    pub(super) net: Net,
    pub(super) agents: Vec<Option<Agent>>,
    /// Gateway schedules: the real robots.
    pub(super) reals: Vec<Option<RealRobot>>,
    pub(super) next_mocap: u64,
    pub(super) mocap_frames: u64,
    pub(super) impostors: Vec<Agent>,
    pub(super) events: BinaryHeap<Reverse<(u64, u64, usize)>>,
    pub(super) event_list: Vec<Option<Event>>,
    pub(super) seq: u64,
    pub(super) now: u64,
    pub(super) report: Report,
    pub(super) early_deaths_left: Vec<u32>,
    /// Robots a forger races at their next `Deploy` ([`Foreign::RacesTheDeploy`]).
    pub(super) racers: Vec<u32>,
    /// The run as the views show it, folded from the core's outputs
    /// (checked against the core after every output: `check_view`).
    pub(super) view: RunView,
}

/// Plays one launch of `case` under `schedule` to its end.
pub fn run(case: &Case, schedule: &Schedule) -> Report {
    play(case, schedule, false).0
}

/// [`run`], with the core's setup and every call made on it, as a launch
/// records them (`launch::core::log`).
pub fn run_logged(case: &Case, schedule: &Schedule) -> (Report, Setup, Vec<Call>) {
    let (report, calls) = play(case, schedule, true);
    (report, setup(case, schedule), calls)
}

pub(super) fn play(case: &Case, schedule: &Schedule, logged: bool) -> (Report, Vec<Call>) {
    let launch = Launch::of(case, schedule);
    let n = case.robots as usize;
    let mut world = World {
        case,
        core: Logged::new(launch.setup(schedule), logged),
        launch,
        schedule,
        net: Net::new(schedule.net_faults.clone(), schedule.partitions.clone(), schedule.seed),
        agents: (0..n).map(|_| None).collect(),
        reals: (0..n).map(|_| None).collect(),
        next_mocap: 0,
        mocap_frames: 0,
        impostors: Vec::new(),
        events: BinaryHeap::new(),
        event_list: Vec::new(),
        seq: 0,
        now: 0,
        report: Report {
            ending: None,
            failure: None,
            gates: Vec::new(),
            robots: Vec::new(),
            deaths: Vec::new(),
            spent: 0,
            ticks: 0,
            resends: 0,
            end_us: 0,
            bad: 0,
            lost: 0,
            stepped: vec![0; n],
            last_tick: vec![None; n],
            idle_ticks: vec![0; n],
            deploys_sent: vec![0; n],
            stops_sent: vec![0; n],
            runs_sent: vec![(0, 0); n],
            beacons_sent: 0,
            forwarded: 0,
            late: Vec::new(),
            gate_times_us: Vec::new(),
            registered_us: vec![None; n],
            started_us: vec![None; n],
            decided: None,
            stop_log: Vec::new(),
            stopped: None,
            revoked: Vec::new(),
            after_revoke: Vec::new(),
            running_at_end: Vec::new(),
            faults: Vec::new(),
            noticed: Vec::new(),
            notes: Vec::new(),
            violations: Vec::new(),
            asked_us: vec![None; n],
            drove: Vec::new(),
            tripped: Vec::new(),
            moved: Vec::new(),
            forged: Vec::new(),
            agents_at_end: Vec::new(),
            wound: None,
            view_differs: None,
        },
        early_deaths_left: schedule.early_deaths.clone(),
        racers: Vec::new(),
        view: RunView::new(),
    };
    world.plan();
    world.play();
    let calls = world.core.take_calls();
    (world.finish(), calls)
}

impl World<'_> {
    pub(super) fn at(&mut self, at: u64, event: Event) {
        self.seq += 1;
        self.event_list.push(Some(event));
        self.events.push(Reverse((at, self.seq, self.event_list.len() - 1)));
    }

    /// Puts the schedule's own events on the timeline.
    pub(super) fn plan(&mut self) {
        let s = self.schedule;
        for c in &s.crashes {
            self.at(c.at_us, Event::Crash(c.robot));
        }
        for &(robot, at) in &s.second_agents {
            self.at(at, Event::SecondAgent(robot));
        }
        for (at, f) in &s.foreign {
            self.at(*at, Event::Forge(*f));
        }
        if let Some(at) = s.interrupt_at_us {
            self.at(at, Event::Interrupt);
        }
        if let Some((at, now)) = s.stop_at_us {
            self.at(at, Event::Stop(now));
        }
        if let Some((at, robot)) = s.revoke_at_us {
            let revoke = Revoke { robot, who: STOP_WHO.into(), why: REVOKE_WHY.into() };
            self.at(at, Event::Tell(Input::Revoke(revoke)));
        }
        if s.remote {
            // A cut link's liveliness token goes after one lease and comes
            // back with the link: facts; the core's timers judge them.
            for p in &s.partitions {
                let lost = p.from_us + LEASE_US;
                if lost >= p.until_us {
                    continue;
                }
                self.at(p.from_us, Event::Cut(p.robot));
                self.at(lost, Event::Tell(Input::Token(p.robot, false)));
                self.at(p.until_us, Event::Tell(Input::Token(p.robot, true)));
                if s.gateways {
                    // The gateway loses the orchestrator's token as well.
                    self.at(lost, Event::Orchestrator(p.robot, false));
                    self.at(p.until_us, Event::Orchestrator(p.robot, true));
                }
            }
        }
        for c in &s.robot_cuts {
            self.at(c.from_us, Event::RobotCut(c.robot, c.until_us));
        }
    }

    pub(super) fn play(&mut self) {
        let mut idle_rounds = 0u32;
        loop {
            let now = self.now;
            self.core.advance(now);
            self.carry_out();
            if self.core.ending().is_some() {
                return;
            }
            let next = [
                self.core.deadline(),
                self.net.next_at(),
                self.events.peek().map(|Reverse((at, _, _))| *at),
                self.agents.iter().flatten().filter_map(Agent::deadline).min(),
                self.reals_deadline(),
            ]
            .into_iter()
            .flatten()
            .min();
            let Some(next) = next else {
                self.report.failure = Some(format!("stalled at {} µs: nothing to wait for, no ending", now));
                return;
            };
            if next <= now {
                idle_rounds += 1;
                if idle_rounds > 1000 {
                    self.report.failure = Some(format!("spins at {now} µs without progress"));
                    return;
                }
            } else {
                idle_rounds = 0;
            }
            self.now = next.max(now);
            if self.now > HANG_US {
                self.report.failure =
                    Some(format!("did not end within {} s of virtual time", HANG_US / 1_000_000));
                return;
            }
            self.deliver();
        }
    }

    pub(super) fn carry_out(&mut self) {
        while let Some(out) = self.core.poll() {
            let now = self.now;
            if let Some(id) = about(&out).filter(|&id| self.core.revoked().iter().any(|r| r.robot == id)) {
                self.report.after_revoke.push((id, out.clone()));
            }
            if let Some(shown) = out.shown() {
                self.view.take(&shown);
                self.check_view();
            }
            match out {
                Output::Start(id) => self.start(id),
                Output::Send(id, msg) => {
                    if msg == ToAgent::Stop {
                        self.report.stop_log.push((now, id));
                    }
                    let deploy = matches!(msg, ToAgent::Deploy(_));
                    if deploy && self.schedule.gateways {
                        self.check_placed(id);
                    }
                    self.report.beacons_sent += u64::from(matches!(msg, ToAgent::Beacon(_)));
                    let counter = match msg {
                        ToAgent::Deploy(_) => Some(&mut self.report.deploys_sent),
                        ToAgent::Stop => Some(&mut self.report.stops_sent),
                        _ => None,
                    };
                    if let Some(n) = counter.and_then(|c| c.get_mut(id as usize - 1)) {
                        *n += 1;
                    }
                    if let (ToAgent::Ticks(t), Some(r)) =
                        (&msg, self.report.runs_sent.get_mut(id as usize - 1))
                    {
                        *r = (r.0 + 1, r.1 + u64::from(t.count));
                    }
                    self.net.send(now, id, Packet::ToAgent(id, msg));
                    if let Some(i) = self.racers.iter().position(|&r| r == id).filter(|_| deploy) {
                        // The forger saw the `Deploy` and answers first.
                        self.racers.swap_remove(i);
                        let pose = forged::at_the_goal(id, self.case.terrain.goal(), self.core.ticks());
                        self.forge(id, pose);
                    }
                }
                Output::Relay(pose) => {
                    self.net.send(now, 0, Packet::Pose { topic: pose.robot.0, pose, relay: true });
                }
                Output::Gate(e) => {
                    self.report.gates.push(e);
                    self.report.gate_times_us.push(now);
                }
                Output::Kill(id) => self.kill(id),
                Output::Event(e) if matches!(e.event, EventKind::AgentLost | EventKind::Unreachable) => {
                    self.report.noticed.push((e.robot, now));
                }
                Output::Bad(..) => self.report.bad += 1,
                Output::Forward(pose) => {
                    self.report.forwarded += 1;
                    self.net.send(now, pose.robot.0, Packet::Forwarded(pose));
                }
                Output::AskOperator(deploy) => self.ask_operator(deploy.robot.0),
                Output::Note(text) => self.report.notes.push(text),
                Output::Moved { robot, pose } => self.report.moved.push((now, robot, pose)),
                Output::Event(_)
                | Output::Heard(_)
                | Output::SimTime(_)
                | Output::Carried(..)
                | Output::Beacon(_)
                | Output::State(_) => {}
            }
        }
    }

    /// The views' fold agrees with the core once the outputs so far are
    /// folded: every beacon where the core's table has it (bit for bit),
    /// every robot in the core's state. The first disagreement is reported.
    fn check_view(&mut self) {
        if self.report.view_differs.is_some() || self.core.peek_output().is_some() {
            return;
        }
        let shown: Vec<(u32, Vec2)> = {
            let mut b: Vec<_> = self.view.beacons().collect();
            b.sort_by_key(|(id, _)| *id);
            b
        };
        let bits =
            |b: &[(u32, Vec2)]| b.iter().map(|(id, at)| (*id, at.x.to_bits(), at.y.to_bits())).collect();
        let (table, folded): (Vec<_>, Vec<_>) = (bits(&self.core.beacons()), bits(&shown));
        if table != folded {
            let why = format!(
                "at {} µs the views' beacons {shown:?}, the core's {:?}",
                self.now,
                self.core.beacons()
            );
            self.report.view_differs = Some(why);
            return;
        }
        for s in self.core.slots() {
            let state = self.view.robot_view(s.id()).and_then(|r| r.state).unwrap_or(SlotState::Waiting);
            if state != s.state() {
                let why = format!(
                    "at {} µs robot {} is {state:?} in the views, {:?} in the core",
                    self.now,
                    s.id(),
                    s.state()
                );
                self.report.view_differs = Some(why);
                return;
            }
        }
    }

    pub(super) fn start(&mut self, id: u32) {
        let i = id as usize - 1;
        if let Some(at) = self.report.started_us.get_mut(i) {
            at.get_or_insert(self.now);
        }
        if self.schedule.remote && self.alive(id) {
            // A remote agent exists on its own: expected again, not made.
            let now = self.now;
            self.core.handle(now, Input::Started { robot: id, pid: None, how: "awaiting its agent".into() });
            return;
        }
        if self.schedule.gateways {
            self.start_real(id);
        } else {
            let delay = self.schedule.register_delay_us.get(i).copied().unwrap_or(Some(50_000));
            let agent = self.launch.agent(id, 0x1000 + u64::from(id), delay.map(|d| self.now + d));
            self.agents[i] = Some(agent);
        }
        if let Some(left) = self.early_deaths_left.get_mut(i).filter(|n| **n > 0) {
            *left -= 1;
            let at = self.now + 5_000;
            self.at(at, Event::Crash(id));
        }
        let now = self.now;
        let (pid, how) = if self.schedule.remote {
            (None, "awaiting its agent")
        } else {
            (Some(10_000 + id), "agent started")
        };
        self.core.handle(now, Input::Started { robot: id, pid, how: how.into() });
    }

    /// The core ended robot `id`'s agent: a process is killed; a remote
    /// agent is only dropped from the launch, and one that never registered
    /// still exists on its host (it may come late).
    pub(super) fn kill(&mut self, id: u32) {
        let i = id as usize - 1;
        let absent = self.core.slots().get(i).is_some_and(|s| s.state() == SlotState::Absent);
        if self.schedule.remote && absent {
            return;
        }
        if let Some(Some(a)) = self.agents.get_mut(i) {
            a.alive = false;
        }
        // A remote gateway is only forgotten: it goes on, cut off or not.
        let now = self.now;
        if let Some(Some(r)) = self.reals.get_mut(i).filter(|_| !self.schedule.remote) {
            r.end(now);
        }
    }

    /// Everything due now, in time then sending order.
    pub(super) fn deliver(&mut self) {
        let now = self.now;
        while let Some(Reverse((at, _, index))) = self.events.peek().copied() {
            if at > now {
                break;
            }
            self.events.pop();
            if let Some(event) = self.event_list[index].take() {
                self.happen(event);
            }
        }
        while let Some(packet) = self.net.pop_due(now) {
            self.arrive(packet);
        }
        let mut sent = Vec::new();
        for a in self.agents.iter_mut().flatten().filter(|a| a.deadline().is_some_and(|t| t <= now)) {
            let before = a.stepped();
            a.advance(now, &mut sent);
            self.report.stepped[a.id() as usize - 1] += a.stepped() - before;
            for s in sent.drain(..) {
                Self::send_from(&mut self.net, now, a.id(), s);
            }
        }
        self.advance_reals();
    }

    pub(super) fn send_from(net: &mut Net, now: u64, id: u32, said: Said) {
        match said {
            Said::Report(r) => net.send(now, id, Packet::Report(r)),
            Said::Pose(p) => net.send(now, id, Packet::Pose { topic: id, pose: p, relay: false }),
            // The process counts and logs what it refused; nothing is sent.
            Said::Refused(_) => {}
        }
    }

    pub(super) fn happen(&mut self, event: Event) {
        let now = self.now;
        match event {
            Event::Crash(id) => {
                if self.alive(id) && self.core.is_running(id) {
                    if let Some(Some(a)) = self.agents.get_mut(id as usize - 1) {
                        a.alive = false;
                    }
                    if let Some(Some(r)) = self.reals.get_mut(id as usize - 1) {
                        r.end(now);
                    }
                    self.fault(id);
                    // A process's end is seen within a few milliseconds,
                    // with its last error line (what a shell's tap reads);
                    // a remote agent's token goes with its session.
                    if self.schedule.remote {
                        self.at(now + 5_000, Event::Tell(Input::Token(id, false)));
                    } else {
                        let words = format!("robot {id}'s agent crashed (harness)");
                        self.at(now + 5_000, Event::Tell(Input::Said(id, words)));
                        let status = std::process::ExitStatus::from_raw(9);
                        self.at(now + 5_000, Event::Tell(Input::Gone(id, Gone::Exited(status))));
                    }
                }
            }
            Event::Tell(input) => self.core.handle(now, input),
            Event::Cut(id) => {
                if self.alive(id) && self.core.is_running(id) {
                    self.fault(id);
                }
            }
            Event::Orchestrator(id, alive) => {
                self.tell_real(id, |r, now, out| r.orchestrator(now, alive, out));
            }
            Event::RobotCut(id, until_us) => self.robot_cut(id, until_us),
            Event::Place(id, at) => self.place(id, at),
            Event::Forge(Foreign::RacesTheDeploy(id)) => self.racers.push(id),
            Event::Forge(f) => {
                if let Some(next) = f.next(self) {
                    self.at(now + 100_000, Event::Forge(next));
                }
                match f.input(self) {
                    Some(Input::Pose { topic, pose }) => self.forge(topic, pose),
                    Some(input) => self.core.handle(now, input),
                    // A series goes on without the pose that made no sense.
                    None if matches!(f, Foreign::GoalSeries { .. }) => {}
                    // Not possible yet (the robot has no pose): a little
                    // later, while the launch runs.
                    None if self.core.ending().is_none() => self.at(now + 10_000, Event::Forge(f)),
                    None => {}
                }
            }
            Event::SecondAgent(id) if !self.registered(id) => {
                // A second agent for a registered robot: later, once it is.
                if self.core.ending().is_none() {
                    self.at(now + 10_000, Event::SecondAgent(id));
                }
            }
            Event::SecondAgent(id) => {
                let mut a = self.launch.agent(id, 0xbad0 + u64::from(id), Some(now));
                let mut sent = Vec::new();
                a.advance(now, &mut sent);
                for s in sent {
                    Self::send_from(&mut self.net, now, id, s);
                }
                self.impostors.push(a);
            }
            Event::Interrupt => self.core.handle(now, Input::Interrupt),
            Event::Stop(at_once) => {
                let stop = Stop { now: at_once, who: STOP_WHO.into(), why: STOP_WHY.into() };
                self.core.handle(now, Input::Stop(stop));
            }
        }
    }

    pub(super) fn arrive(&mut self, packet: Packet) {
        let now = self.now;
        match packet {
            Packet::Report(r) => {
                let i = r.robot().0 as usize;
                if matches!(r, FromAgent::Register(_)) && (1..=self.report.registered_us.len()).contains(&i) {
                    self.report.registered_us[i - 1].get_or_insert(now);
                }
                self.core.handle(now, Input::Report(r));
            }
            Packet::Pose { topic, pose, relay } => {
                // Agents sense the beacons the core sends them, not poses.
                if !relay {
                    self.core.handle(now, Input::Pose { topic, pose });
                }
            }
            Packet::Forwarded(pose) => self.tell_real(pose.robot.0, |r, _, _| r.pose(&pose)),
            Packet::ToAgent(id, cmd) => {
                self.tell_real(id, |r, now, out| r.command(now, &cmd, out));
                let mut sent = Vec::new();
                if let Some(Some(a)) = self.agents.get_mut(id as usize - 1) {
                    let before = a.stepped();
                    let idle = matches!(cmd, ToAgent::Tick(_)) && a.idle();
                    a.command(&cmd, &mut sent);
                    self.report.idle_ticks[id as usize - 1] += u64::from(idle);
                    self.report.stepped[id as usize - 1] += a.stepped() - before;
                    if let (ToAgent::Tick(t), true) = (&cmd, a.alive) {
                        self.report.last_tick[id as usize - 1] = Some(t.step);
                    }
                }
                for imp in self.impostors.iter_mut().filter(|a| a.id() == id) {
                    imp.command(&cmd, &mut Vec::new());
                }
                for s in sent {
                    Self::send_from(&mut self.net, now, id, s);
                }
            }
        }
    }

    pub(super) fn finish(mut self) -> Report {
        let core = &self.core;
        self.report.ending = core.ending().cloned();
        // The view's arrival (the trace's success) is the core's outcome.
        let arrived = core.ending().is_some_and(|e| e.outcome == Outcome::Arrived);
        if self.view.arrived().is_some() != arrived && self.report.view_differs.is_none() {
            let why =
                format!("the views' arrival {:?} for the outcome {:?}", self.view.arrived(), core.ending());
            self.report.view_differs = Some(why);
        }
        let recording = if self.schedule.recording_fails { Err("disk full (harness)") } else { Ok(()) };
        self.report.decided =
            core.ending().map(|e| super::super::summary::of(core, &self.view, e, recording));
        self.report.robots = core.slots().iter().map(|s| (s.state(), s.steps(), s.last_pose())).collect();
        self.report.deaths = core.slots().iter().map(|s| s.death().map(|d| d.reason.clone())).collect();
        self.report.late = core.slots().iter().filter(|s| s.joined_late()).map(|s| s.id()).collect();
        self.report.stopped = core.stopped().cloned();
        self.report.revoked = core.revoked().to_vec();
        self.report.running_at_end = core.slots().iter().filter(|s| s.alive()).map(|s| s.id()).collect();
        self.report.agents_at_end = (1..=self.case.robots).filter(|&id| self.alive(id)).collect();
        self.report.spent = core.spent();
        self.report.ticks = core.ticks();
        self.report.resends = core.resends();
        self.report.end_us = self.now;
        self.report.lost = self.net.lost;
        self.collect_violations();
        if self.report.ending.is_some() {
            self.wind_down();
        }
        self.report
    }

    /// Hands the core a forged pose on robot `topic`'s topic, noting
    /// whether the core took it (made it the robot's latest: plausible by
    /// every rule it has) or not (`Report::forged`).
    pub(super) fn forge(&mut self, topic: u32, pose: Pose) {
        let now = self.now;
        self.core.handle(now, Input::Pose { topic, pose });
        let latest = self.true_pose(pose.robot.0);
        let taken = latest.is_some_and(|p| p == pose && pose.robot.0 == topic);
        self.report.forged.push((pose, taken));
    }

    /// Robot `id`'s agent crashed or its link was cut now: the launch must
    /// notice within [`NOTICE_US`] ([`check`]), unless it already holds
    /// the robot as unreachable.
    pub(super) fn fault(&mut self, id: u32) {
        let held = self
            .core
            .slots()
            .get(id as usize - 1)
            .is_some_and(|s| s.outages().last().is_some_and(|o| o.back_unix_ms.is_none()));
        if !held {
            self.report.faults.push((id, self.now));
        }
    }

    /// Whether robot `id`'s agent (simulated, or real gateway) runs.
    pub(super) fn alive(&self, id: u32) -> bool {
        let agent = self.agents.get(id as usize - 1).and_then(Option::as_ref).is_some_and(|a| a.alive);
        agent || self.real_alive(id)
    }

    /// Whether robot `id` has a registered agent.
    pub(super) fn registered(&self, id: u32) -> bool {
        self.core
            .slots()
            .get(id as usize - 1)
            .is_some_and(|s| s.alive() && !matches!(s.state(), SlotState::Waiting | SlotState::Spawned))
    }

    /// Robot `id`'s true latest pose (its agent's), for forgeries.
    pub(super) fn true_pose(&self, id: u32) -> Option<Pose> {
        self.core.slots().get(id as usize - 1).and_then(|s| s.last_pose())
    }
}

/// The robot an output is about, if it is about one.
fn about(out: &Output) -> Option<u32> {
    match out {
        Output::Start(id)
        | Output::Send(id, _)
        | Output::Kill(id)
        | Output::Heard(id)
        | Output::Carried(id, _) => Some(*id),
        Output::Relay(pose) | Output::Forward(pose) => Some(pose.robot.0),
        Output::Moved { robot, .. }
        | Output::Beacon(BeaconAt { robot, .. })
        | Output::State(StateChange { robot, .. }) => Some(*robot),
        Output::Gate(e) => Some(e.robot.0),
        Output::Event(e) => Some(e.robot),
        Output::AskOperator(d) => Some(d.robot.0),
        Output::Note(_) | Output::Bad(..) | Output::SimTime(_) => None,
    }
}
