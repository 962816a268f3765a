//! `orchestrator`: the commands BYCOMS users run.
//!
//! A thin `main` (ripgrep style): parse the command line, run one
//! subcommand, turn its result into an explicit exit code. Each subcommand
//! lives in its own file under `commands/`.

use bycoms_orchestrator::commands;
use bycoms_runtime::exit;
use clap::Parser;

fn main() {
    let cli = commands::Cli::parse();
    bycoms_runtime::logging::init(cli.log.log_format);
    bycoms_runtime::cli::tune_zenoh_runtime();
    let code = match commands::run(cli) {
        Ok(code) => code,
        Err(err) => {
            tracing::error!("{}", exit::message(&err));
            exit::code_of(&err)
        }
    };
    std::process::exit(code);
}
