//! Wire types and identifiers shared by every BYCOMS process.
//!
//! The core is `no_std` so the same types compile into ESP32 firmware. For now
//! it holds the identifiers the simulator needs; the messages, the
//! encode/decode pair and the bus arrive with the processes work (roadmap 2).
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]

pub mod ids;

pub use ids::RobotId;
