//! A simulated robot's agent in virtual time: the `sim-agent` process's
//! rules, on either clock, around the same [`AgentCore`].
//!
//! Why the same core: the harness must reproduce `simulate` bit for bit
//! without faults, so the robot is the very `AgentCore`/`SimRobot` the
//! `sim-agent` process runs. What this file adds is the process's message
//! rules (`sim-agent/src/sim_agent/run.rs`): register until heard from,
//! heartbeats, `Deploy` answered with the start pose (a repeat of it too),
//! a `Tick` stepped once and a repeated one answered without stepping, and
//! the pose and the tick's answer (`Parked` once the robot will never
//! move again, and `TickDone`) after each period; in real time, a period every
//! `period` of its own clock (started when it registers), numbered from that
//! start, whatever came. Those rules are restated here in a few dozen lines
//! because the process keeps them inside its bus loop.

use super::SETTINGS;
use bycoms_protocol::msg::{Deploy, FromAgent, Heartbeat, Pose, Register, RobotKind, Status, ToAgent};
use bycoms_protocol::{RobotId, PROTOCOL_VERSION};
use bycoms_sim::sim_agent::core::AgentCore;
use bycoms_sim::terrain::Terrain;
use bycoms_sim::RunConfig;

/// What an agent sends: a report, or a pose on its own topic.
#[derive(Clone, Debug, PartialEq)]
pub enum Sent {
    /// A report to the orchestrator.
    Report(FromAgent),
    /// Its pose.
    Pose(Pose),
}

/// One simulated agent.
pub struct Agent {
    id: u32,
    instance: u64,
    core: AgentCore,
    tick: u64,
    heard: bool,
    deployed: Option<Deploy>,
    period_us: u64,
    /// Ticks stepped (each exactly once).
    pub stepped: u64,
    /// Alive (not crashed, killed or shut down).
    pub alive: bool,
    /// When it next registers or beats, µs (none: it never registers).
    pub next_beat: Option<u64>,
    heartbeat_us: u64,
    beats: u64,
    /// Real time: its own clock's start and period (wall µs), once it runs.
    realtime: Option<RealTime>,
    /// Real time: when its next period is due, µs.
    pub next_period: Option<u64>,
}

/// An agent's own real-time clock.
#[derive(Clone, Copy, Debug)]
struct RealTime {
    period_us: u64,
    t0: Option<u64>,
}

impl Agent {
    /// Robot `id`'s agent, registering first at `register_at` (never if
    /// none); on the real-time clock with a period of `wall_period_us` when
    /// given, else lockstep.
    pub fn new(
        id: u32,
        instance: u64,
        terrain: Terrain,
        run: RunConfig,
        register_at: Option<u64>,
        wall_period_us: Option<u64>,
    ) -> Self {
        let period_us = (run.kinematics.dt * 1e6).round() as u64;
        Self {
            id,
            instance,
            core: AgentCore::new(RobotId(id), terrain, run),
            tick: 0,
            heard: false,
            deployed: None,
            period_us,
            stepped: 0,
            alive: true,
            next_beat: register_at,
            heartbeat_us: 500_000,
            beats: 0,
            realtime: wall_period_us.map(|period_us| RealTime { period_us: period_us.max(1), t0: None }),
            next_period: None,
        }
    }

    /// The robot.
    pub fn id(&self) -> u32 {
        self.id
    }

    /// Its timer fired at `now`: a registration (repeated until heard from)
    /// and a heartbeat.
    pub fn beat(&mut self, now: u64, out: &mut Vec<Sent>) {
        if !self.alive {
            return;
        }
        let robot = RobotId(self.id);
        if let Some(rt) = self.realtime.as_mut().filter(|rt| rt.t0.is_none()) {
            // Its clock starts when it registers, as the process's does.
            rt.t0 = Some(now);
            self.next_period = Some(now + rt.period_us);
        }
        if !self.heard {
            let r = Register {
                robot,
                kind: RobotKind::Simulated,
                protocol_version: PROTOCOL_VERSION,
                instance: self.instance,
                settings: SETTINGS,
                failsafe_grace_ms: 0,
            };
            out.push(Sent::Report(FromAgent::Register(r)));
        }
        self.beats += 1;
        out.push(Sent::Report(FromAgent::Heartbeat(Heartbeat { robot, seq: self.beats })));
        self.next_beat = Some(now + self.heartbeat_us);
    }

    /// Real time: its period due at `now` (late periods are skipped, as the
    /// process skips what it was late for).
    pub fn period(&mut self, now: u64, out: &mut Vec<Sent>) {
        let Some(RealTime { period_us, t0: Some(t0) }) = self.realtime else { return };
        if !self.alive {
            self.next_period = None;
            return;
        }
        let index = (now - t0) / period_us;
        self.tick = index;
        if self.core.step() {
            self.stepped += 1;
            self.publish(out);
            out.push(Sent::Report(FromAgent::Status(self.status())));
        } else {
            self.publish(out);
        }
        self.next_period = Some(t0 + (index + 1) * period_us);
    }

    /// A command from the orchestrator.
    pub fn command(&mut self, cmd: &ToAgent, out: &mut Vec<Sent>) {
        if !self.alive {
            return;
        }
        if let ToAgent::Refused(r) = cmd {
            if r.instance == self.instance {
                self.alive = false;
            }
            return;
        }
        self.heard = true;
        match cmd {
            ToAgent::Deploy(d) => {
                let again = self.deployed == Some(*d);
                if again || self.core.deploy(d).is_ok() {
                    self.deployed = Some(*d);
                    self.answer_deploy(out);
                }
            }
            ToAgent::GoalBearing(b) => {
                let _ = self.core.set_bearing(b);
            }
            // A real-time agent steps on its own clock (the process counts a
            // `Tick` as refused traffic).
            ToAgent::Tick(_) if self.realtime.is_some() => {}
            ToAgent::Tick(t) if t.step <= self.tick => {
                if t.step == self.tick {
                    self.publish(out);
                    out.extend(self.core.tick_answer(t.step).map(Sent::Report));
                }
            }
            ToAgent::Tick(t) => {
                self.tick = t.step;
                if self.core.step() {
                    self.stepped += 1;
                    self.publish(out);
                    out.push(Sent::Report(FromAgent::Status(self.status())));
                } else {
                    self.publish(out);
                }
                out.extend(self.core.tick_answer(t.step).map(Sent::Report));
            }
            ToAgent::Stop => self.core.stop(),
            ToAgent::Shutdown => {
                self.alive = false;
                self.next_period = None;
            }
            ToAgent::Refused(_) => {}
            ToAgent::Beacon(b) => {
                // An out-of-sequence beacon is taken too; the process logs it.
                let _ = self.core.beacon(b);
            }
        }
    }

    fn answer_deploy(&mut self, out: &mut Vec<Sent>) {
        self.publish(out);
        out.push(Sent::Report(FromAgent::Status(self.status())));
    }

    fn status(&self) -> Status {
        Status { robot: RobotId(self.id), mode: self.core.mode() as u8, step: self.tick }
    }

    fn publish(&mut self, out: &mut Vec<Sent>) {
        if let Some(p) = self.core.pose(self.tick, self.tick.saturating_mul(self.period_us)) {
            out.push(Sent::Pose(p));
        }
    }
}
