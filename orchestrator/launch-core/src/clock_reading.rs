//! One robot's measured clock offset, as the core keeps it (`clocks.rs`
//! says what it means and how it is judged).

use serde::{Deserialize, Serialize};

pub use bycoms_protocol::clock_limits::{ClockLimits, ClockVerdict};

/// One robot's last measured clock offset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClockReading {
    /// Its host's clock minus the orchestrator's, µs.
    pub offset_us: i64,
    /// The round trip of the measurement, µs.
    pub round_trip_us: u32,
    /// When it was reported, µs of launch time.
    pub at_us: u64,
}
