//! `ros2-robot`: one ROS 2 ground robot's BYCOMS agent (see
//! `bycoms_ros2_robot`). Thin `main`: parse, run, exit code. The command
//! line is the library's (`bycoms_ros2_robot::cli`), shared with whoever
//! starts the agent (`Ros2RobotArgs::to_flags`).

fn main() {
    let command = bycoms_ros2_robot::cli::parse_from(std::env::args_os()).unwrap_or_else(|e| e.exit());
    bycoms_runtime::logging::init(command.log.log_format);
    bycoms_runtime::cli::tune_zenoh_runtime();
    std::process::exit(bycoms_ros2_robot::cli::main_with(&command.robot));
}
