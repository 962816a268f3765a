//! The emulated lab of the paper's experiments (§VI): the physical world
//! around real-robot firmware, so the whole real-robot path runs and is
//! tested without hardware.
//!
//! * [`sound`] — each speaker's tone at each microphone, falling with
//!   distance, with wall echoes, motor vibration and ADC noise, sampled as
//!   the robot's ADC would;
//! * [`characterise`] — gradient direction error and V_ave against distance
//!   to a speaker (`cargo bench -p bycoms-sim --bench lab_sensing` prints it).
//!
//! Status: the crawler bodies, the scenarios (`deploy/lab/`) and the
//! emulated ESP32s behind UDP sockets are in [`body`], [`scenario`] and
//! [`esp32`] as far as they exist; see each module's doc.

pub mod body;
pub mod characterise;
pub mod esp32;
pub mod scenario;
pub mod sound;
pub mod world;

#[cfg(test)]
mod tests;
