//! Fault injection into a launch's own bus: the `[faults]` section of the
//! launch config (all rates 0 by default: off).
//!
//! Why in the launch and not only in tests: a lab wants to see how its
//! swarm copes with a lossy network before it has one, and the soak test
//! (`tests/tests/soak.rs`) drives hundreds of launches through the very
//! same knob. The faults are the protocol crate's seeded fault layer
//! ([`FaultBus`]) on the orchestrator's receiving side: agent reports and
//! poses are dropped, delayed, duplicated or reordered, the same ones for
//! the same seed.

use super::transport::{Backend, LaunchBus};
use anyhow::Result;
use bycoms_protocol::bus::fault::FaultBus;
use std::rc::Rc;

pub use super::config::FaultsConfig;

/// The fault layer on the launch's transport (the `[faults]` table itself
/// is the config's).
impl FaultsConfig {
    /// `bus` as the launch's transport: wrapped in the fault layer when a
    /// fault is enabled, as it is otherwise.
    pub fn wrap<B>(&self, bus: B) -> Result<Rc<dyn LaunchBus>>
    where
        B: Backend + 'static,
        B::Publisher: 'static,
        B::Subscriber: 'static,
    {
        if !self.is_on() {
            return Ok(Rc::new(bus));
        }
        tracing::warn!(
            "fault injection on ({}): received messages are dropped, delayed, duplicated or reordered",
            self.words()
        );
        Ok(Rc::new(FaultBus::new(bus, self.fault_config())?))
    }
}

impl<B: Backend> Backend for FaultBus<B> {
    const KIND: &'static str = B::KIND;
    fn cleanup(&self) {
        self.inner().cleanup();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::bus::memory::MemoryBus;
    use bycoms_protocol::bus::Limits;
    use bycoms_protocol::TopicName;

    #[test]
    fn off_by_default_and_lossy_when_on() {
        assert!(!FaultsConfig::default().is_on());
        let topic = TopicName::parse("bycoms/faults/raw").expect("topic");
        let count = |faults: FaultsConfig| {
            let bus = faults.wrap(MemoryBus::new(Limits::default()).expect("bus")).expect("wrap");
            let sub = bus.subscriber(&topic).expect("sub");
            let publ = bus.publisher(&topic).expect("pub");
            // Fewer than the bus's buffer holds: only the faults lose messages.
            for i in 0..50u8 {
                publ.publish(&[i]).expect("publish");
            }
            let mut buf = [0u8; 8];
            std::iter::from_fn(|| sub.try_recv_into(&mut buf).expect("recv")).count()
        };
        assert_eq!(count(FaultsConfig::default()), 50);
        let lossy = count(FaultsConfig { drop: 0.5, seed: 3, ..FaultsConfig::default() });
        assert!((10..40).contains(&lossy), "{lossy} of 50 got through");
        let err = FaultsConfig { reorder: 1.5, ..FaultsConfig::default() }.validate().unwrap_err();
        assert_eq!(
            err.to_string(),
            "faults.reorder = 1.5: a fault rate must lie in 0..=1",
            "the key and its value"
        );
    }

    #[test]
    fn the_faults_are_logged_in_words_not_as_a_struct() {
        let faults = FaultsConfig { drop: 0.5, delay: 0.1, seed: 3, ..FaultsConfig::default() };
        assert_eq!(faults.words(), "drop 0.5, duplicate 0, delay 0.1 by 10 ms, reorder 0, seed 3");
    }
}
