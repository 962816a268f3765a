//! The one conversion of a shell's wall clock into a sans-IO core's time:
//! [`Micros`] since an [`Epoch`] the shell picks.
//!
//! Why one helper: every core ([`bycoms_protocol::SansIo`]) takes time as
//! whole microseconds and never reads a clock; every shell around one (the
//! gateway's loop, the ROS 2 robot's, `sim-agent`'s) turns its `Instant`s
//! into that time and the core's deadlines back into instants to wait for.
//! Written once here, the rounding is the same in every shell: an instant
//! is truncated to its whole microsecond (a core's "now" is never later
//! than the wall clock's), and an instant before the epoch is the epoch.

use bycoms_protocol::Micros;
use std::time::{Duration, Instant};

/// The instant a shell's core time counts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Epoch(Instant);

impl Epoch {
    /// An epoch at this very instant.
    pub fn now() -> Self {
        Self(Instant::now())
    }

    /// An epoch at `at`.
    pub fn at(at: Instant) -> Self {
        Self(at)
    }

    /// The instant it counts from.
    pub fn start(&self) -> Instant {
        self.0
    }

    /// The core time of `at`: whole µs since the epoch (0 before it,
    /// saturating at `u64::MAX`).
    pub fn micros(&self, at: Instant) -> Micros {
        micros_of(at.saturating_duration_since(self.0))
    }

    /// The core time now.
    pub fn elapsed(&self) -> Micros {
        self.micros(Instant::now())
    }

    /// The wall instant of core time `at`.
    pub fn instant(&self, at: Micros) -> Instant {
        self.0 + Duration::from_micros(at)
    }

    /// How long from now until core time `at` (zero once it is past).
    pub fn until(&self, at: Micros) -> Duration {
        self.instant(at).saturating_duration_since(Instant::now())
    }
}

/// Whole microseconds of `d`, truncated (saturating at `u64::MAX`).
pub fn micros_of(d: Duration) -> Micros {
    u64::try_from(d.as_micros()).unwrap_or(u64::MAX)
}

/// Whole microseconds of `d`, rounded up (saturating at `u64::MAX`): a
/// period or a timeout in a core's settings, so that "at least `d` since"
/// holds at whole microseconds exactly as it did on `Instant`s.
pub fn micros_ceil(d: Duration) -> Micros {
    let us = micros_of(d);
    if d.subsec_nanos().is_multiple_of(1000) {
        us
    } else {
        us.saturating_add(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instants_become_whole_microseconds_and_back() {
        let t0 = Instant::now();
        let e = Epoch::at(t0);
        assert_eq!(e.micros(t0), 0);
        assert_eq!(e.micros(t0 + Duration::from_nanos(1_999)), 1, "truncated");
        assert_eq!(e.micros(t0 + Duration::from_millis(250)), 250_000);
        assert_eq!(e.instant(250_000), t0 + Duration::from_millis(250));
        assert_eq!(Epoch::at(t0 + Duration::from_secs(1)).micros(t0), 0, "before the epoch: the epoch");
    }

    #[test]
    fn settings_round_up_to_the_microsecond() {
        assert_eq!(micros_ceil(Duration::from_millis(100)), 100_000);
        assert_eq!(micros_ceil(Duration::from_nanos(299_999_999)), 300_000);
        assert_eq!(micros_of(Duration::from_nanos(299_999_999)), 299_999);
        assert_eq!(micros_ceil(Duration::MAX), u64::MAX);
    }
}
