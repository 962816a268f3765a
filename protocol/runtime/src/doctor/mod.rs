//! The doctor's findings and the checks every host of a lab shares: the
//! orchestrator's (`orchestrator doctor`) and the robots' hosts' (`agent
//! doctor`, `sim-agent doctor`).
//!
//! Why: a robot's host must be checkable without the orchestrator binary
//! (issue 34), and `orchestrator doctor --connect` run there and the
//! agents' own doctors must say the same thing the same way. So the
//! [`Finding`] and its report ([`text`], [`json`]), the zenoh reach,
//! liveliness and clock check ([`zenoh`]), this robot's certificate
//! ([`certs`]), a UDP port and the open-files limit ([`host`]) are here,
//! once; the orchestrator keeps only its own checks (the whole certificate
//! set against the ACL, memory for the planned robot count, iceoryx2
//! leftovers, NatNet).
//!
//! Why in `bycoms-runtime` (feature `doctor`) and not a crate of its own:
//! the three binaries already depend on this crate, and its `process`
//! feature already brings the zenoh bus and the x509 parser (through
//! `bycoms-protocol`) and clap; the doctor adds only `serde_json`, and no
//! edge between crates. Behind a feature, so the crate's light users (the
//! quantile, the logging) get none of it.
//!
//! A host's doctor ([`HostArgs`], [`main_with`]) runs on a robot's host:
//! the open-files limit, the gateway's UDP port (`gateway` only), this
//! robot's certificate in its zenoh config, the orchestrator's endpoint
//! reached, its liveliness seen and this host's clock offset to it judged
//! by the launch's default limits ([`ClockLimits::LAB`]). Exit 0 without an
//! error, 1 with one, 2 for a usage error.

pub mod certs;
mod finding;
pub mod host;
#[cfg(test)]
mod tests;
pub mod zenoh;

pub use finding::{any_error, json, text, Finding, Level, WARN_DAYS};

use bycoms_protocol::bus::zenoh::clock::ClockLimits;
use bycoms_protocol::Swarm;
use std::io::Write as _;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::{Duration, SystemTime};

/// The flags of a robot's host's doctor (`gateway doctor`, `sim-agent
/// doctor`): what this host's agent is started with, less what the
/// doctor does not need.
#[derive(Clone, Debug, PartialEq, Eq, clap::Args)]
pub struct HostArgs {
    /// The orchestrator's zenoh endpoint this host's agents connect to, e.g.
    /// quic/orchestrator.lab:7447: reached as an agent would (client mode),
    /// the orchestrator's liveliness seen there and this host's clock offset
    /// to it measured (warn past 100 ms, error past 500 ms).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: String,
    /// This robot's zenoh config (certs/robot-K.json5 of `orchestrator
    /// certs`), read first; its certificate is checked: signed by the lab's
    /// CA, common name robot-K, valid (warn within 30 days of its expiry).
    #[arg(long, value_name = "FILE")]
    pub zenoh_config: Option<PathBuf>,
    /// Swarm name: the launch whose orchestrator must be alive.
    #[arg(long, value_name = "NAME")]
    pub swarm: String,
    /// This host's robot (its certificate must be robot-K's).
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(1..))]
    pub robot: u32,
    /// How long the zenoh session, the orchestrator's liveliness and each
    /// clock exchange may take, ms.
    #[arg(long, value_name = "MS", default_value_t = 500, value_parser = crate::seconds::millis)]
    pub timeout_ms: u64,
    /// Print the findings as JSON: {"findings": [{check, level, cause, fix}], "errors", "warnings"}.
    #[arg(long)]
    pub json: bool,
}

/// What a host's doctor checks besides [`HostArgs`]: what its agent
/// process needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HostNeeds {
    /// Open files the agent process needs ([`host::AGENT_FILES`]).
    pub files: u64,
    /// The robot link's UDP address the gateway binds (`gateway doctor --bind`).
    pub bind: Option<SocketAddr>,
}

/// The findings of a robot's host at `now`, or a usage error (a bad
/// endpoint or swarm name).
pub fn host_findings(args: &HostArgs, needs: HostNeeds, now: SystemTime) -> Result<Vec<Finding>, String> {
    bycoms_protocol::bus::zenoh::check_endpoint(&args.connect).map_err(|e| format!("bad --connect {e}"))?;
    let swarm = Swarm::new(&args.swarm).map_err(|e| format!("bad --swarm: {e}"))?;
    let mut found = vec![host::open_files_here(needs.files)];
    if let Some(bind) = needs.bind {
        found.extend(host::udp_ports(&[(args.robot, bind)]));
    }
    if let Some(config) = &args.zenoh_config {
        found.extend(certs::robot(config, args.robot, now));
    }
    found.extend(zenoh::check(&zenoh::Reach {
        endpoint: args.connect.clone(),
        zenoh_config: args.zenoh_config.clone(),
        swarm: Some(swarm),
        timeout: Duration::from_millis(args.timeout_ms),
        clocks: ClockLimits::LAB,
    }));
    Ok(found)
}

/// Runs a robot's host's doctor and prints its report on stdout (text, or
/// JSON with `--json`); returns the exit code: 0 without an error, 1 with
/// one (or when the report cannot be written), 2 for a usage error.
pub fn main_with(args: &HostArgs, needs: HostNeeds) -> i32 {
    let found = match host_findings(args, needs, SystemTime::now()) {
        Ok(found) => found,
        Err(usage) => {
            tracing::error!("{usage}");
            return 2;
        }
    };
    let report = if args.json {
        serde_json::to_string_pretty(&json(&found)).unwrap_or_default()
    } else {
        text(&found).join("\n")
    };
    if let Err(e) = writeln!(std::io::stdout().lock(), "{report}") {
        tracing::error!("cannot write the doctor's report: {e}");
        return 1;
    }
    i32::from(any_error(&found))
}
