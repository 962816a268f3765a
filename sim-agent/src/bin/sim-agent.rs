//! `sim-agent`: one simulated BYCOMS robot as its own process (see
//! `bycoms_sim::agent_process`), or with `sim-agent lab …` the emulated lab
//! of real robots (see `bycoms_sim::lab::process`). Thin `main`: parse, run,
//! exit code.
//!
//! The robot's flags stay at the top level (the orchestrator spawns
//! `sim-agent --swarm … --robot …`) next to the `lab` subcommand: one clap
//! command where a subcommand lifts the top level's required flags
//! (`subcommand_negates_reqs`) and the two exclude each other
//! (`args_conflicts_with_subcommands`), so `--help` lists `lab` and
//! `sim-agent lab --help` has the lab's own usage line. The command is
//! assembled from the argument structs rather than derived as one struct:
//! clap's derive cannot leave out a flattened struct that itself flattens
//! another (the robot's failsafe flags) when the subcommand is used.

use bycoms_logging::LogArgs;
use bycoms_sim::agent_process::{main_with, AgentArgs};
use bycoms_sim::lab::process::LabArgs;
use clap::{Args, Command, FromArgMatches};

/// The whole command line: the robot's flags, the logging flags, `lab`.
/// (The about lines are set last: `augment_args` applies each struct's doc
/// comment as the command's about.)
fn command() -> Command {
    let lab = LabArgs::augment_args(Command::new("lab"));
    let top = Command::new("sim-agent")
        .args_conflicts_with_subcommands(true)
        .subcommand_negates_reqs(true)
        .subcommand(lab);
    LogArgs::augment_args(AgentArgs::augment_args(top))
        .version(env!("CARGO_PKG_VERSION"))
        .about(env!("CARGO_PKG_DESCRIPTION"))
        .long_about(None::<&str>)
}

/// The value, or clap's error (with this command's usage) and exit 2.
fn parsed<T>(result: Result<T, clap::Error>) -> T {
    result.unwrap_or_else(|e| e.format(&mut command()).exit())
}

fn main() {
    let matches = command().get_matches();
    let log: LogArgs = parsed(LogArgs::from_arg_matches(&matches));
    bycoms_logging::init(log.log_format);
    bycoms_sim::agent_process::cli::tune_zenoh_runtime();
    let code = match matches.subcommand() {
        Some(("lab", lab)) => bycoms_sim::lab::process::main_with(&parsed(LabArgs::from_arg_matches(lab))),
        _ => main_with(&parsed(AgentArgs::from_arg_matches(&matches))),
    };
    std::process::exit(code);
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_command_is_consistent() {
        super::command().debug_assert();
    }
}
