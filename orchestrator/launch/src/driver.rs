//! The IO shell around the launch core: the real bus, agents, poses and
//! wall clock.
//!
//! Why a shell that decides nothing: every rule of a launch lives in
//! [`LaunchCore`](crate::LaunchCore), which is tested in virtual time without processes. This
//! driver only carries inputs in (reports from the bus, poses from the pose
//! source, the agent source's facts — an agent ended, a liveliness token
//! went or came back —, Ctrl-C, the time since the launch began) and the core's outputs out (messages, agent
//! starts and kills, gate events, the recording, the terminal), waiting for
//! IO until the core's next deadline. At the end it sends `Shutdown`, winds
//! the agents down and builds the summary from the core's slots.

use super::agents::{AgentPlan, AgentSource, Gone, Joining, Started};
use super::config::{Clock, LaunchConfig};
use super::control::{shown, Answer, Ask, Control, Reply, Request};
use super::core::log::{self, Logged};
use super::core::view::RunView;
use super::core::{Ending, Input, Output, Revoke, Slot, SlotState, Stop, WindDown, WindStep};
use super::events::EVENT_SCHEMA;
use super::ports::Ports;
use super::poses::{PoseSink, PoseSource};
use super::progress::{Progress, Waits};
use super::recording::Seen;
use super::status::{self, Facts, LaunchStatus};
use super::summary::{RealtimeReport, RecordingSummary, Summary};
use super::World;
use bycoms_protocol::bus::zenoh::settings::SettingsServer;
use bycoms_protocol::msg::{FromAgent, Pose, ToAgent};
use bycoms_record::schema;
use bycoms_sim_agent::RunSettings;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Longest single wait for IO before the driver looks at the interrupt
/// flag and the terminal again.
pub const SLICE: Duration = Duration::from_millis(10);

/// One launch's shell: the core and the real things it drives.
pub struct Driver {
    core: Logged,
    cfg: LaunchConfig,
    world: World,
    ports: Ports,
    agents: Box<dyn AgentSource>,
    pose_source: Box<dyn PoseSource>,
    joining: Joining,
    run: RunSettings,
    progress: Progress,
    stop: Arc<AtomicBool>,
    /// Launch time 0 (when the core was made).
    epoch: Instant,
    /// When `launch::run` was called (before the bus was opened).
    begun: Instant,
    endpoints: Vec<String>,
    /// zenoh: the run's settings, served to the end; its refusals (askers
    /// for robots outside the launch) count as `unknown_robot`.
    settings: Option<SettingsServer>,
    poses: Vec<(u32, Pose)>,
    /// What the launch waits for, said when a wait lasts.
    waits: Waits,
    /// `orchestrator status` and `stop` (and the ROS 2 stop service) reach
    /// the launch here (`control.rs`).
    control: Option<Control>,
    /// The replies to stops asked, given once the launch has ended (a stop
    /// `now` ends after the robots' answers).
    stop_replies: Vec<Reply>,
    /// When the agent source was last polled (at most every
    /// [`POLL_EVERY`]: a poll is a `wait4` per spawned agent).
    polled_at: Option<Instant>,
    /// The run as the views show it, folded from the core's outputs: the
    /// summary's robots used and beacons (`summary::of`).
    view: RunView,
}

/// Least time between two polls of the agent source: an agent's end is
/// seen within milliseconds, and a crowd of agents costs little per pass.
const POLL_EVERY: Duration = Duration::from_millis(5);

/// What a driver is built from.
pub struct Parts {
    /// The launch's settings.
    pub cfg: LaunchConfig,
    /// Start, goal and the terrain handed to simulated agents.
    pub world: World,
    /// The bus, with recording and bad-traffic counting.
    pub ports: Ports,
    /// Where agents come from.
    pub agents: Box<dyn AgentSource>,
    /// Where the gate's poses come from.
    pub pose_source: Box<dyn PoseSource>,
    /// How every agent joins the launch.
    pub joining: Joining,
    /// The run's settings every agent is given.
    pub run: RunSettings,
    /// The Ctrl-C flag.
    pub stop: Arc<AtomicBool>,
    /// When the launch command began.
    pub begun: Instant,
    /// zenoh: where the orchestrator listens.
    pub endpoints: Vec<String>,
    /// zenoh: the settings server (held to the end, its refusals counted).
    pub settings: Option<SettingsServer>,
    /// Where status and stop questions come in.
    pub control: Option<Control>,
}

impl Driver {
    /// A driver around a new core for `parts`.
    pub fn new(parts: Parts) -> Self {
        let Parts {
            cfg,
            world,
            ports,
            agents,
            pose_source,
            joining,
            run,
            stop,
            begun,
            endpoints,
            settings,
            control,
        } = parts;
        let setup = super::setup::setup(&cfg, &world, &run, agents.as_ref(), pose_source.as_ref());
        let mut ports = ports;
        // The core's setup and calls go into the recording: `replay` feeds
        // them to the same core (`launch::core::log`).
        let recorded = ports.recording.is_on();
        if recorded {
            let topic = format!("bycoms/{}/core/setup", joining.swarm);
            ports.recording.bytes(&topic, schema::CORE_SETUP, &log::encode_setup(&setup));
        }
        Self {
            core: Logged::new(setup, recorded),
            progress: Progress::new(cfg.robots),
            cfg,
            world,
            ports,
            agents,
            pose_source,
            joining,
            run,
            stop,
            epoch: Instant::now(),
            begun,
            endpoints,
            settings,
            poses: Vec::new(),
            waits: Waits::new(Instant::now()),
            control,
            stop_replies: Vec::new(),
            polled_at: None,
            view: RunView::new(),
        }
    }

    /// The bad traffic seen: the ports' counts, and the settings queries of
    /// agents of robots outside the launch (their reports go to topics
    /// the ports do not read).
    fn traffic(&self) -> bycoms_runtime::Traffic {
        let mut traffic = self.ports.traffic;
        traffic.unknown_robot += self.settings.as_ref().map_or(0, SettingsServer::refused);
        traffic
    }

    fn now(&self) -> u64 {
        self.epoch.elapsed().as_micros() as u64
    }

    /// Runs the launch until the core says it has ended, then ends it in
    /// order and returns the summary.
    pub fn run(mut self) -> Summary {
        let ending = loop {
            let now = self.now();
            if self.stop.load(Ordering::SeqCst) {
                self.core.handle(now, Input::Interrupt);
            }
            self.core.advance(now);
            let acted = self.carry_out();
            self.record_calls();
            self.ports.show_scene();
            if let Some(ending) = self.core.ending() {
                let ending = ending.clone();
                self.answer_stops();
                break ending;
            }
            let wait = if acted {
                Duration::ZERO
            } else {
                let due =
                    self.core.deadline().map_or(SLICE, |d| Duration::from_micros(d.saturating_sub(now)));
                due.min(SLICE)
            };
            if let Err(e) = self.pump(wait) {
                let now = self.now();
                self.core.handle(now, Input::Failed(bycoms_runtime::exit::message(&e)));
            }
        };
        self.finish(ending)
    }

    /// Records the core's calls since the last time (one message a pass).
    fn record_calls(&mut self) {
        let calls = self.core.take_calls();
        if !calls.is_empty() {
            let topic = format!("bycoms/{}/core/calls", self.joining.swarm);
            self.ports.recording.bytes(&topic, schema::CORE_CALLS, &log::encode_calls(&calls));
        }
    }

    /// Hands one input to the core and carries out what it asks at once.
    fn feed(&mut self, input: Input) {
        let now = self.now();
        // The recording's projections see the reports the core is handed
        // (lockstep's acknowledgements, most of them, show nothing).
        if let Input::Report(report) = &input {
            if !matches!(report, FromAgent::TickDone(_)) {
                self.ports.recording.seen(Seen::Report(*report));
            }
        }
        self.core.handle(now, input);
        self.carry_out();
    }

    /// Carries out every output of the core; whether there was any.
    fn carry_out(&mut self) -> bool {
        let mut acted = false;
        while let Some(out) = self.core.poll() {
            acted = true;
            if let Err(e) = self.carry(out) {
                let now = self.now();
                self.core.handle(now, Input::Failed(bycoms_runtime::exit::message(&e)));
            }
        }
        acted
    }

    fn carry(&mut self, out: Output) -> anyhow::Result<()> {
        if let Some(shown) = out.shown() {
            self.view.take(&shown);
        }
        match out {
            Output::Start(id) => {
                let started = self.start(id);
                let now = self.now();
                match started {
                    Ok(s) => {
                        let pid = match s {
                            Started::Process { pid } => Some(pid),
                            Started::Awaited | Started::Thread => None,
                        };
                        self.core.handle(now, Input::Started { robot: id, pid, how: s.to_string() });
                    }
                    Err(e) => self.core.handle(now, Input::Failed(bycoms_runtime::exit::message(&e))),
                }
            }
            Output::Send(id, msg) => {
                // A tick's beacons, bearing and `Tick` to one agent ring once.
                let more = matches!(self.core.peek_output(), Some(Output::Send(next, _)) if *next == id);
                self.ports.send(id, &msg, more)?;
            }
            // A dead robot's last pose again, for the agents' field: the
            // views showed it when the core applied it.
            Output::Relay(pose) => self.ports.relay(&pose)?,
            Output::Moved { robot, pose } => self.ports.show_moved(robot, &pose),
            Output::Beacon(beacon) => self.ports.show_beacon(beacon),
            Output::State(change) => self.ports.show_state(change),
            Output::Forward(pose) => self.ports.forward_pose(&pose)?,
            Output::Gate(event) => {
                self.ports.publish_gate(&event)?;
                self.ports.recording.seen(Seen::Gate(event));
            }
            Output::Event(event) => {
                let topic = format!("bycoms/{}/events", self.joining.swarm);
                self.ports.recording.json(&topic, EVENT_SCHEMA, &event);
            }
            Output::Note(text) => self.progress.event(&text),
            Output::Bad(kind, text) => self.ports.count(kind, &text),
            Output::Kill(id) => {
                self.agents.kill(id);
            }
            Output::Heard(id) => self.agents.heard(id),
            Output::SimTime(ns) => self.ports.recording.set_simulated_time(ns),
            Output::AskOperator(request) => self.ports.ask_operator(&request)?,
            Output::Carried(id, by_hand) => self.pose_source.carried(id, by_hand),
        }
        Ok(())
    }

    /// Opens robot `id`'s ports and poses (so nothing it sends is missed)
    /// and starts its agent.
    fn start(&mut self, id: u32) -> anyhow::Result<Started> {
        self.ports.open_robot(id)?;
        self.pose_source.open_robot(id)?;
        let mut joining = self.joining.clone();
        joining.bus.zenoh_config = self.cfg.transport.agent_config_of(id);
        let plan = AgentPlan { joining: &joining, settings: &self.run };
        Ok(self.agents.start(id, &plan)?)
    }

    /// Takes in everything pending, waiting up to `timeout` for the first
    /// agent report: reports, poses, losses, reachability.
    fn pump(&mut self, timeout: Duration) -> anyhow::Result<()> {
        // What the last pass recorded goes to the writer before the wait.
        self.ports.recording.tick();
        let mut wait = timeout;
        while let Some(got) = self.ports.recv_report(wait)? {
            wait = Duration::ZERO;
            if let Some(msg) = got {
                self.feed(Input::Report(msg));
            }
        }
        let mut poses = std::mem::take(&mut self.poses);
        let record_decoded = !self.pose_source.on_the_bus();
        let bytes = std::mem::take(&mut self.ports.pose_bytes);
        let (recording, traffic, swarm) = self.ports.intake();
        let mut sink =
            PoseSink::new(recording, traffic, swarm, &mut poses, record_decoded).encoding_with(bytes);
        let drained = self.pose_source.drain(&mut sink);
        let numbers = sink.numbers().to_vec();
        // The encodings it made are what is forwarded and shown of them.
        let bytes = sink.take_bytes();
        self.ports.pose_bytes = bytes;
        drained?;
        for ((topic, pose), recorded) in poses.drain(..).zip(numbers) {
            let now = self.now();
            // Logged by its number in the recording: each pose stored once.
            // Shown only if the core applies it (`Output::Moved`).
            self.core.handle_pose(now, topic, pose, recorded);
            self.carry_out();
        }
        self.poses = poses;
        if self.polled_at.is_none_or(|t| t.elapsed() >= POLL_EVERY) {
            self.polled_at = Some(Instant::now());
            self.poll_agents();
        }
        self.answer_questions();
        if self.progress.due() {
            self.redraw();
        }
        self.say_waits();
        Ok(())
    }

    /// Takes in the agent source's facts: agents that ended (with their
    /// last words), tokens that went or came back.
    fn poll_agents(&mut self) {
        let gone = self.agents.poll();
        let unclean = gone.iter().any(|(_, g)| !matches!(g, Gone::Exited(status) if status.success()));
        for (robot, gone) in gone {
            if let Some(words) = self.agents.last_error(robot) {
                self.feed(Input::Said(robot, words));
            }
            self.feed(Input::Gone(robot, gone));
        }
        if unclean {
            // What an agent that did not end cleanly left on the bus
            // (iceoryx2: its node's ports) goes now, after its death is
            // noted (the scan takes a while), and in the time an agent
            // started again for its robot takes to open its ports; agents
            // do not clean up after each other (`IpcConfig::cleans_dead_nodes`).
            self.ports.cleanup_dead_nodes();
        }
        for (robot, present) in self.agents.tokens() {
            self.feed(Input::Token(robot, present));
        }
    }

    /// Answers the status and stop questions that came in; a stop is the
    /// core's input, so the launch ends by the core's one rule.
    fn answer_questions(&mut self) {
        let Some(requests) = self.control.as_ref().map(Control::take) else { return };
        for Request { ask, reply } in requests {
            let answer = match ask {
                Ask::Stop { now, who, why } => {
                    let (who, why) = (shown(&who), shown(&why));
                    tracing::warn!(now, who, why, "a stop was asked");
                    self.feed(Input::Stop(Stop { now, who, why }));
                    let at = self.now();
                    self.core.advance(at);
                    self.carry_out();
                    // Answered once the launch has ended (`answer_stops`).
                    self.stop_replies.push(reply);
                    continue;
                }
                Ask::Status => Answer::Status(Box::new(self.status())),
                Ask::Revoke { robot, who, why, lab } => {
                    self.revoke(Revoke { robot, who: shown(&who), why: shown(&why) }, lab)
                }
            };
            reply(&answer);
        }
    }

    /// Answers the stops asked, the launch having ended: with `now`, how
    /// many robots were told `Stop` and answered it, and the slowest answer.
    fn answer_stops(&mut self) {
        if self.stop_replies.is_empty() {
            return;
        }
        let stop = self.core.stopped();
        let answered = stop.map_or(&[][..], |s| &s.answered[..]);
        let answer = Answer::Stopping {
            swarm: self.joining.swarm.clone(),
            now: stop.is_some_and(|s| s.now),
            told: stop.map_or(0, |s| s.told.len() as u32),
            answered: answered.len() as u32,
            slowest_us: answered.iter().map(|a| a.after_us).max(),
            recording: self.cfg.record.as_ref().map(|p| p.display().to_string()),
            pid: std::process::id(),
        };
        for reply in self.stop_replies.drain(..) {
            reply(&answer);
        }
    }

    /// Takes a robot's voice away (`orchestrator revoke`): one core input,
    /// decided and carried out (its `Stop` sent) before the answer.
    fn revoke(&mut self, revoke: Revoke, lab: Option<std::path::PathBuf>) -> Answer {
        if lab.is_some_and(|lab| !super::control::same_lab(&lab, self.cfg.transport.zenoh_config.as_deref()))
        {
            return Answer::OtherLab;
        }
        let (robot, robots) = (revoke.robot, self.core.slots().len());
        if robot == 0 || robot as usize > robots {
            return Answer::Refused(format!("robot {robot} is not in this launch (robots 1..={robots})"));
        }
        tracing::warn!(robot, who = %revoke.who, why = %revoke.why, "a revocation was asked");
        let already = self.core.revoked().iter().any(|r| r.robot == robot);
        let told = !already && self.core.is_running(robot);
        self.feed(Input::Revoke(revoke));
        let at = self.now();
        self.core.advance(at);
        self.carry_out();
        Answer::Revoked { swarm: self.joining.swarm.clone(), robot, told, already, pid: std::process::id() }
    }

    /// Where the launch stands (`orchestrator status`).
    pub fn status(&self) -> LaunchStatus {
        let facts = Facts {
            swarm: self.joining.swarm.clone(),
            clock: self.cfg.clock.as_str().into(),
            transport: self.cfg.transport.kind.as_str().into(),
            recording: self.cfg.record.as_ref().map(|p| p.display().to_string()),
            pid: std::process::id(),
            uptime_s: self.begun.elapsed().as_secs_f64(),
        };
        status::of(&self.core, self.now(), &facts)
    }

    /// Says what the launch waits for, when a wait lasts.
    fn say_waits(&mut self) {
        let now = Instant::now();
        if !self.waits.due(now) {
            return;
        }
        let waiting = self.core.waiting();
        let what = waiting.as_ref().map(|w| w.what.as_str());
        if let Some(line) = self.waits.line(what, waiting.as_ref().map_or(0, |w| w.resent), now) {
            self.progress.event(&line);
        }
    }

    /// Redraws every robot's live line.
    fn redraw(&self) {
        for s in self.core.slots() {
            let at = s.last_pose().map(|p| format!("({:6.2}, {:6.2})", p.x, p.y)).unwrap_or_default();
            let mode =
                if s.state() == SlotState::Moving { format!(" mode {}", s.mode()) } else { String::new() };
            self.progress.robot(s.id(), format!("{}{mode} {at}", s.state().words()));
        }
    }

    /// Shuts every agent down, finishes the recording, builds the summary.
    ///
    /// Why always the same path: a won run, a time limit, Ctrl-C and an
    /// error all leave agents and an open recording behind. Each ends the
    /// same way: `Shutdown` to every agent still running, a grace period,
    /// an end for the ones that did not exit, the recording finished.
    fn finish(mut self, ending: Ending) -> Summary {
        let killed = self.wind_down_agents();
        self.record_last_reports();
        self.redraw();
        self.progress.finish();
        let mut summary = self.summary(&ending, killed);
        self.close_recording(&mut summary, &ending);
        summary
    }

    /// Tells every running agent `Shutdown` and waits out the grace: the
    /// robots whose agents had to be killed.
    fn wind_down_agents(&mut self) -> Vec<u32> {
        let running: Vec<u32> =
            self.core.slots().iter().filter(|s| self.agents.is_running(s.id())).map(Slot::id).collect();
        let live = running.len();
        let grace = self.cfg.supervision.shutdown_grace_for(live);
        let winding = Instant::now();
        let ports = &mut self.ports;
        // A failure to send only means it is ended after the grace period.
        let mut shutdown = |id| drop(ports.send(id, &ToAgent::Shutdown, false));
        let killed = wind_down(self.agents.as_mut(), &running, grace, &mut shutdown);
        tracing::debug!(
            agents = live,
            killed = killed.len(),
            grace_ms = grace.as_millis() as u64,
            took_ms = winding.elapsed().as_millis() as u64,
            "agents wound down"
        );
        // Killed agents may leave transport state behind (iceoryx2 nodes):
        // the transport removes it now rather than at the next launch.
        self.ports.cleanup_dead_nodes();
        if !killed.is_empty() {
            let ids: Vec<String> = killed.iter().map(u32::to_string).collect();
            let whose = if ids.len() == 1 { "robot" } else { "robots" };
            let fate = self.agents.properties().ended_by;
            self.progress.event(&format!(
                "the agents of {whose} {} did not exit after Shutdown: {fate}",
                ids.join(", ")
            ));
        }
        killed
    }

    /// Records the reports the agents sent while they wound down, the core
    /// not fed them (the run has ended; replay re-runs the core's log, which
    /// does not hold them): a ROS 2 robot's agent answers `Shutdown` with a
    /// zero velocity and its `Commanded`, and the recording holds every
    /// command sent. At most [`LAST_REPORTS_PER_ROBOT`] per robot, so a
    /// flood cannot hold the end up.
    fn record_last_reports(&mut self) {
        let most = LAST_REPORTS_PER_ROBOT * self.cfg.robots as usize;
        let mut taken = 0;
        while taken < most && matches!(self.ports.recv_report(Duration::ZERO), Ok(Some(_))) {
            taken += 1;
        }
        tracing::debug!(reports = taken, "reports recorded after the agents wound down");
    }

    /// The summary of the launch as the core decided it (`summary::of`),
    /// with the driver's own figures: wall time, speed, real-time report.
    fn summary(&mut self, ending: &Ending, killed: Vec<u32>) -> Summary {
        let decided = super::summary::of(&self.core, &self.view, ending, Ok(()));
        let dt = self.run.run_config().kinematics.dt;
        let wall_s = self.epoch.elapsed().as_secs_f64();
        let realtime = (self.cfg.clock == Clock::Realtime)
            .then(|| RealtimeReport::new(self.cfg.speed, decided.frames.0, decided.frames.1));
        if let Some(rt) = realtime.as_ref().filter(|rt| !rt.faithful) {
            tracing::warn!(
                missed_periods = rt.missed_periods,
                periods = rt.periods,
                achieved_speed = rt.achieved_speed,
                "the agents could not keep up with {}× real time: {} of {} periods missed, \
                 achieved {:.1}×; the run is not faithful (lower --speed)",
                self.cfg.speed,
                rt.missed_periods,
                rt.periods + rt.missed_periods,
                rt.achieved_speed
            );
        }
        let (spent, ticks) = (decided.steps, decided.ticks);
        let first_moving = self.core.first_moving_us().map(|us| {
            (self.epoch.saturating_duration_since(self.begun) + Duration::from_micros(us)).as_secs_f64()
        });
        Summary {
            swarm: self.joining.swarm.clone(),
            terrain: self.world.name.clone(),
            eps: self.cfg.eps,
            noise: self.cfg.noise,
            seed: self.cfg.seed,
            clock: self.cfg.clock.as_str().into(),
            speed: (self.cfg.clock == Clock::Realtime).then_some(self.cfg.speed),
            success: decided.verdict.success,
            outcome: decided.verdict.outcome,
            error: decided.verdict.error,
            robots_used: decided.robots_used,
            steps: spent,
            time_s: self.run.run_config().kinematics.time_of(spent),
            ticks,
            ticked_agents: self.core.ticked_agents(),
            tick_us: self.core.tick_us(),
            quiet_us_per_agent: self.core.quiet_us_per_agent(),
            wall_s,
            sim_speed: match self.cfg.clock {
                Clock::Lockstep if wall_s > 0.0 => ticks as f64 * dt / wall_s,
                Clock::Lockstep => 0.0,
                Clock::Realtime => realtime.as_ref().map_or(self.cfg.speed, |rt| rt.achieved_speed),
            },
            realtime,
            beacons: decided.beacons,
            robots: decided.robots,
            bad_traffic: self.traffic(),
            recording: None,
            picture: None,
            transport: self.cfg.transport.kind.as_str().into(),
            endpoints: std::mem::take(&mut self.endpoints),
            first_moving_s: first_moving,
            resends: decided.resends,
            shutdown_killed: killed,
            stop: self.core.stopped().cloned(),
            revoked: self.core.revoked().to_vec(),
        }
    }

    /// Shows the scene to its end, draws the picture, writes the summary
    /// into the recording and closes it; a recording that fails to close
    /// changes the verdict.
    fn close_recording(&mut self, summary: &mut Summary, ending: &Ending) {
        // The observers see the scene to its last gate event.
        self.ports.recording.sync();
        self.ports.show_scene();
        if let Some(trace) = self.ports.recording.take_trace() {
            summary.picture = self.picture(&trace, summary);
        }
        if self.ports.recording.is_on() {
            let topic = format!("bycoms/{}/summary", summary.swarm);
            self.ports.recording.json(&topic, super::events::SUMMARY_SCHEMA, &*summary);
        }
        let recording = std::mem::replace(&mut self.ports.recording, super::recording::Recording::off());
        match recording.finish() {
            Ok(Some(rec)) => {
                summary.recording = Some(RecordingSummary {
                    path: rec.path.display().to_string(),
                    messages: rec.messages,
                    counts: rec.counts,
                });
            }
            Ok(None) => {}
            Err(e) => {
                let v = super::summary::verdict(ending, Err(&e.to_string()));
                (summary.outcome, summary.success, summary.error) = (v.outcome, v.success, v.error);
            }
        }
    }

    /// The snapshot picture of the run from what crossed the bus (`--svg`).
    fn picture(&self, trace: &bycoms_study::draw::trace::Trace, summary: &Summary) -> Option<String> {
        let heading = format!(
            "{} — ε = {}, {} launch, swarm {}",
            summary.terrain, summary.eps, summary.clock, summary.swarm
        );
        let dt = self.run.run_config().kinematics.dt;
        let real = crate::lab::real_robots(&self.cfg, &self.world);
        let opts = bycoms_study::draw::snapshot::Options::in_room(self.world.unit, self.world.room.as_ref());
        Some(bycoms_study::draw::trace::picture_in(
            &self.world.terrain,
            trace,
            self.cfg.eps,
            dt,
            &heading,
            &bycoms_study::draw::snapshot::Options { real: &real, ..opts },
        ))
    }
}

/// The most reports per robot recorded after the agents wound down
/// ([`Driver::record_last_reports`]).
const LAST_REPORTS_PER_ROBOT: usize = 64;

/// How often winding down looks whether the agents ended.
const REAP_EVERY: Duration = Duration::from_millis(2);

/// Winds down the agents of `running` as the core's [`WindDown`] decides,
/// on this shell's clock (the sources read none): `shutdown(id)` sends
/// robot `id`'s agent `Shutdown`, the source asks those that may have
/// missed it to end, they get up to `grace` to exit, and the source ends
/// the rest; returns those it had to end.
pub fn wind_down(
    agents: &mut dyn AgentSource,
    running: &[u32],
    grace: Duration,
    shutdown: &mut dyn FnMut(u32),
) -> Vec<u32> {
    let start = Instant::now();
    let now = || u64::try_from(start.elapsed().as_micros()).unwrap_or(u64::MAX);
    let grace_us = u64::try_from(grace.as_micros()).unwrap_or(u64::MAX);
    let mut winding = WindDown::new(now(), grace_us, running.iter().copied());
    loop {
        match winding.poll(now()) {
            Some(WindStep::Shutdown(ids)) => ids.into_iter().for_each(&mut *shutdown),
            Some(WindStep::AskToEnd) => agents.ask_to_end(),
            // The source ends what it still runs, and says what that was.
            Some(WindStep::EndRest(_)) => return agents.end_rest(),
            None if winding.is_done() => return agents.end_rest(),
            None => {
                reap(agents, &mut winding);
                if winding.running().next().is_some() {
                    std::thread::sleep(REAP_EVERY);
                }
            }
        }
    }
}

/// Takes in the agents that ended: every one when the source sees none
/// running (or cannot see them leave).
fn reap(agents: &mut dyn AgentSource, winding: &mut WindDown) {
    if !agents.reap() {
        return winding.all_ended();
    }
    let ended: Vec<u32> = winding.running().filter(|&id| !agents.is_running(id)).collect();
    for id in ended {
        winding.ended(id);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::agents::spawned::{AgentCommand, Spawned};

    /// An agent that never registers and ends only on SIGTERM (as a
    /// `sim-agent` still opening its bus: the `Shutdown` was lost on it)
    /// is asked to end, not killed after the grace: nobody had to end it.
    #[test]
    fn an_agent_never_heard_from_is_asked_to_end_not_killed_after_the_grace() {
        let script = "trap 'exit 130' TERM; while :; do sleep 0.02; done";
        let command = AgentCommand {
            program: "/bin/sh".into(),
            prefix: vec!["-c".into(), script.into(), "agent".into()],
            own: false,
        };
        let mut source = Spawned::new(command);
        source.spawn(1, &[], "").expect("spawn");
        let killed = wind_down(&mut source, &[1], Duration::from_secs(20), &mut |_| {});
        assert_eq!(killed, Vec::<u32>::new(), "it ended when asked, so nobody had to kill it");
        assert!(!source.is_running(1));
    }
}
