//! How far a host's clock may be off the orchestrator's: the limits an
//! offset is judged by ([`ClockLimits`]) and the verdict ([`ClockVerdict`]).
//!
//! Why a module of its own, outside `bus::zenoh::clock` (which measures
//! offsets over zenoh and re-exports these at their old path): the launch
//! core, which has no IO and no zenoh, judges offsets with the same
//! arithmetic as the doctors of the robots' hosts; plain types, `no_std`.

/// The limits a clock offset is judged by, µs (0: not judged): the
/// launch's (its config's `supervision.clock_warn` and `clock_limit`,
/// refusing an agent past the limit) and every doctor's (`orchestrator
/// doctor --connect`, `gateway doctor`, `sim-agent doctor`).
///
/// Why here, beside the measurement: the launch core and the doctors of
/// the robots' hosts (which cannot depend on the orchestrator) must judge
/// an offset with one arithmetic, and this is the lowest module all of
/// them reach.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ClockLimits {
    /// Past this an offset is noted (and warned about).
    pub warn_us: u64,
    /// Past this an agent is refused at registration.
    pub limit_us: u64,
}

/// What an offset is, judged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockVerdict {
    /// Within the warning (or not judged).
    Fine,
    /// Past the warning, within the limit.
    Warn,
    /// Past the limit.
    Refuse,
}

impl ClockLimits {
    /// A launch's defaults (the config's `supervision.clock_warn` 0.1 s and
    /// `supervision.clock_limit` 0.5 s): warn past 100 ms, refuse past
    /// 500 ms, zenoh's own bound on a sample stamped in the future.
    pub const LAB: Self = Self { warn_us: 100_000, limit_us: 500_000 };

    /// Whether offsets are judged at all.
    pub fn on(&self) -> bool {
        self.limit_us > 0
    }

    /// The verdict on an offset of `offset_us` (either way).
    pub fn judge(&self, offset_us: i64) -> ClockVerdict {
        let off = offset_us.unsigned_abs();
        if self.on() && off > self.limit_us {
            ClockVerdict::Refuse
        } else if self.warn_us > 0 && off > self.warn_us {
            ClockVerdict::Warn
        } else {
            ClockVerdict::Fine
        }
    }
}
