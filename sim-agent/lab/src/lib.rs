//! The emulated lab of the paper's experiments (§VI): the physical world
//! around real-robot firmware, so the whole real-robot path runs and is
//! tested without hardware.
//!
//! * [`sound`] — each speaker's tone at each microphone, falling with
//!   distance, with wall echoes, motor vibration and ADC noise, sampled as
//!   the robot's ADC would; calibrated so V_ave = V_target 0.5 m from a
//!   lone speaker;
//! * [`body`] — crawler bodies: differential drive with saturation and lag,
//!   stuck on contact with a frame or another body;
//! * [`ros2_body`] — a ROS 2 ground robot's body: `cmd_vel` (v, ω) with
//!   latency, wheel limits, seeded slip and its driver's timeout, colliding
//!   as the crawler does;
//! * [`scenario`] — lab scenario files (`deploy/lab/`, `exp-short` and
//!   `exp-long` built in);
//! * [`esp32`] — one emulated ESP32: the firmware core behind its own UDP
//!   socket (port 0);
//! * [`world`] — the lab clock tying them together, with the emulated
//!   operator who places a robot at the start when it is first enabled;
//! * [`characterise`] — gradient direction error and V_ave against distance
//!   to a speaker (`cargo bench -p bycoms-lab --bench lab_sensing`), and
//!   [`sensing_plot`] its picture;
//! * [`robots`] — the robots file (`deploy/lab/robots.toml`): each robot's
//!   UDP address, its gateway's, its key file;
//! * [`process`] (feature `process`) — `sim-agent lab`: the lab as a
//!   process, paced at `--speed`, publishing true poses on the bus as
//!   simulated motion capture;
//! * [`cmd_vel`] (feature `process`) — `sim-agent lab --ros2-router`:
//!   the ROS 2 robots' `cmd_vel` over rmw_zenoh, handed to their bodies;
//! * [`natnet_out`] (feature `process`) — `sim-agent lab --natnet ADDR`:
//!   the bodies served by NatNet (OptiTrack's format) instead.
//!
//! Why a crate of its own: the lab is a world of its own (sound, crawlers,
//! the firmware core), not the paper's point robots; it uses the simulated
//! world only for the terrain's size limit and the NatNet server
//! (`bycoms_natnet_server`) for `--natnet`, and the firmware's host replay
//! (`agent/firmware-qemu/host`) uses it without any process or bus.
//!
//! In-process tests run the experiments with a test gateway standing in for
//! the `gateway` and the orchestrator (`tests/udp.rs`); `tests/` at
//! the workspace root runs them through the real processes.

pub mod arena;
pub mod body;
pub mod characterise;
#[cfg(feature = "process")]
pub mod cmd_vel;
pub mod esp32;
#[cfg(feature = "process")]
pub mod natnet_out;
#[cfg(feature = "process")]
pub mod process;
pub mod robots;
pub mod ros2_body;
pub mod scenario;
pub mod sensing_plot;
pub mod sound;
pub mod world;

#[cfg(test)]
mod tests;
