//! `sim-agent`: one simulated BYCOMS robot as its own process (see
//! `bycoms_sim_agent`), with `sim-agent lab …` the emulated lab
//! of real robots (see `bycoms_lab::process`), or with `sim-agent
//! doctor` the checks of this host (`bycoms_runtime::doctor`). Thin `main`: parse, run,
//! exit code. The command line is the library's
//! (`bycoms_sim_agent::options::command`), shared with whoever
//! starts a `sim-agent` (`AgentArgs::to_flags`, `LabArgs::to_args`).

use bycoms_sim_agent::options::{parse_from, SimAgentRun};

fn main() {
    let (log, run) = parse_from(std::env::args_os()).unwrap_or_else(|e| e.exit());
    bycoms_runtime::logging::init(log.log_format);
    bycoms_runtime::cli::tune_zenoh_runtime();
    let code = match run {
        SimAgentRun::Lab(lab) => bycoms_lab::process::main_with(&lab),
        SimAgentRun::Robot(agent) => bycoms_sim_agent::main_with(&agent),
        SimAgentRun::Doctor(doctor) => doctor.main(),
    };
    std::process::exit(code);
}
