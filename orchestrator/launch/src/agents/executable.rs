//! Which executable runs the agents, and where the workspace's sibling
//! binaries sit: the one lookup of the agent and gateway executables
//! (`agent_command`, `gateway_command`, `ros2_robot_command`).
//!
//! Why a file of its own: the launch command, the benches and the choice of
//! agents (`choice.rs`) all look executables up, and none of them may use
//! `orchestrator/launch/src/lib.rs`, which uses them (no file cycles).

use super::spawned::AgentCommand;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// Environment variable naming the agent executable.
pub const AGENT_BIN_ENV: &str = "BYCOMS_SIM_AGENT";

/// Which executable runs the agents: `explicit` (the `--agent-bin` flag),
/// else `$BYCOMS_SIM_AGENT`, else `configured` (the config file), else
/// `sim-agent` next to this executable, else this executable itself as
/// `orchestrator sim-agent` (so `cargo run --bin orchestrator`, which builds
/// no other binary, still works).
pub fn agent_command(explicit: Option<&Path>, configured: Option<&Path>) -> Result<AgentCommand> {
    let chosen = explicit
        .map(Path::to_path_buf)
        .or_else(|| std::env::var_os(AGENT_BIN_ENV).map(PathBuf::from))
        .or_else(|| configured.map(Path::to_path_buf));
    if let Some(program) = chosen {
        return Ok(AgentCommand { program, prefix: Vec::new(), own: false });
    }
    let (me, beside) = beside_this_executable("sim-agent")?;
    if beside.is_file() {
        return Ok(AgentCommand { program: beside, prefix: Vec::new(), own: true });
    }
    Ok(AgentCommand { program: me, prefix: vec!["sim-agent".into()], own: true })
}

/// This executable, and where a sibling binary `name` of the workspace
/// would sit next to it (`cargo build` puts them together): the one lookup
/// of the agent and gateway executables.
fn beside_this_executable(name: &str) -> Result<(PathBuf, PathBuf)> {
    let me = std::env::current_exe().context("cannot locate the orchestrator executable")?;
    let beside = me.with_file_name(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    Ok((me, beside))
}

/// The gateway executable: `explicit`, else `gateway` next to this executable.
pub fn gateway_command(explicit: Option<&Path>) -> Result<AgentCommand> {
    robot_agent_command(explicit, "gateway", "bycoms-agent", "agents.gateway_bin")
}

/// The ROS 2 robot agent's executable: `explicit`, else `ros2-robot` next
/// to this executable.
pub fn ros2_robot_command(explicit: Option<&Path>) -> Result<AgentCommand> {
    robot_agent_command(explicit, "ros2-robot", "bycoms-ros2-robot", "agents.ros2_robot_bin")
}

/// A real robot's agent executable `name` (of crate `package`, set by
/// config key `key`): `explicit`, else next to this executable.
fn robot_agent_command(
    explicit: Option<&Path>,
    name: &str,
    package: &str,
    key: &str,
) -> Result<AgentCommand> {
    if let Some(program) = explicit {
        return Ok(AgentCommand { program: program.to_path_buf(), prefix: Vec::new(), own: false });
    }
    let (me, beside) = beside_this_executable(name)?;
    anyhow::ensure!(
        beside.is_file(),
        "no {name} executable: `{name}` is not next to {} (build it with `cargo build -p {package}`, \
         or set {key})",
        me.display()
    );
    Ok(AgentCommand { program: beside, prefix: Vec::new(), own: false })
}
