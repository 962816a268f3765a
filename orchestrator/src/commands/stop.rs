//! `orchestrator stop`: ends a running launch from another terminal (this
//! host's launches) or another host (`--connect`, over zenoh).
//!
//! Why a command and not a signal: a signal reaches only a process of this
//! host whose pid one knows, and says neither who nor why. The stop is
//! asked of the launch itself (`orchestrator/launch/src/control.rs`), which takes it as one
//! input of its core (`orchestrator/launch-core/src/stop.rs`): graceful, it ends as after
//! Ctrl-C; `--now`, every running robot is told `Stop` at once first. The
//! launch records who asked and why in its summary and events.
//!
//! Exit codes: 0 the launch said it stops; 1 no launch answered (none
//! runs, or it died); 2 a usage error (several launches and no `--swarm`).

use anyhow::Result;
use bycoms_launch::control::{Answer, Ask, Asker};
use bycoms_runtime::exit;
use bycoms_runtime::outln;

/// Stop a running launch: gracefully (as Ctrl-C) or every robot at once.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Tell every running robot `Stop` at once, then end the launch: a moving
    /// robot that answers stands where it stopped, a beacon (its summary
    /// says `end: stopped`, its position is in `beacons`); without it the
    /// launch ends as after Ctrl-C (a moving robot: `end: moving`).
    #[arg(long)]
    pub now: bool,
    #[command(flatten)]
    pub which: super::status::Which,
    /// Why, recorded in the launch's summary with who asked (at most 200 characters).
    #[arg(long, value_name = "TEXT", default_value = "")]
    pub why: String,
}

/// `--why` within the launch's bound: a usage error, before any launch is
/// asked, naming the flag and the length given.
pub fn check_why(why: &str) -> Result<()> {
    bycoms_launch::control::check_why(why).map_err(exit::usage)
}

/// Who asks, in words: user id, host and pid.
pub fn who(command: &str) -> String {
    use std::os::unix::fs::MetadataExt;
    let uid = std::fs::metadata("/proc/self").map(|m| m.uid().to_string()).unwrap_or_else(|_| "?".into());
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_default();
    format!("{command} (uid {uid} on {}, pid {})", host.trim(), std::process::id())
}

/// The one launch a command that acts on a launch means: the one named
/// with `--swarm`, or the only one running (a usage error when several
/// run and none is named; an error when none runs).
pub fn one_launch(asker: &Asker, swarm: Option<&str>) -> Result<String> {
    if let Some(s) = swarm {
        return Ok(s.to_owned());
    }
    match super::status::running(asker)?.as_slice() {
        [] => anyhow::bail!("{}", super::status::none_answered(asker, None)?),
        [one] => Ok(one.clone()),
        many => Err(exit::usage(format!(
            "{} launches run {} ({}): pick one with --swarm",
            many.len(),
            asker.place(),
            many.join(", ")
        ))),
    }
}

pub fn run(args: Args) -> Result<i32> {
    check_why(&args.why)?;
    let asker = args.which.asker()?;
    let swarm = one_launch(&asker, args.which.swarm.as_deref())?;
    let ask = Ask::Stop { now: args.now, who: who("orchestrator stop"), why: args.why.clone() };
    let reached = asker.ask(Some(&swarm), &ask)?;
    let Some(r) = reached.into_iter().next() else {
        anyhow::bail!("{}", super::status::none_answered(&asker, Some(&swarm))?);
    };
    match r.answer {
        Ok(Answer::Stopping { swarm, now, told, answered, slowest_us, recording, pid }) => {
            let how = match (now, slowest_us) {
                (false, _) => "the launch winds down".to_string(),
                (true, Some(us)) => format!(
                    "{answered} of {told} robots said they stopped (the last after {:.1} ms); the launch ends",
                    us as f64 / 1000.0
                ),
                (true, None) => format!("{answered} of {told} robots said they stopped; the launch ends"),
            };
            outln!("stopping swarm {swarm} (orchestrator pid {pid}): {how}")?;
            if let Some(path) = recording {
                outln!("its recording: {path}")?;
            }
            Ok(exit::SUCCESS)
        }
        Ok(Answer::Refused(why)) => anyhow::bail!("the launch of swarm {swarm:?} refused: {why}"),
        Ok(other) => anyhow::bail!("the launch of swarm {swarm:?} answered something else: {other:?}"),
        Err(why) => anyhow::bail!("the launch of swarm {swarm:?} did not answer: {why}"),
    }
}
