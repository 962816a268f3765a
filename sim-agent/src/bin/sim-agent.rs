//! `sim-agent`: one simulated BYCOMS robot as its own process (see
//! `bycoms_sim::agent_process`), or with `sim-agent lab …` the emulated lab
//! of real robots (see `bycoms_sim::lab::process`). Thin `main`: parse, run,
//! exit code.
//!
//! Why `lab` is dispatched by hand: the robot's flags are required and
//! flattened at the top level (the orchestrator spawns `sim-agent --swarm …
//! --robot …`), which clap cannot mix with a subcommand that has other
//! required flags; the first argument decides.

use bycoms_sim::agent_process::{main_with, AgentArgs};
use bycoms_sim::lab::process::LabArgs;
use clap::Parser;

#[derive(Parser)]
#[command(name = "sim-agent", version, about, long_about)]
struct Cli {
    #[command(flatten)]
    agent: AgentArgs,
    #[command(flatten)]
    log: bycoms_logging::LogArgs,
}

/// The emulated lab: one emulated ESP32 per robot behind its own UDP
/// socket, crawler bodies, sound, and true poses on the bus as simulated
/// motion capture.
#[derive(Parser)]
#[command(name = "sim-agent lab", version)]
struct LabCli {
    #[command(flatten)]
    lab: LabArgs,
    #[command(flatten)]
    log: bycoms_logging::LogArgs,
}

fn main() {
    let mut args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    if args.get(1).is_some_and(|a| a == "lab") {
        args.remove(1);
        let cli = LabCli::parse_from(args);
        bycoms_logging::init(cli.log.log_format);
        bycoms_sim::agent_process::cli::tune_zenoh_runtime();
        std::process::exit(bycoms_sim::lab::process::main_with(&cli.lab));
    }
    let cli = Cli::parse_from(args);
    bycoms_logging::init(cli.log.log_format);
    bycoms_sim::agent_process::cli::tune_zenoh_runtime();
    std::process::exit(main_with(&cli.agent));
}
