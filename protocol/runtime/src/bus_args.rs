//! The bus flags and the bus of every agent process: `sim-agent` and the
//! real robot's `gateway`.
//!
//! Why one definition: both are members of a swarm that joins the
//! orchestrator's bus the same way — iceoryx2 on this host, or zenoh to the
//! orchestrator's endpoint from any host (with a liveliness token, so the
//! orchestrator sees the process or its link go, and a watch on the
//! orchestrator's token, so the robot stops when the orchestrator is gone).
//! Written twice, the two would drift: a gateway that could not run on a
//! bridge host was exactly that.
//!
//! [`BusArgs::open`] opens the bus these flags describe and hands it to an
//! [`OnBus`] (a generic callback: the caller's loop is generic over
//! [`Bus`], and iceoryx2 and zenoh are two types).

use crate::bus_config::{ipc_config, zenoh_config};
use crate::failsafe::{Failsafe, FailsafeArgs};
use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::bus::zenoh::clock::{ClockProbe, HostClock};
use bycoms_protocol::bus::zenoh::{AliveWatch, Mode, ZenohBus, ZenohConfig};
use bycoms_protocol::bus::{Bus, BusError};
use bycoms_protocol::naming::Member;
use bycoms_protocol::Swarm;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The bus every process of a launch talks over.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "snake_case")]
pub enum Transport {
    /// iceoryx2 shared memory: every process on this host (the default).
    #[default]
    Ipc,
    /// zenoh over tcp or tls: processes on any host; the orchestrator's
    /// session is the rendezvous (router), agents connect to it.
    Zenoh,
    /// The in-memory bus of one process: a launch whose simulated agents
    /// run as threads of the orchestrator (`transport.kind = "memory"` in a
    /// launch config; quick tests with no shared memory and no sockets).
    /// Not a choice for an agent process.
    #[value(skip)]
    Memory,
}

impl Transport {
    /// The transport's name as on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Ipc => "ipc",
            Self::Zenoh => "zenoh",
            Self::Memory => "memory",
        }
    }
}

/// How an agent process reaches the swarm's bus.
#[derive(Clone, Debug, Default, PartialEq, clap::Args)]
pub struct BusArgs {
    /// The bus: `ipc` (this host) or `zenoh` (connect to the orchestrator).
    #[arg(long, value_enum, default_value_t = Transport::Ipc)]
    pub transport: Transport,
    /// zenoh: the orchestrator's endpoint, e.g. `tcp/10.0.0.5:7447` or
    /// `quic/lab-host:7447` (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// zenoh: a zenoh JSON5 config file read first (TLS certificates,
    /// access control; see deploy/zenoh/).
    #[arg(long, value_name = "FILE")]
    pub zenoh_config: Option<PathBuf>,
}

/// What runs on the bus once it is open (see the module docs).
pub trait OnBus {
    /// What the run returns.
    type Output;
    /// Over zenoh, once the session is open and before the member's
    /// liveliness token is declared: what the process must learn first
    /// (an agent's run settings from the orchestrator). An `Err` is the
    /// process's output: it ends there, never seen as a member.
    fn prepare(&mut self, _bus: &ZenohBus) -> Result<(), Self::Output> {
        Ok(())
    }
    /// Over zenoh: how long to keep trying to reach the orchestrator when
    /// it is not there yet (an agent started before the launch); `None`
    /// (the default): fail at once with zenoh's error.
    fn wait_for_orchestrator(&self) -> Option<Duration> {
        None
    }
    /// Over zenoh, an agent (a member that is a robot's): the measurement
    /// of its host's clock offset to the orchestrator's, running from now
    /// (`bus::zenoh::clock`), for its loop to report. Dropped by default.
    fn clock(&mut self, _probe: ClockProbe) {}
    /// Runs on `bus`; over zenoh, `failsafe` is the failsafe and the
    /// liveliness watch that feeds it (`None` over iceoryx2, where the
    /// process's lifeline ties it to the orchestrator's).
    fn run<B: Bus>(self, bus: &B, failsafe: Option<(Failsafe, AliveWatch)>) -> Self::Output;
}

impl BusArgs {
    /// Checks what clap cannot: endpoints, and that the zenoh flags come
    /// with the zenoh transport.
    pub fn validate(&self) -> Result<(), String> {
        for endpoint in &self.connect {
            bycoms_protocol::bus::zenoh::check_endpoint(endpoint)
                .map_err(|e| format!("bad --connect {e}"))?;
        }
        let zenoh_flags = !self.connect.is_empty() || self.zenoh_config.is_some();
        match self.transport {
            Transport::Ipc | Transport::Memory if zenoh_flags => {
                Err("--connect and --zenoh-config need --transport zenoh".into())
            }
            Transport::Zenoh if !zenoh_flags => {
                Err("--transport zenoh needs the orchestrator's endpoint: --connect tcp/HOST:PORT".into())
            }
            _ => Ok(()),
        }
    }

    /// The flags that reproduce these values.
    pub fn to_flags(&self) -> Vec<String> {
        let mut v = Vec::new();
        if self.transport != Transport::Ipc {
            v.push("--transport".into());
            v.push(self.transport.as_str().into());
        }
        for endpoint in &self.connect {
            v.push("--connect".into());
            v.push(endpoint.clone());
        }
        if let Some(file) = &self.zenoh_config {
            v.push("--zenoh-config".into());
            v.push(file.display().to_string());
        }
        v
    }

    /// Opens the bus as `member` of `swarm` and runs `then` on it. Over
    /// iceoryx2 the services are sized for `swarm_size` robots and the node
    /// is named `node` (for `iox2` tools); over zenoh a member (an agent)
    /// declares its liveliness token (held while `then` runs) and, with a
    /// `failsafe`, watches the orchestrator's. A process that is no member
    /// (the emulated lab) declares nothing. The memory transport is
    /// refused: it joins threads of one process.
    pub fn open<R: OnBus>(
        &self,
        swarm: &Swarm,
        member: Option<Member>,
        failsafe: Option<&FailsafeArgs>,
        swarm_size: u32,
        node: String,
        mut then: R,
    ) -> Result<R::Output, BusOpenError> {
        match self.transport {
            Transport::Ipc => {
                let mut config = ipc_config(swarm_size);
                config.node_name = Some(node);
                Ok(then.run(&IpcBus::new(config)?, None))
            }
            Transport::Zenoh => {
                let failsafe =
                    failsafe.map(FailsafeArgs::failsafe).transpose().map_err(BusOpenError::Args)?;
                let mut config =
                    zenoh_config(Mode::Client, Vec::new(), self.connect.clone(), self.zenoh_config.clone());
                // An agent's certificate must be its robot's (the lab's ACL
                // is by common name): checked before zenoh sees it.
                config.identity = member.map(bycoms_protocol::bus::zenoh::certs::common_name);
                let bus = open_zenoh(config, then.wait_for_orchestrator())?;
                tracing::debug!(connect = ?self.connect, "connected over zenoh");
                if let Err(output) = then.prepare(&bus) {
                    return Ok(output);
                }
                // The orchestrator sees this process go (ended, link cut)
                // when the token is withdrawn; it lives until `then` returns.
                let _alive = member.map(|m| bus.declare_alive(swarm, m)).transpose()?;
                // ... and this process sees the orchestrator go (the failsafe).
                let failsafe = match failsafe {
                    Some(f) => Some((f, bus.watch_alive_of(swarm, Member::Orchestrator)?)),
                    None => None,
                };
                if matches!(member, Some(Member::Agent(_))) {
                    then.clock(bus.clock_probe(swarm, HostClock::from_env()));
                }
                Ok(then.run(&bus, failsafe))
            }
            Transport::Memory => Err(BusOpenError::Args(
                "the memory transport joins threads of one process: an agent process needs ipc or zenoh"
                    .into(),
            )),
        }
    }
}

/// Opens a zenoh session with `config`; with a `wait`, tries again every
/// half second while the orchestrator cannot be reached (saying so every
/// few seconds), for up to `wait`.
fn open_zenoh(config: ZenohConfig, wait: Option<Duration>) -> Result<ZenohBus, BusError> {
    let Some(wait) = wait else { return ZenohBus::open(config) };
    // A wrong certificate stays wrong: said at once, not retried.
    config.check_certificates(&config.to_zenoh()?)?;
    let begun = Instant::now();
    let mut said = begun;
    loop {
        match ZenohBus::open(config.clone()) {
            Ok(bus) => return Ok(bus),
            Err(e) if begun.elapsed() + RETRY_OPEN < wait => {
                if said.elapsed() >= Duration::from_secs(5) || said == begun {
                    said = Instant::now();
                    tracing::info!(
                        connect = ?config.connect,
                        "the orchestrator is not reachable yet ({:.0} s of {:.0} s): {e}",
                        begun.elapsed().as_secs_f64(),
                        wait.as_secs_f64()
                    );
                }
                std::thread::sleep(RETRY_OPEN);
            }
            Err(e) => return Err(e),
        }
    }
}

/// Wait between two attempts to reach an orchestrator that is not there yet.
const RETRY_OPEN: Duration = Duration::from_millis(500);

/// Why the bus could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum BusOpenError {
    /// A flag has an unusable value.
    #[error("{0}")]
    Args(String),
    /// The bus failed.
    #[error("bus: {0}")]
    Bus(#[from] BusError),
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        bus: BusArgs,
    }

    fn parse(flags: Vec<String>) -> BusArgs {
        Cli::try_parse_from(std::iter::once("x".to_string()).chain(flags)).unwrap().bus
    }

    #[test]
    fn flags_round_trip_and_bad_combinations_are_refused() {
        let args = BusArgs {
            transport: Transport::Zenoh,
            connect: vec!["tcp/127.0.0.1:7447".into(), "quic/lab:7448".into()],
            zenoh_config: Some("robot-1.json5".into()),
        };
        let parsed = parse(args.to_flags());
        assert_eq!(parsed, args);
        assert!(parsed.validate().is_ok());
        assert_eq!(parse(Vec::new()), BusArgs::default());
        assert!(BusArgs::default().validate().is_ok());
        let no_endpoint = BusArgs { connect: Vec::new(), zenoh_config: None, ..args.clone() };
        assert!(no_endpoint.validate().unwrap_err().contains("--connect"));
        let ipc_with_endpoint = BusArgs { transport: Transport::Ipc, ..args.clone() };
        assert!(ipc_with_endpoint.validate().unwrap_err().contains("--transport zenoh"));
        let bad_endpoint = BusArgs { connect: vec!["10.0.0.1:7447".into()], ..args };
        assert!(bad_endpoint.validate().unwrap_err().contains("bad --connect"));
    }
}
