//! `agent`: one real robot's gateway (see `bycoms_gateway`), or with
//! `agent bench` the gateway's added-latency figures. Thin `main`.
//!
//! Why `bench` is dispatched by hand: the gateway's flags are required and
//! flattened at the top level (launchers spawn `agent --swarm … --robot …`,
//! as they spawn `sim-agent`), which clap cannot mix with a subcommand.

use bycoms_gateway::bench::BenchArgs;
use bycoms_gateway::{main_with, GatewayArgs};
use clap::Parser;

#[derive(Parser)]
#[command(name = "agent", version, about, long_about)]
struct Cli {
    #[command(flatten)]
    gateway: GatewayArgs,
    #[command(flatten)]
    log: bycoms_logging::LogArgs,
}

/// Measure the gateway's added latency: robot frame in → bus message out.
#[derive(Parser)]
#[command(name = "agent bench", version)]
struct BenchCli {
    #[command(flatten)]
    bench: BenchArgs,
    #[command(flatten)]
    log: bycoms_logging::LogArgs,
}

fn main() {
    let mut args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    if args.get(1).is_some_and(|a| a == "bench") {
        args.remove(1);
        let cli = BenchCli::parse_from(args);
        bycoms_logging::init(cli.log.log_format);
        bycoms_sim::agent_process::cli::quiet_iceoryx2();
        if let Err(e) = bycoms_gateway::bench::run(&cli.bench) {
            tracing::error!("{}", bycoms_logging::error_text(e.as_ref()));
            std::process::exit(1);
        }
        return;
    }
    let cli = Cli::parse_from(args);
    bycoms_logging::init(cli.log.log_format);
    bycoms_sim::agent_process::cli::tune_zenoh_runtime();
    std::process::exit(main_with(&cli.gateway));
}
