//! The zenoh endpoint a robot's host connects to, reached from here
//! (`orchestrator doctor --connect`, `gateway doctor`, `sim-agent doctor`),
//! and, with a swarm name, the orchestrator's liveliness token seen
//! through it and this host's clock offset to the orchestrator's,
//! measured as the agents measure it and judged as the launch judges it
//! (`bus::zenoh::clock`: [`ClockLimits::judge`], the launch core's rule).
//!
//! Why bounded by a thread: opening a client session to a host that
//! accepts TCP but never answers zenoh's handshake (a wrong port, a
//! firewall that drops, another service) can take zenoh much longer than
//! an operator waits; the doctor gives it `timeout` and says so. The
//! session is opened as an agent's would be (client mode, the robot's
//! zenoh config with its certificate when given), so a certificate the
//! orchestrator's ACL or TLS would refuse fails here the same way.

use super::Finding;
use bycoms_protocol::bus::zenoh::clock::{ClockLimits, ClockSample, ClockVerdict, HostClock};
use bycoms_protocol::bus::zenoh::{Mode, Presence, ZenohBus, ZenohConfig};
use bycoms_protocol::naming::Member;
use bycoms_protocol::Swarm;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

const CHECK: &str = "zenoh";
const CLOCK: &str = "clock";

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
    /// The clock offsets the launch warns about and refuses.
    pub clocks: ClockLimits,
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
    // A config file that cannot be read or is not a zenoh config is the
    // file's problem, not the network's: said before any connection.
    if let Err(e) = config.to_zenoh() {
        return vec![bad_config(reach.zenoh_config.as_deref(), &e.to_string())];
    }
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
    if found.last().is_some_and(|f| f.level == super::Level::Ok) {
        let measured = bus.measure_clock(swarm, HostClock::from_env(), reach.timeout);
        found.push(clock_finding(measured.map_err(|e| e.to_string()), reach.clocks));
    }
    found
}

/// The finding of a clock measurement (`None`: nobody answered).
pub fn clock_finding(measured: Result<Option<ClockSample>, String>, limits: ClockLimits) -> Finding {
    const FIX: &str = "synchronise this host's clock with the orchestrator's: run chrony (or ntpd, systemd-timesyncd) on both against the same server (`chronyc tracking` shows the offset, `chronyc makestep` steps it)";
    let s = match measured {
        Ok(Some(s)) => s,
        Ok(None) => {
            return Finding::error(
                CLOCK,
                "the orchestrator did not answer the clock query (an orchestrator of an older build, or the ACL denies bycoms/*/clock)",
                "update the orchestrator, or regenerate the zenoh configs with `orchestrator certs`",
            )
        }
        Err(e) => return Finding::error(CLOCK, e, "check the robot's zenoh config and the ACL"),
    };
    let (ms, rtt) = (s.offset_us as f64 / 1000.0, s.round_trip_us as f64 / 1000.0);
    let (warn, limit) = (limits.warn_us / 1000, limits.limit_us / 1000);
    let cause = format!("this host's clock is {ms:+.1} ms off the orchestrator's (round trip {rtt:.1} ms)");
    match limits.judge(s.offset_us) {
        ClockVerdict::Fine => Finding::ok(CLOCK, cause),
        ClockVerdict::Warn => Finding::warn(CLOCK, format!("{cause}: more than {warn} ms"), FIX),
        ClockVerdict::Refuse => Finding::error(
            CLOCK,
            format!("{cause}: more than {limit} ms, the launch refuses this host's agents"),
            FIX,
        ),
    }
}

/// The finding of a `--zenoh-config` that is not a usable zenoh config.
fn bad_config(path: Option<&Path>, cause: &str) -> Finding {
    let file = path.map_or_else(|| "the zenoh config".to_owned(), |p| p.display().to_string());
    Finding::error(
        CHECK,
        cause,
        format!("give --zenoh-config a zenoh JSON5 config instead of {file} (a robot's certs/robot-K.json5 from `orchestrator certs`)"),
    )
}

fn unreachable(endpoint: &str, cause: &str) -> Finding {
    Finding::error(
        CHECK,
        format!("{endpoint} not reached: {cause}"),
        "check the orchestrator runs and listens there (transport.listen), the host name, and that the firewall lets the port through (UDP for quic/, TCP for tcp/ and tls/)",
    )
}
