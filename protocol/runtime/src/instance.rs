//! Who an agent process is: a random number drawn once per process and
//! sent in its `Register`.
//!
//! Why: two agents may register for the same robot (a second host started
//! by mistake, a restarted agent whose first instance still runs). The
//! orchestrator keeps the first and refuses the other by its instance
//! (`ToAgent::Refused`); a repeated `Register` of the same process is
//! recognised as a repeat. Only uniqueness matters, not secrecy, so no
//! crate: std's `RandomState` is keyed from the operating system's random
//! source once per process, and hashing the pid and the time on top of it
//! makes two processes collide with negligible probability. This is no
//! simulation randomness (it never reaches a result), so it is not seeded.

use std::collections::hash_map::RandomState;
use std::hash::{BuildHasher, Hasher};
use std::sync::OnceLock;
use std::time::{SystemTime, UNIX_EPOCH};

/// This process's agent instance (the same value for the whole process).
pub fn instance() -> u64 {
    static INSTANCE: OnceLock<u64> = OnceLock::new();
    *INSTANCE.get_or_init(|| {
        let mut h = RandomState::new().build_hasher();
        h.write_u32(std::process::id());
        let now = SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
        h.write_u128(now);
        h.finish()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_value_per_process_and_keyed_hashers_differ() {
        assert_eq!(instance(), instance());
        let a = RandomState::new().build_hasher().finish();
        let b = RandomState::new().build_hasher().finish();
        // Two keyed hashers of nothing differ: the keys are random (a check
        // that the source of the instance is not a constant).
        assert_ne!(a, b);
    }
}
