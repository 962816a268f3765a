//! `orchestrator status`: every running launch this host can see (or,
//! with `--connect`, every launch reachable over zenoh), as the launch
//! itself says it stands: swarm, clock, phase, each robot's state, last
//! pose and its age, recording, uptime.
//!
//! Why asked of the launch: its logs say what happened, not where it
//! stands; the launch answers from its core (`orchestrator/launch/src/status.rs`) over its
//! control socket or queryable (`orchestrator/launch/src/control.rs`). A launch whose lock
//! file no process holds, or that stopped answering, shows as gone.
//!
//! `--watch` redraws every `--interval` seconds until Ctrl-C (and says
//! which launches went away since the last look). Exit codes: 0 at least
//! one launch answered, 1 none runs.

use anyhow::Result;
use bycoms_launch::config::{check_endpoints, check_swarm};
use bycoms_launch::control::{Answer, Ask, Asker, Reached};
use bycoms_launch::status;
use bycoms_runtime::exit;
use bycoms_runtime::outln;
use std::collections::BTreeSet;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Shortest and longest redraw interval of `--watch`, s: the one range
/// of `--interval` (its clap parser, [`interval`]).
const INTERVAL_RANGE: (f64, f64) = (0.1, 60.0);

/// `--interval`'s value parser: seconds in [`INTERVAL_RANGE`].
fn interval(text: &str) -> Result<f64, String> {
    bycoms_runtime::seconds::seconds_between(text, INTERVAL_RANGE.0, INTERVAL_RANGE.1)
}

/// Show the running launches: phase, robots, poses, recording, uptime.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub which: Which,
    /// One JSON object per launch and line (`{"swarm", "status"}` or
    /// `{"swarm", "gone"}`); `[]` when no launch answers.
    #[arg(long)]
    pub json: bool,
    /// Redraw until Ctrl-C.
    #[arg(long)]
    pub watch: bool,
    /// Seconds between redraws of `--watch` (0.1 to 60).
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0, value_parser = interval)]
    pub interval: f64,
}

/// Which launches `status` and `stop` ask, and where: one set of flags
/// for both commands.
#[derive(Debug, clap::Args)]
pub struct Which {
    /// The launch's swarm (`stop`: needed when several launches run).
    #[arg(long, value_name = "NAME")]
    pub swarm: Option<String>,
    /// Ask launches on other hosts over zenoh, at this endpoint (a
    /// launch's `--listen`, or the lab's router).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Option<String>,
    /// zenoh JSON5 config read first (certificates; deploy/zenoh/).
    #[arg(long, value_name = "FILE.json5", requires = "connect")]
    pub zenoh_config: Option<PathBuf>,
}

impl Which {
    /// The flags checked (usage errors name them), and the asker they open.
    pub fn asker(&self) -> Result<Asker> {
        if let Some(s) = &self.swarm {
            check_swarm(s)?;
        }
        if let Some(c) = &self.connect {
            check_endpoints("--connect", std::slice::from_ref(c))?;
        }
        Asker::open(self.connect.as_deref(), self.zenoh_config.clone())
    }
}

pub fn run(args: Args) -> Result<i32> {
    let asker = args.which.asker()?;
    let stop = bycoms_launch::interrupt_flag();
    let mut seen = BTreeSet::new();
    let swarm = args.which.swarm.as_deref();
    loop {
        let reached = asker.ask(swarm, &Ask::Status)?;
        let answered = show(&reached, &seen, args.json)?;
        if answered == 0 && args.json {
            outln!("[]")?;
        }
        if !args.watch {
            if answered == 0 {
                anyhow::bail!("{}", none_answered(&asker, swarm)?);
            }
            return Ok(exit::SUCCESS);
        }
        seen = reached.iter().filter(|r| r.answer.is_ok()).map(|r| r.swarm.clone()).collect();
        if answered == 0 && !args.json {
            outln!("{}", none_answered(&asker, swarm)?)?;
        }
        let until = Instant::now() + Duration::from_secs_f64(args.interval);
        while Instant::now() < until {
            if stop.load(Ordering::SeqCst) {
                return Ok(exit::SUCCESS);
            }
            std::thread::sleep(
                Duration::from_millis(50).min(until.saturating_duration_since(Instant::now())),
            );
        }
        if !args.json {
            outln!("")?;
        }
    }
}

/// Prints what each launch said (and the launches gone since `before`);
/// how many answered.
fn show(reached: &[Reached], before: &BTreeSet<String>, json: bool) -> Result<usize> {
    let mut answered = 0;
    for r in reached {
        match &r.answer {
            Ok(Answer::Status(s)) => {
                answered += 1;
                if json {
                    outln!("{}", serde_json::json!({ "swarm": r.swarm, "status": s }))?;
                } else {
                    outln!("{}", status::text(s).trim_end())?;
                }
            }
            Ok(other) => outln!("swarm {}: an unexpected answer {other:?}", r.swarm)?,
            Err(why) if json => outln!("{}", serde_json::json!({ "swarm": r.swarm, "gone": why }))?,
            Err(why) => outln!("swarm {}: {why}", r.swarm)?,
        }
    }
    for gone in before.iter().filter(|s| !reached.iter().any(|r| &r.swarm == *s && r.answer.is_ok())) {
        if json {
            outln!("{}", serde_json::json!({ "swarm": gone, "gone": "its launch ended" }))?;
        } else {
            outln!("swarm {gone}: gone (its launch ended)")?;
        }
    }
    Ok(answered)
}

/// The swarms whose launches answer `asker` now, in swarm order.
pub fn running(asker: &Asker) -> Result<Vec<String>> {
    Ok(asker.ask(None, &Ask::Status)?.into_iter().filter(|r| r.answer.is_ok()).map(|r| r.swarm).collect())
}

/// Why no launch answered, in words: "no launch runs …", or, when
/// `swarm` was asked for, that none of that swarm runs (gone, or never
/// started) and which do.
pub fn none_answered(asker: &Asker, swarm: Option<&str>) -> Result<String> {
    let place = asker.place();
    if let Some(why) = asker.silenced() {
        return Ok(format!("{why} ({place})"));
    }
    let Some(swarm) = swarm else { return Ok(format!("no launch runs {place}")) };
    let none = format!("no launch of swarm {swarm:?} runs {place} (it ended, or never started)");
    Ok(match running(asker)?.as_slice() {
        [] => format!("{none}; no other runs either"),
        others => format!("{none}; running: {}", others.join(", ")),
    })
}
