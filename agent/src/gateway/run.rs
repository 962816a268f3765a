//! The gateway's loop: one UDP socket, the bus, and the [`Session`] (its
//! rules, sans-IO) around [`GatewayCore`]; the loop only moves bytes.
//!
//! Over zenoh (a gateway on a bridge host) it also feeds the session the
//! orchestrator's liveliness, for the failsafe (the same [`Failsafe`] as
//! sim-agent's).
//!
//! Why one thread with a short receive timeout: an iceoryx2 bus is confined
//! to the thread that opened it, and the robot's datagrams must be relayed
//! at once (the added latency is a figure of merit: `gateway bench`). So the
//! loop blocks on the socket for at most [`SLICE`], relays every datagram
//! as it comes, and between datagrams drains the bus (commands, the robot's
//! own pose), runs the core's timers and checks its [`Lifeline`]. A
//! command therefore waits at most one slice before it goes to the robot.
//!
//! The session's time is µs since the loop's [`Epoch`] (the one
//! conversion of the wall clock, `bycoms_runtime::epoch`), which the
//! ROS 2 robot's loop shares through [`BusSide`].

use super::core::{Datagram, GatewayCore, Output};
use super::session::{GatewaySession, Input, Rejected, RobotSide, Session};
use bycoms_protocol::bus::zenoh::clock::{self, ClockProbe};
use bycoms_protocol::bus::zenoh::{AliveWatch, Presence};
use bycoms_protocol::bus::{Bus, BusError, BusExt, TypedPublisher, TypedSubscriber};
use bycoms_protocol::msg::{FromAgent, Pose, ToAgent};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{RobotId, SansIo, Swarm};
use bycoms_runtime::failsafe::Failsafe;
use bycoms_runtime::{instance, BadKind, Epoch, ExitCause, Lifeline, Traffic};
use std::io;
use std::net::UdpSocket;
use std::time::{Duration, Instant};

/// Longest wait on the socket before the bus and the timers are served.
pub const SLICE: Duration = Duration::from_millis(2);

/// A real robot agent's ports on the bus (a gateway's, a ROS 2 robot's).
pub struct GatewayPorts<B: Bus> {
    commands: TypedSubscriber<B::Subscriber, ToAgent>,
    own_pose: TypedSubscriber<B::Subscriber, Pose>,
    report: TypedPublisher<B::Publisher, FromAgent>,
}

impl<B: Bus> GatewayPorts<B> {
    /// Opens every port, subscribers first (nothing sent after the
    /// gateway's `Register` can be missed).
    pub fn open(bus: &B, swarm: &Swarm, id: RobotId) -> Result<Self, BusError> {
        let commands = bus.typed_subscriber(&swarm.to_agent(id))?;
        let own_pose = bus.typed_subscriber(&swarm.pose(id))?;
        let report = bus.typed_publisher(&swarm.from_agent(id))?;
        Ok(Self { commands, own_pose, report })
    }
}

/// Why the loop stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The bus failed.
    #[error("bus: {0}")]
    Bus(#[from] BusError),
    /// The robot's socket failed.
    #[error("robot socket: {0}")]
    Io(#[from] io::Error),
}

/// What a gateway counted.
#[derive(Clone, Debug, Default)]
pub struct GatewayStats {
    /// Telemetry frames relayed.
    pub relayed: u64,
    /// Per relayed telemetry frame: socket receive returned → its bus
    /// messages published, ns (the first million).
    pub relay_ns: Vec<u64>,
}

/// The bus side of a real robot's agent, whatever its robot side (a
/// gateway's UDP link, a ROS 2 robot's `cmd_vel`): its ports, the
/// orchestrator's liveliness and clock over zenoh, and the bad traffic
/// counted, and the epoch its session's time counts from. Written once,
/// for every [`Session`].
pub struct BusSide<B: Bus> {
    ports: GatewayPorts<B>,
    who: String,
    traffic: Traffic,
    epoch: Epoch,
    /// zenoh: the liveliness watch that feeds the session's failsafe.
    watch: Option<AliveWatch>,
    /// zenoh: the measurement of this host's clock offset to the
    /// orchestrator's, reported as it comes (`FromAgent::Clock`).
    clock: Option<ClockProbe>,
}

impl<B: Bus> BusSide<B> {
    /// The bus side of `robot`'s agent on `ports`, its session's time
    /// counted from `epoch`; over zenoh `watch` feeds the session's
    /// failsafe.
    pub fn new(ports: GatewayPorts<B>, robot: RobotId, watch: Option<AliveWatch>, epoch: Epoch) -> Self {
        let who = format!("agent[robot {}]", robot.0);
        Self { ports, who, traffic: Traffic::default(), epoch, watch, clock: None }
    }

    /// The epoch of its session's time.
    pub fn epoch(&self) -> Epoch {
        self.epoch
    }

    /// Its session's time now.
    pub fn now(&self) -> bycoms_protocol::Micros {
        self.epoch.elapsed()
    }

    /// Bad bus messages counted so far.
    pub fn traffic(&self) -> &Traffic {
        &self.traffic
    }

    /// Reports this host's clock offset to the orchestrator's as `probe`
    /// measures it (see [`BusSide::clock_reports`]).
    pub fn report_clock(&mut self, probe: ClockProbe) {
        self.clock = Some(probe);
    }

    /// Publishes the clock offsets of `robot` measured since the last call
    /// (waiting up to `wait` for one when given: the first measurement goes
    /// before the first `Register`, so the launch judges the registration
    /// by it).
    pub fn clock_reports(&mut self, robot: RobotId, wait: Option<Duration>) -> Result<(), BusError> {
        let Some(probe) = &self.clock else { return Ok(()) };
        let samples = match wait {
            Some(wait) => probe.wait(wait).into_iter().collect(),
            None => probe.take(),
        };
        for sample in samples {
            self.ports.report.publish(&clock::report(robot, sample))?;
        }
        Ok(())
    }

    /// Feeds `session` what zenoh saw of the orchestrator.
    pub fn watch_orchestrator<C: RobotSide>(&mut self, session: &mut Session<C>) {
        let Some(watch) = self.watch.as_mut() else { return };
        while let Some(event) = watch.try_recv() {
            if event.member == Member::Orchestrator {
                let alive = event.presence == Presence::Alive;
                // Liveliness is taken as it came: no refusal to act on.
                let _ = session.handle(self.epoch.micros(event.at), Input::Orchestrator { alive });
            }
        }
    }

    /// Hands every waiting pose and command to `session`, waiting up to
    /// `wait` when given — for the robot's own pose while the robot side
    /// awaits one ([`RobotSide::awaits_pose`]: a ROS 2 robot's command waits
    /// for it), else for the first command: why to exit, if `Shutdown` or
    /// this agent's refusal came.
    pub fn drain<C: RobotSide>(
        &mut self,
        session: &mut Session<C>,
        wait: Option<Duration>,
    ) -> Result<Option<ExitCause>, BusError> {
        let (mut pose_wait, mut wait) = match session.core().awaits_pose() {
            true => (wait, None),
            false => (None, wait),
        };
        loop {
            let next = match pose_wait.take() {
                Some(timeout) => self.ports.own_pose.recv_timeout(timeout),
                None => self.ports.own_pose.try_recv(),
            };
            match next {
                Ok(Some(pose)) => {
                    // A pose is taken as it came: no refusal to act on.
                    let _ = session.handle(self.epoch.elapsed(), Input::Pose(&pose));
                }
                Ok(None) => break,
                Err(e) => self.absorb("pose", e)?,
            }
        }
        loop {
            let next = match wait.take() {
                Some(timeout) => self.ports.commands.recv_timeout(timeout),
                None => self.ports.commands.try_recv(),
            };
            match next {
                Ok(Some(cmd)) => match session.handle(self.epoch.elapsed(), Input::Command(&cmd)) {
                    Ok(()) if session.exit().is_some() => return Ok(session.exit()),
                    Ok(()) => {}
                    Err(r) => self.traffic.count(&self.who, BadKind::Refused, &r),
                },
                Ok(None) => return Ok(None),
                Err(e) => self.absorb("to_agent", e)?,
            }
        }
    }

    /// Publishes a report; a failsafe report best effort (the link may be
    /// cut: a reminder follows its return).
    pub fn publish(&self, msg: &FromAgent) -> Result<(), BusError> {
        match msg {
            FromAgent::Failsafe(_) => {
                let _ = self.ports.report.publish(msg);
                Ok(())
            }
            _ => self.ports.report.publish(msg),
        }
    }

    fn absorb(&mut self, topic: &str, e: BusError) -> Result<(), BusError> {
        match self.traffic.absorb(&self.who, topic, e) {
            None => Ok(()),
            Some(fatal) => Err(fatal),
        }
    }
}

/// One gateway process's loop.
pub struct Gateway<B: Bus> {
    session: GatewaySession,
    bus: BusSide<B>,
    socket: UdpSocket,
    stats: GatewayStats,
}

impl<B: Bus> Gateway<B> {
    /// A gateway around `core`, serving the robot on `socket`, beating
    /// every `heartbeat_every`; over zenoh it watches the orchestrator's
    /// liveliness with `failsafe` (see [`Session`]: once gone past the
    /// grace, the robot is stopped — its firmware told `Stop`, its own
    /// 500 ms failsafe holding it if that is lost — and the loop ends with
    /// [`ExitCause::OrchestratorLost`] or goes on, by policy). The
    /// session's time counts from `epoch` (the one `core` was made at a
    /// time of).
    pub fn new(
        core: GatewayCore,
        ports: GatewayPorts<B>,
        socket: UdpSocket,
        heartbeat_every: Duration,
        failsafe: Option<(Failsafe, AliveWatch)>,
        epoch: Epoch,
    ) -> io::Result<Self> {
        socket.set_read_timeout(Some(SLICE))?;
        let (failsafe, watch) = failsafe.unzip();
        let bus = BusSide::new(ports, core.robot(), watch, epoch);
        let session = Session::new(core, heartbeat_every, instance(), failsafe);
        Ok(Self { session, bus, socket, stats: GatewayStats::default() })
    }

    /// Reports this host's clock offset to the orchestrator's as `probe`
    /// measures it: the first measurement before the first `Register`
    /// (waiting up to [`clock::FIRST_WAIT`]), then each new one as it comes.
    pub fn report_clock(&mut self, probe: ClockProbe) {
        self.bus.report_clock(probe);
    }

    /// The core (drop counters, link state).
    pub fn core(&self) -> &GatewayCore {
        self.session.core()
    }

    /// What was counted so far.
    pub fn stats(&self) -> &GatewayStats {
        &self.stats
    }

    /// Bad bus messages counted so far.
    pub fn traffic(&self) -> &Traffic {
        self.bus.traffic()
    }

    /// Registers, then runs until `Shutdown`, a signal or the parent's death.
    pub fn run(&mut self, lifeline: &mut Lifeline) -> Result<ExitCause, RunError> {
        let robot = self.core().robot();
        self.bus.clock_reports(robot, Some(clock::FIRST_WAIT))?;
        let _ = self.session.handle(self.bus.now(), Input::Start);
        let mut buf = [0u8; 2048];
        loop {
            self.bus.clock_reports(robot, None)?;
            if let Some(cause) = lifeline.check() {
                let _ = self.session.handle(self.bus.now(), Input::End);
                self.flush(None)?;
                return Ok(cause);
            }
            self.bus.watch_orchestrator(&mut self.session);
            self.session.advance(self.bus.now());
            self.flush(None)?;
            if let Some(cause) = self.session.exit() {
                return Ok(cause);
            }
            match self.socket.recv_from(&mut buf) {
                Ok((n, from)) => {
                    let got = Instant::now();
                    let datagram = Datagram { bytes: &buf[..n], from };
                    let now = self.bus.epoch().micros(got);
                    if let Err(Rejected::Frame(reason)) = self.session.handle(now, Input::Link(datagram)) {
                        tracing::debug!(robot = self.core().robot().0, %from, %reason, "link frame refused");
                    }
                    self.flush(Some(got))?;
                }
                Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => {}
                // An earlier send to a robot that is not listening (ICMP).
                Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e.into()),
            }
            let exit = self.bus.drain(&mut self.session, None)?;
            self.flush(None)?;
            if let Some(cause) = exit {
                return Ok(cause);
            }
        }
    }

    /// Sends and publishes everything the core queued; `received` is when
    /// the datagram that caused it arrived (for the relay latency).
    fn flush(&mut self, received: Option<Instant>) -> Result<(), RunError> {
        let mut relayed = false;
        while let Some(out) = self.session.poll() {
            match out {
                Output::Datagram(bytes, to) => match self.socket.send_to(&bytes, to) {
                    Ok(_) => {}
                    // WiFi loses datagrams too; the link copes.
                    Err(e)
                        if matches!(
                            e.kind(),
                            io::ErrorKind::ConnectionRefused | io::ErrorKind::WouldBlock
                        ) => {}
                    Err(e) => return Err(e.into()),
                },
                Output::Report(msg) => {
                    relayed |= matches!(msg, FromAgent::Telemetry(_));
                    self.bus.publish(&msg)?;
                }
            }
        }
        if let (true, Some(t)) = (relayed, received) {
            self.stats.relayed += 1;
            if self.stats.relay_ns.len() < 1_000_000 {
                self.stats.relay_ns.push(t.elapsed().as_nanos() as u64);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
