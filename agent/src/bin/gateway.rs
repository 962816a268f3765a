//! `gateway`: one real robot's gateway (see `bycoms_agent::gateway`), with
//! `gateway bench` the gateway's added-latency figures, or with `agent
//! doctor` the checks of this host (`bycoms_runtime::doctor`). Thin `main`: parse,
//! run, exit code. The command line is the library's
//! (`bycoms_agent::gateway::cli::command`), shared with whoever starts a gateway
//! (`GatewayArgs::to_flags`).

use bycoms_agent::gateway::cli::{parse_from, AgentRun};

fn main() {
    let (log, run) = parse_from(std::env::args_os()).unwrap_or_else(|e| e.exit());
    bycoms_runtime::logging::init(log.log_format);
    match run {
        AgentRun::Bench(bench) => {
            bycoms_runtime::cli::quiet_iceoryx2();
            if let Err(e) = bycoms_agent::gateway::bench::run(&bench) {
                tracing::error!("{}", bycoms_runtime::logging::error_text(e.as_ref()));
                std::process::exit(1);
            }
        }
        AgentRun::Doctor(doctor) => {
            bycoms_runtime::cli::tune_zenoh_runtime();
            std::process::exit(doctor.main());
        }
        AgentRun::Gateway(gateway) => {
            bycoms_runtime::cli::tune_zenoh_runtime();
            std::process::exit(bycoms_agent::gateway::main_with(&gateway));
        }
    }
}
