//! A stop asked from outside the launch: `orchestrator stop` from another
//! terminal or host, or the ROS 2 stop service (issue 34, issue 32).
//!
//! Why one rule in the core: every way to stop a launch must do the same
//! thing, in the same order, and be tested in virtual time. A graceful stop
//! is Ctrl-C asked from elsewhere: the launch ends (outcome `interrupted`)
//! and the driver winds the agents down with `Shutdown`. A stop `now` first
//! tells every robot whose agent runs `Stop` (a simulated agent stays put,
//! a gateway sends its robot the link's stop frame), all in the same
//! `advance`, then ends the same way. Either records who asked and why
//! ([`Core::stopped`]: the summary's `stop`, an event per robot told).
//! The first stop asked wins; a later one changes nothing.

use super::*;

impl Core {
    /// Books a stop (the first one asked).
    pub(super) fn on_stop(&mut self, now: u64, stop: Stop) {
        if self.stop.is_none() {
            let Stop { now: at_once, who, why } = stop;
            self.stop =
                Some(StopSummary { now: at_once, who, why, unix_ms: self.unix_ms(now), told: Vec::new() });
        }
    }

    /// Whether a stop was asked and the launch has not ended yet.
    pub(super) fn stop_due(&self) -> bool {
        self.stop.is_some() && self.ending.is_none()
    }

    /// The stop asked, once it was (who, why, the robots told `Stop`).
    pub fn stopped(&self) -> Option<&StopSummary> {
        self.stop.as_ref()
    }

    /// Carries out the stop asked: `Stop` to every running robot when it is
    /// `now`, then the launch ends as interrupted.
    pub(super) fn stop_all(&mut self) {
        let Some(mut stop) = self.stop.take() else { return };
        let by = if stop.why.is_empty() {
            format!("stopped by {}", stop.who)
        } else {
            format!("stopped by {}: {}", stop.who, stop.why)
        };
        if stop.now {
            let running: Vec<u32> = self.slots.iter().filter(|s| s.alive).map(|s| s.id).collect();
            for &id in &running {
                self.outputs.push_back(Output::Send(id, ToAgent::Stop));
                self.event(id, EventKind::Stopped, None, Some(by.clone()));
            }
            stop.told = running;
            self.note(format!("{by}; every running robot was told to stop ({})", stop.told.len()));
        } else {
            self.note(format!("{by}; the launch winds down"));
        }
        self.stop = Some(stop);
        self.end(Outcome::Interrupted, None);
    }
}
