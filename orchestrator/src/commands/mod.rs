//! Command-line interface: one file per subcommand.

use anyhow::Result;
use clap::{Parser, Subcommand};

pub mod bench;
pub mod bridge;
pub mod certs;
pub mod completions;
pub mod doctor;
pub mod draw;
pub mod launch;
pub mod merge;
pub mod record;
pub mod replay;
pub mod revoke;
pub mod simulate;
pub mod status;
pub mod stop;
pub mod sweep;
pub mod terrain;
pub mod world;

/// BYCOMS swarm orchestrator: simulate runs, generate terrains, reproduce the
/// paper's simulation study, and deploy robots as agent processes (`launch`).
///
/// Exit codes: 0 success (for `simulate` and `launch`: a robot reached the goal),
/// 1 error, 2 usage error, 3 the run ended without any robot arriving,
/// 130 interrupted (work done so far is kept).
#[derive(Debug, Parser)]
#[command(name = "orchestrator", version, about, long_about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// Logging flags (global: accepted after any subcommand).
    #[command(flatten)]
    pub log: bycoms_runtime::logging::LogArgs,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// One in-process run: summary, optional JSON, and an SVG snapshot.
    Simulate(simulate::Args),
    /// Generate terrains of a given minimum path width into a directory.
    Terrain(terrain::Args),
    /// The paper's study: success rate over ε × path width, with and without noise.
    Sweep(sweep::Args),
    /// Combine the CSVs of sharded sweeps into the same tables and heatmaps.
    Merge(merge::Args),
    /// Deploy robots one at a time as agent processes: iceoryx2 on one host, zenoh across hosts, real robots through gateways.
    Launch(Box<launch::Args>),
    /// Draw a recorded launch (FILE.mcap) as the snapshot picture (SVG).
    Draw(draw::Args),
    /// Tools for recordings: `record recover FILE` completes a recording cut short.
    Record(record::Args),
    /// Feed a recording's launch-core inputs to a new core; exit 1 unless it makes the recorded decisions.
    Replay(replay::Args),
    /// Measure the process layer: gate reaction, lockstep speed, real-time scale.
    Bench(bench::Args),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell) on stdout.
    Completions(completions::Args),
    /// Republish a local iceoryx2 swarm on zenoh, to watch a launch from another host.
    Bridge(bridge::Args),
    /// Make a lab CA, orchestrator and robot certificates, and zenoh configs with the ACL.
    Certs(certs::Args),
    /// Show every running launch this host (or, with --connect, zenoh) can see: phase, robots, poses, uptime.
    ///
    /// As the launch itself answers; a launch that died shows as gone. Exit codes: 0 at least
    /// one launch answered (also when Ctrl-C ends --watch), 1 none runs, 2 usage.
    Status(status::Args),
    /// Stop a running launch from another terminal or host: gracefully, or --now every robot at once.
    ///
    /// The launch records who asked and why in its summary (`stop`) and exits 130. Exit codes:
    /// 0 the launch said it stops, 1 no launch answered, 2 usage (several run and --swarm is missing).
    Stop(stop::Args),
    /// Take a robot's voice away in a running launch, within a second and without a restart.
    ///
    /// The launch tells robot K `Stop`, refuses its agent (a new registration is refused as
    /// revoked) and drops and counts its reports; the other robots go on. With --certs DIR the
    /// lab's ACL also denies K everything from the next start (zenoh checks no revocation list,
    /// so until then K's certificate still connects: the launch drops its traffic). Exit codes:
    /// 0 the launch took it, 1 no launch answered or it refused, 2 usage.
    Revoke(revoke::Args),
    /// Check this host before a lab day: certificates, limits, ports, leftovers, NatNet, zenoh.
    ///
    /// Each finding names its check, its level (ok, warn, error), its cause
    /// and its fix. Exit 0 when nothing is an error, 1 when something is, 2
    /// on a usage error. Checks of this host: the certificates in --certs DIR
    /// (chain, common names, expiry: a warning under 30 days; the ACL names
    /// every robot), the open-files and memory limits for the planned robot
    /// count, the gateways' UDP ports of the config's robots file free,
    /// iceoryx2 files of dead swarms (--clean removes them), and the NatNet
    /// server answering when the config's [mocap] source is natnet. With
    /// --connect: the orchestrator's zenoh endpoint reached as a robot's
    /// host would, its liveliness seen (--swarm) and this host's clock
    /// offset to it. A robot's host without this binary runs the same
    /// checks with `gateway doctor` or `sim-agent doctor`.
    Doctor(doctor::Args),
    /// Run one simulated robot (what `launch` starts when no `sim-agent` binary sits next to it).
    #[command(hide = true)]
    SimAgent(bycoms_sim_agent::AgentArgs),
}

/// Runs the parsed command; returns the process exit code.
pub fn run(cli: Cli) -> Result<i32> {
    tracing::debug!(version = env!("CARGO_PKG_VERSION"), command = ?cli.command, "orchestrator starts");
    match cli.command {
        Command::Simulate(args) => simulate::run(args),
        Command::Terrain(args) => terrain::run(args),
        Command::Sweep(args) => sweep::run(args),
        Command::Merge(args) => merge::run(args),
        Command::Launch(args) => launch::run(*args),
        Command::Draw(args) => draw::run(args),
        Command::Record(args) => record::run(args),
        Command::Replay(args) => replay::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Completions(args) => completions::run(&args, <Cli as clap::CommandFactory>::command()),
        Command::Bridge(args) => bridge::run(args),
        Command::Certs(args) => certs::run(args),
        Command::Status(args) => status::run(args),
        Command::Stop(args) => stop::run(args),
        Command::Revoke(args) => revoke::run(args),
        Command::Doctor(args) => doctor::run(args),
        Command::SimAgent(args) => Ok(bycoms_sim_agent::main_with(&args)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_launch::setup::{joining, run_settings};
    use bycoms_launch::{LaunchConfig, World};
    use bycoms_sim_agent::options::{parse_from, SimAgentRun};

    /// `orchestrator sim-agent` (what a launch runs when no `sim-agent`
    /// binary sits beside it) reads an agent's flags as `sim-agent` does.
    #[test]
    fn the_hidden_sim_agent_reads_the_flags_a_launch_passes_as_sim_agent_does() {
        let cfg = LaunchConfig { eps: 0.1 + 0.2, seed: 7, noise: true, ..LaunchConfig::default() };
        let args = joining(&cfg, "s".into(), Vec::new()).sim_agent(2, &run_settings(&cfg, &World::tiny()));
        let flags = args.to_flags();
        let here = Cli::try_parse_from(
            ["orchestrator", "sim-agent"].map(String::from).into_iter().chain(flags.clone()),
        )
        .expect("orchestrator sim-agent parses");
        let Command::SimAgent(here) = here.command else { panic!("not sim-agent") };
        let Ok((_, SimAgentRun::Robot(there))) =
            parse_from(std::iter::once("sim-agent".to_string()).chain(flags))
        else {
            panic!("sim-agent parses")
        };
        assert_eq!(here, args);
        assert_eq!(there, args);
    }
}
