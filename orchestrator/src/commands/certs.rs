//! `orchestrator certs`: a lab's CA, certificates and zenoh configs for
//! TLS with mutual authentication and an access-control list, so a lab
//! does not have to learn openssl to deploy securely (see `crate::certs`).

use crate::certs::{add_robots, generate, revoke, Plan};
use anyhow::Result;
use bycoms_launch::config::MAX_ROBOTS;
use bycoms_launch::control::{Answer, Ask, Asker};
use bycoms_runtime::exit;
use std::path::{Path, PathBuf};

/// Make a lab CA, the orchestrator's certificate, one per robot, and the
/// matching zenoh configs (orchestrator.json5 with the ACL, robot-K.json5).
///
/// Robot K may then publish only under its own id (`bycoms/*/robot/K/**`,
/// plus the shared `from_agents`). Keep ca-key.pem offline: it signs new
/// certificates. Private keys are written with mode 0600.
///
/// An existing CA in DIR is never replaced without --force (every robot
/// provisioned with it would be locked out); --add-robots issues
/// certificates for more robots with it instead; --revoke K withdraws
/// robot K's certificate (a lost or stolen robot) and a running launch of
/// this lab on this host drops it at once.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Robots 1..=N get a certificate each.
    #[arg(long, required_unless_present = "revoke")]
    pub robots: Option<u32>,
    /// Output directory (created). A CA already there is kept: see --add-robots and --force.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Keep the CA in DIR (ca.pem, ca-key.pem) and every certificate there;
    /// make certificates and configs for the robots of 1..=N that have none,
    /// and update orchestrator.json5's ACL to all of them (restart the
    /// orchestrator with it).
    #[arg(long, conflicts_with = "force")]
    pub add_robots: bool,
    /// Make a new CA even though DIR holds one, replacing every certificate,
    /// key and config of the set (robots provisioned with the old CA are
    /// locked out; keep a copy of ca-key.pem first).
    #[arg(long)]
    pub force: bool,
    /// Host names / IP addresses robots reach the orchestrator at (its certificate's names).
    #[arg(long = "host", value_name = "NAME", default_values_t = ["localhost".to_string(), "127.0.0.1".to_string()])]
    pub hosts: Vec<String>,
    /// The orchestrator's listen endpoint: quic/HOST:PORT, or tls/HOST:PORT
    /// where UDP is blocked (zenoh's tls/ link can drop under traffic; see
    /// the README).
    #[arg(long, value_name = "ENDPOINT", default_value = "quic/0.0.0.0:7447")]
    pub listen: String,
    /// The endpoint robots connect to [default: the listen protocol, <first --host>:7447].
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Option<String>,
    /// Withdraw robot K's certificate (a lost or stolen robot; repeatable):
    /// orchestrator.json5's ACL in DIR denies it everything from the next
    /// launch on, and a launch of this host running with that config drops
    /// the robot at once (as `orchestrator revoke`). Nothing else changes.
    #[arg(long, value_name = "K", conflicts_with_all = ["add_robots", "force", "robots"])]
    pub revoke: Vec<u32>,
}

/// Asks every launch of this host that runs with the lab's `config` (a
/// launch of another lab answers that it is not) to revoke `ids` now
/// (`orchestrator/launch-core/src/revoke.rs`): the swarms that took it. Launches gone (a
/// lock file left by a killed one) are passed over.
fn revoke_live(config: &Path, ids: &[u32]) -> Vec<String> {
    let lab = std::fs::canonicalize(config).unwrap_or_else(|_| config.to_path_buf());
    let who = super::stop::who("orchestrator certs --revoke");
    let mut took = Vec::new();
    for &robot in ids {
        let why = "its certificate was revoked".to_owned();
        let ask = Ask::Revoke { robot, who: who.clone(), why, lab: Some(lab.clone()) };
        let reached = Asker::Local.ask(None, &ask).unwrap_or_default();
        for r in reached {
            match r.answer {
                Ok(Answer::Revoked { swarm, .. }) if !took.contains(&swarm) => took.push(swarm),
                Ok(Answer::Revoked { .. } | Answer::OtherLab) => {}
                Ok(other) => {
                    tracing::warn!("the launch of swarm {} answered the revocation: {other:?}", r.swarm);
                }
                Err(why) => tracing::debug!("the launch of swarm {} did not answer: {why}", r.swarm),
            }
        }
    }
    took
}

/// Certificates only for robots a launch can deploy (at most
/// [`MAX_ROBOTS`]): 100 000 robots took over a minute for files no launch
/// would ever use.
fn check_robots(robots: u32) -> Result<()> {
    if robots > MAX_ROBOTS {
        return Err(exit::usage(format!(
            "--robots {robots}: a launch deploys at most {MAX_ROBOTS} robots, so certificates for more \
             would never be used"
        )));
    }
    Ok(())
}

pub fn run(args: Args) -> Result<i32> {
    if !args.revoke.is_empty() {
        let config = revoke(&args.out, &args.revoke, "--out", "--revoke")?;
        let ids: Vec<String> = args.revoke.iter().map(u32::to_string).collect();
        let live = revoke_live(&config, &args.revoke);
        let applied = match live.as_slice() {
            [] => "no launch of this lab runs on this host; it applies from the next start".to_owned(),
            swarms => format!("taken live by the running launch of swarm {}", swarms.join(", ")),
        };
        bycoms_runtime::logging::status_line(&format!(
            "certs: robot {} revoked in {}: {applied}",
            ids.join(", "),
            config.display()
        ));
        return Ok(exit::SUCCESS);
    }
    let robots = args.robots.unwrap_or_default();
    check_robots(robots)?;
    let first = args.hosts.first().cloned().unwrap_or_else(|| "localhost".into());
    let proto = if args.listen.starts_with("tls/") { "tls" } else { "quic" };
    let connect = args.connect.unwrap_or_else(|| format!("{proto}/{first}:7447"));
    for (flag, endpoint) in [("--listen", &args.listen), ("--connect", &connect)] {
        if !bycoms_protocol::bus::zenoh::is_secured(endpoint) {
            return Err(exit::usage(format!(
                "{flag} {endpoint}: certificates are for secured endpoints, quic/HOST:PORT or tls/HOST:PORT"
            )));
        }
    }
    let plan =
        Plan { robots, hosts: args.hosts, listen: args.listen, connect, out: args.out, force: args.force };
    let (made, what) = match args.add_robots {
        true => (add_robots(&plan)?, "kept CA"),
        false => (generate(&plan)?, "CA"),
    };
    bycoms_runtime::logging::status_line(&format!(
        "certs: {what} {}, orchestrator config {}, {} new robot configs in {}",
        made.ca.display(),
        made.orchestrator_config.display(),
        made.robot_configs.len(),
        plan.out.display()
    ));
    Ok(exit::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn more_robots_than_a_launch_deploys_is_a_usage_error() {
        let e = check_robots(100_000).expect_err("too many");
        assert_eq!(exit::code_of(&e), exit::USAGE);
        assert!(e.to_string().contains("--robots 100000: a launch deploys at most 1000 robots"), "{e}");
        assert!(check_robots(MAX_ROBOTS).is_ok());
    }
}
