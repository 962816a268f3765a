//! The gateway's loop: one UDP socket, the bus, and [`GatewayCore`].
//!
//! Over zenoh (a gateway on a bridge host) it also watches the
//! orchestrator's liveliness: gone past the failsafe's grace, the robot is
//! told to stop (the same [`Failsafe`] as sim-agent's).
//!
//! Why one thread with a short receive timeout: an iceoryx2 bus is confined
//! to the thread that opened it, and the robot's datagrams must be relayed
//! at once (the added latency is a figure of merit: `agent bench`). So the
//! loop blocks on the socket for at most [`SLICE`], relays every datagram
//! as it comes, and between datagrams drains the bus (commands, the robot's
//! own pose), runs the core's timers and checks its [`Lifeline`]. A
//! command therefore waits at most one slice before it goes to the robot.

use super::core::{GatewayCore, Output};
use bycoms_protocol::bus::zenoh::clock::{self, ClockProbe};
use bycoms_protocol::bus::zenoh::{AliveWatch, Presence};
use bycoms_protocol::bus::{Bus, BusError, BusExt, TypedPublisher, TypedSubscriber};
use bycoms_protocol::msg::{FromAgent, Heartbeat, Pose, Register, RobotKind, ToAgent};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{RobotId, Swarm, PROTOCOL_VERSION};
use bycoms_runtime::failsafe::{Failsafe, Verdict};
use bycoms_runtime::{instance, BadKind, ExitCause, Lifeline, Traffic};
use std::io;
use std::net::UdpSocket;
use std::time::{Duration, Instant};

/// Longest wait on the socket before the bus and the timers are served.
pub const SLICE: Duration = Duration::from_millis(2);

/// The gateway's ports on the bus.
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
    /// Bad bus messages.
    pub traffic: Traffic,
    /// Telemetry frames relayed.
    pub relayed: u64,
    /// Per relayed telemetry frame: socket receive returned → its bus
    /// messages published, ns (the first million).
    pub relay_ns: Vec<u64>,
}

/// One gateway process's loop.
pub struct Gateway<B: Bus> {
    core: GatewayCore,
    ports: GatewayPorts<B>,
    socket: UdpSocket,
    heartbeat_every: Duration,
    who: String,
    stats: GatewayStats,
    /// zenoh: the failsafe and the liveliness watch that feeds it.
    failsafe: Option<(Failsafe, AliveWatch)>,
    /// zenoh: the measurement of this host's clock offset to the
    /// orchestrator's, reported as it comes (`FromAgent::Clock`).
    clock: Option<ClockProbe>,
}

impl<B: Bus> Gateway<B> {
    /// A gateway around `core`, serving the robot on `socket`.
    pub fn new(
        core: GatewayCore,
        ports: GatewayPorts<B>,
        socket: UdpSocket,
        heartbeat_every: Duration,
    ) -> io::Result<Self> {
        socket.set_read_timeout(Some(SLICE))?;
        let who = format!("agent[robot {}]", core.robot().0);
        Ok(Self {
            core,
            ports,
            socket,
            heartbeat_every,
            who,
            stats: GatewayStats::default(),
            failsafe: None,
            clock: None,
        })
    }

    /// Watches the orchestrator's liveliness on `watch` (zenoh): once it has
    /// been gone for longer than the failsafe's grace, the robot is stopped
    /// (its firmware is told `Stop`, and its own 500 ms failsafe holds it
    /// if that is lost), and the loop ends with
    /// [`ExitCause::OrchestratorLost`] or goes on, by policy.
    pub fn watch_orchestrator(&mut self, failsafe: Failsafe, watch: AliveWatch) {
        self.failsafe = Some((failsafe, watch));
    }

    /// Feeds the failsafe what zenoh saw and acts on its verdict.
    fn check_failsafe(&mut self) -> Result<Option<ExitCause>, RunError> {
        let Some((failsafe, watch)) = self.failsafe.as_mut() else { return Ok(None) };
        while let Some(event) = watch.try_recv() {
            if event.member == Member::Orchestrator {
                match event.presence {
                    Presence::Alive => failsafe.orchestrator_alive(event.at),
                    Presence::Lost => failsafe.orchestrator_lost(event.at),
                }
            }
        }
        let verdict = failsafe.check(Instant::now());
        if let Some(report) = verdict.report(self.core.robot()) {
            // Best effort: the link may be cut (a reminder follows its return).
            let _ = self.ports.report.publish(&report);
        }
        let (lost_for, exit) = match verdict {
            Verdict::Run => return Ok(None),
            Verdict::Remind { lost_for } => {
                tracing::info!(?lost_for, "orchestrator back: told it that the failsafe stopped the robot");
                return Ok(None);
            }
            Verdict::Stop { lost_for } => (lost_for, false),
            Verdict::StopAndExit { lost_for } => (lost_for, true),
        };
        tracing::error!(
            ?lost_for,
            "orchestrator lost past the grace period: robot stopped, {}",
            if exit { "exiting" } else { "waiting" }
        );
        self.core.on_command(&ToAgent::Stop, Instant::now()).ok();
        self.flush(None)?;
        Ok(exit.then_some(ExitCause::OrchestratorLost))
    }

    /// The core (drop counters, link state).
    pub fn core(&self) -> &GatewayCore {
        &self.core
    }

    /// What was counted so far.
    pub fn stats(&self) -> &GatewayStats {
        &self.stats
    }

    /// Reports this host's clock offset to the orchestrator's as `probe`
    /// measures it: the first before the `Register` (waited for up to
    /// [`clock::FIRST_WAIT`]), so the launch judges the registration by it.
    pub fn report_clock(&mut self, probe: ClockProbe) {
        self.clock = Some(probe);
    }

    /// Publishes the clock offsets measured since the last call (waiting
    /// up to `wait` for one).
    fn clock_reports(&mut self, wait: Option<Duration>) -> Result<(), BusError> {
        let Some(probe) = &self.clock else { return Ok(()) };
        let samples = match wait {
            Some(wait) => probe.wait(wait).into_iter().collect(),
            None => probe.take(),
        };
        for sample in samples {
            self.ports.report.publish(&clock::report(self.core.robot(), sample))?;
        }
        Ok(())
    }

    /// Registers, then runs until `Shutdown`, a signal or the parent's death.
    pub fn run(&mut self, lifeline: &mut Lifeline) -> Result<ExitCause, RunError> {
        self.clock_reports(Some(clock::FIRST_WAIT))?;
        let robot = self.core.robot();
        let register = Register {
            robot,
            kind: RobotKind::Real,
            protocol_version: PROTOCOL_VERSION,
            instance: instance(),
            settings: 0,
            failsafe_grace_ms: self.failsafe.as_ref().map_or(0, |(f, _)| f.grace_ms()),
        };
        self.ports.report.publish(&FromAgent::Register(register))?;
        let (mut seq, mut next_heartbeat) = (0u64, Instant::now());
        // Until the orchestrator sends a command, every heartbeat repeats
        // the `Register` (a lost one would leave the robot never enabled).
        let mut heard_orchestrator = false;
        let mut buf = [0u8; 2048];
        loop {
            if let Some(cause) = lifeline.check() {
                self.core.on_command(&ToAgent::Stop, Instant::now()).ok();
                self.flush(None)?;
                return Ok(cause);
            }
            if let Some(cause) = self.check_failsafe()? {
                return Ok(cause);
            }
            let now = Instant::now();
            if now >= next_heartbeat {
                self.clock_reports(None)?;
                seq += 1;
                next_heartbeat = now + self.heartbeat_every;
                if !heard_orchestrator && seq > 1 {
                    self.ports.report.publish(&FromAgent::Register(register))?;
                }
                self.ports.report.publish(&FromAgent::Heartbeat(Heartbeat { robot, seq }))?;
            }
            match self.socket.recv_from(&mut buf) {
                Ok((n, from)) => {
                    let got = Instant::now();
                    if let Err(reason) = self.core.on_datagram(&buf[..n], from, got) {
                        tracing::debug!(robot = robot.0, %from, %reason, "link frame refused");
                    }
                    self.flush(Some(got))?;
                }
                Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => {}
                // An earlier send to a robot that is not listening (ICMP).
                Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e.into()),
            }
            let (exit, commanded) = self.drain_bus()?;
            heard_orchestrator |= commanded;
            if let Some(cause) = exit {
                self.flush(None)?;
                return Ok(cause);
            }
            self.core.poll(Instant::now());
            self.flush(None)?;
        }
    }

    /// Handles every waiting command and pose: (why to exit, if `Shutdown`
    /// or this gateway's refusal came; whether any command came).
    fn drain_bus(&mut self) -> Result<(Option<ExitCause>, bool), BusError> {
        let mut commanded = false;
        loop {
            match self.ports.own_pose.try_recv() {
                Ok(Some(pose)) => self.core.on_pose(&pose),
                Ok(None) => break,
                Err(e) => self.absorb("pose", e)?,
            }
        }
        loop {
            match self.ports.commands.try_recv() {
                // Another gateway holds this robot: leave (a refusal of
                // another instance is not for us).
                Ok(Some(ToAgent::Refused(r))) if r.instance == instance() => {
                    tracing::error!(
                        robot = r.robot.0,
                        "refused by the orchestrator for robot {}: {}",
                        r.robot.0,
                        r.why
                    );
                    self.core.on_command(&ToAgent::Stop, Instant::now()).ok();
                    return Ok((Some(ExitCause::Refused), commanded));
                }
                Ok(Some(ToAgent::Refused(_))) => {}
                Ok(Some(cmd)) => {
                    commanded = true;
                    match self.core.on_command(&cmd, Instant::now()) {
                        Ok(true) => return Ok((Some(ExitCause::Shutdown), true)),
                        Ok(false) => {}
                        Err(r) => self.stats.traffic.count(&self.who, BadKind::Refused, &r),
                    }
                }
                Ok(None) => return Ok((None, commanded)),
                Err(e) => self.absorb("to_agent", e)?,
            }
        }
    }

    fn absorb(&mut self, topic: &str, e: BusError) -> Result<(), BusError> {
        match self.stats.traffic.absorb(&self.who, topic, e) {
            None => Ok(()),
            Some(fatal) => Err(fatal),
        }
    }

    /// Sends and publishes everything the core queued; `received` is when
    /// the datagram that caused it arrived (for the relay latency).
    fn flush(&mut self, received: Option<Instant>) -> Result<(), RunError> {
        let mut relayed = false;
        while let Some(out) = self.core.poll_output() {
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
                    self.ports.report.publish(&msg)?;
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
