//! The real-time driver: every agent is its own clock.
//!
//! Why the orchestrator only reacts here: as in a lab, robots move on their
//! own 10 Hz (× `speed`) clocks and motion capture streams their poses; the
//! orchestrator answers every pose of the moving robot with the goal
//! bearing from that pose, republishes dead robots' poses once a period, and
//! judges motion from the poses' own timestamps (simulated time), so the
//! gate behaves the same at any speed. No parity with the runner is claimed
//! on this clock: message timing decides which bearing a period uses.

use super::deploy::Next;
use super::engine::{Launch, SLICE};
use super::summary::Outcome;
use anyhow::Result;
use std::time::{Duration, Instant};

impl Launch {
    /// Runs the launch on the real-time clock until it ends.
    pub fn run_realtime(&mut self) -> Result<Outcome> {
        let period = self.cfg.wall_period();
        let mut next_relay = Instant::now();
        let mut frame: u64 = 0;
        loop {
            if self.must_end() {
                return Ok(Outcome::Interrupted);
            }
            if let Some(outcome) = self.settle_verdicts()? {
                return Ok(outcome);
            }
            if self.budget_spent()? {
                return Ok(Outcome::TimeLimit);
            }
            if self.watch.is_none() {
                if self.slot(self.next).is_none() {
                    return Ok(Outcome::RobotsExhausted);
                }
                match self.deploy_next()? {
                    Next::Deployed => {}
                    Next::NoneLeft => return Ok(Outcome::RobotsExhausted),
                    Next::Ended => continue,
                }
            }
            let now = Instant::now();
            if now >= next_relay {
                frame += 1;
                let sim_us = (self.started.elapsed().as_secs_f64() * self.cfg.speed * 1e6) as u64;
                self.relay_dead(frame, sim_us)?;
                next_relay = now + period;
            }
            self.pump(SLICE.min(next_relay.saturating_duration_since(now)).max(Duration::from_millis(1)))?;
        }
    }
}
