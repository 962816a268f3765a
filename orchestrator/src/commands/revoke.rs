//! `orchestrator revoke`: takes one robot's voice away in a running launch,
//! without a restart (issue 34), and with `--certs DIR` in the lab's ACL
//! for the next start.
//!
//! Why both: zenoh checks no certificate revocation list, and a running
//! zenoh router keeps the access-control list it started with, so a robot
//! whose certificate was withdrawn (`certs --revoke`) still connects over
//! QUIC until the orchestrator restarts. The launch itself therefore drops
//! the robot (`orchestrator/launch-core/src/revoke.rs`): asked over the same control channel
//! as `status` and `stop` (`orchestrator/launch/src/control.rs`), it tells the robot `Stop`,
//! refuses its agent and drops (and counts) its reports from then on; the
//! others go on. The answer says how long the launch took, from here.
//!
//! Exit codes: 0 the launch took it; 1 no launch answered or it refused
//! (the ACL, with `--certs`, is rewritten all the same); 2 a usage error
//! (robot 0, a robot outside the certificates, several launches and no
//! `--swarm`).

use super::stop::{check_why, one_launch, who};
use anyhow::Result;
use bycoms_launch::control::{Answer, Ask};
use bycoms_runtime::exit;
use bycoms_runtime::outln;
use std::path::PathBuf;
use std::time::Instant;

/// Take a robot's voice away in a running launch: told `Stop`, its agent
/// refused, its reports dropped and counted.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The robot (its id, from 1).
    #[arg(long, value_name = "K")]
    pub robot: u32,
    #[command(flatten)]
    pub which: super::status::Which,
    /// The lab's certificates (`orchestrator certs --out DIR`): its
    /// orchestrator.json5's ACL denies robot K everything from the next
    /// start on.
    #[arg(long, value_name = "DIR")]
    pub certs: Option<PathBuf>,
    /// Why, recorded in the launch's summary with who asked (at most 200 characters).
    #[arg(long, value_name = "TEXT", default_value = "")]
    pub why: String,
}

pub fn run(args: Args) -> Result<i32> {
    let robot = args.robot;
    if robot == 0 {
        return Err(exit::usage("--robot 0: robots are numbered from 1"));
    }
    check_why(&args.why)?;
    // The ACL first: a robot outside the lab's certificates is a usage
    // error before any launch is asked.
    let acl = match &args.certs {
        Some(dir) => {
            let config = crate::certs::revoke(dir, &[robot], "--certs", "--robot")?;
            let said = format!(
                "the ACL of {} now denies robot {robot} everything from the next start",
                config.display()
            );
            bycoms_runtime::logging::status_line(&format!("revoke: {said}"));
            Some(said)
        }
        None => None,
    };
    // An error from here on still says what was done to the ACL (and
    // exits as it would without it).
    let with_acl = |e: anyhow::Error| match &acl {
        Some(said) => {
            let text = format!("{}; {said}", exit::message(&e));
            if exit::code_of(&e) == exit::USAGE {
                exit::usage(text)
            } else {
                anyhow::anyhow!(text)
            }
        }
        None => e,
    };
    ask_launch(&args, robot).map_err(with_acl)
}

/// Asks the launch (the one `--swarm` names, or the only one running) to
/// revoke `robot`, and says its answer.
fn ask_launch(args: &Args, robot: u32) -> Result<i32> {
    let asker = args.which.asker()?;
    let swarm = one_launch(&asker, args.which.swarm.as_deref())?;
    let ask = Ask::Revoke { robot, who: who("orchestrator revoke"), why: args.why.clone(), lab: None };
    let asked = Instant::now();
    let reached = asker.ask(Some(&swarm), &ask)?;
    let took_ms = asked.elapsed().as_secs_f64() * 1e3;
    let Some(r) = reached.into_iter().next() else {
        anyhow::bail!("{}", super::status::none_answered(&asker, Some(&swarm))?);
    };
    match r.answer {
        Ok(Answer::Revoked { swarm, robot, told, already, pid }) => {
            let what = match (already, told) {
                (true, _) => "it was revoked already",
                (false, true) => "told to stop and its agent to end; its reports are dropped from now on",
                (false, false) => "its agent was not running; its reports are dropped from now on",
            };
            outln!(
                "robot {robot} revoked in swarm {swarm} (orchestrator pid {pid}), answered in {took_ms:.1} ms: {what}"
            )?;
            Ok(exit::SUCCESS)
        }
        Ok(Answer::Refused(why)) => anyhow::bail!("the launch of swarm {swarm:?} refused: {why}"),
        Ok(other) => anyhow::bail!("the launch of swarm {swarm:?} answered something else: {other:?}"),
        Err(why) => anyhow::bail!("the launch of swarm {swarm:?} did not answer: {why}"),
    }
}
