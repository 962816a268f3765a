//! `sim-agent`: one simulated BYCOMS robot as its own process (see
//! `bycoms_sim::agent_process`). Thin `main`: parse, run, exit code.

use bycoms_sim::agent_process::{main_with, AgentArgs};
use clap::Parser;

#[derive(Parser)]
#[command(name = "sim-agent", version, about, long_about)]
struct Cli {
    #[command(flatten)]
    agent: AgentArgs,
    #[command(flatten)]
    log: bycoms_logging::LogArgs,
}

fn main() {
    let cli = Cli::parse();
    bycoms_logging::init(cli.log.log_format);
    std::process::exit(main_with(&cli.agent));
}
