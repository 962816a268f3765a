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
mod foxglove_recording;
mod gateway_lab;
mod lab_launch;
mod launch_report;
mod live_view;
mod netns_liveliness;
mod netns_remote;
mod parity;
mod recording;
mod remote_agents;
mod replay;
mod same_swarm;
mod secure_launch;
mod soak;
mod supervision;
mod watch_decoder;
