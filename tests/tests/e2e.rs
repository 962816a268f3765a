//! Every end-to-end test of the project, as one test binary.
//!
//! Why one binary: each file here used to be its own test target, and
//! each target compiled and linked its own copy of everything it used
//! (the orchestrator, zenoh, iceoryx2): about a minute and a half of a
//! fresh CI build on two cores for twenty binaries. As modules of one
//! binary they compile and link once, and the test runner fills both
//! threads across what used to be binary boundaries. Run one file's tests
//! with `cargo test -p bycoms-tests --test e2e remote_agents::`.
//! A new file here is added as a module below (`autotests = false`).

mod bad_traffic;
mod bridge_watch;
mod closed_output;
mod deploy_files;
mod docs;
mod foxglove_recording;
mod gateway_lab;
mod lab_day;
mod lab_launch;
mod launch_report;
mod live_view;
mod manifests;
mod netns_bridge_host;
mod netns_doctor;
mod netns_liveliness;
mod netns_remote;
mod parity;
mod readme_commands;
mod recording;
mod remote_agents;
mod replay;
mod ros2_launch;
mod ros2_robot;
mod same_swarm;
mod secure_launch;
mod slurm;
mod soak;
mod supervision;
mod watch_decoder;

/// A swarm's lock file (`/dev/shm/bycoms-swarm….lock`) and the launch's
/// control socket beside it (`….sock`), removed on drop: a launch removes
/// its own when it ends, but not one killed by SIGKILL (its lock, an
/// `flock`, went with it; the files stay). A test that kills an
/// orchestrator holds one, so it leaves nothing in shared memory.
pub struct SwarmLockFile(std::path::PathBuf);

impl SwarmLockFile {
    /// The lock file of swarm `swarm` (under this process's bus tag).
    pub fn of(swarm: &str) -> Self {
        use bycoms_launch::swarm_lock::{lock_dir, lock_name};
        let tag = bycoms_protocol::bus::ipc::root::tag_from_env();
        SwarmLockFile(lock_dir().join(lock_name(tag.as_deref(), swarm)))
    }
}

impl Drop for SwarmLockFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
        let _ = std::fs::remove_file(self.0.with_extension("sock"));
    }
}
