//! The zenoh endpoint a robot's host connects to, reached from here
//! (`doctor --connect`), and the orchestrator's liveliness token seen
//! through it (with a swarm name).
//!
//! Why bounded by a thread: opening a client session to a host that
//! accepts TCP but never answers zenoh's handshake (a wrong port, a
//! firewall that drops, another service) can take zenoh much longer than
//! an operator waits; the doctor gives it `timeout` and says so. The
//! session is opened as an agent's would be (client mode, the robot's
//! zenoh config with its certificate when given), so a certificate the
//! orchestrator's ACL or TLS would refuse fails here the same way.

use super::Finding;
use bycoms_protocol::bus::zenoh::{Mode, Presence, ZenohBus, ZenohConfig};
use bycoms_protocol::naming::Member;
use bycoms_protocol::Swarm;
use std::path::PathBuf;
use std::sync::mpsc;
use std::time::Duration;

const CHECK: &str = "zenoh";

/// What `doctor --connect` checks.
#[derive(Clone, Debug)]
pub struct Reach {
    /// The endpoint robots connect to, e.g. `quic/orchestrator.lab:7447`.
    pub endpoint: String,
    /// A robot's zenoh config (`certs/robot-1.json5`) read first.
    pub zenoh_config: Option<PathBuf>,
    /// The swarm whose orchestrator must be alive (none: not checked).
    pub swarm: Option<Swarm>,
    /// How long each step may take.
    pub timeout: Duration,
}

/// Connects as an agent would, then waits for the orchestrator's token.
pub fn check(reach: &Reach) -> Vec<Finding> {
    let endpoint = reach.endpoint.clone();
    let config = ZenohConfig {
        mode: Mode::Client,
        connect: vec![endpoint.clone()],
        base_config: reach.zenoh_config.clone(),
        ..ZenohConfig::default()
    };
    let (tx, rx) = mpsc::channel();
    // Detached on a timeout: the process ends with the doctor.
    std::thread::spawn(move || tx.send(ZenohBus::open(config)));
    let bus = match rx.recv_timeout(reach.timeout) {
        Ok(Ok(bus)) => bus,
        Ok(Err(e)) => return vec![unreachable(&endpoint, &e.to_string())],
        Err(_) => {
            return vec![unreachable(&endpoint, &format!("no zenoh session within {:?}", reach.timeout))]
        }
    };
    let mut found = vec![Finding::ok(CHECK, format!("{endpoint} reached"))];
    let Some(swarm) = &reach.swarm else { return found };
    let name = swarm.as_str();
    let seen = bus
        .watch_alive_of(swarm, Member::Orchestrator)
        .map(|watch| watch.wait_for(Member::Orchestrator, Presence::Alive, reach.timeout).0.is_some());
    found.push(match seen {
        Ok(true) => Finding::ok(CHECK, format!("the orchestrator of swarm {name} is alive at {endpoint}")),
        Ok(false) => Finding::error(
            CHECK,
            format!("no orchestrator of swarm {name} seen at {endpoint} within {:?}", reach.timeout),
            "start the launch (with this --swarm) first, or check the swarm name and the endpoint",
        ),
        Err(e) => Finding::error(CHECK, e.to_string(), "check the robot's zenoh config and the ACL"),
    });
    found
}

fn unreachable(endpoint: &str, cause: &str) -> Finding {
    Finding::error(
        CHECK,
        format!("{endpoint} not reached: {cause}"),
        "check the orchestrator runs and listens there (transport.listen), the host name, and that the firewall lets the port through (UDP for quic/, TCP for tcp/ and tls/)",
    )
}
