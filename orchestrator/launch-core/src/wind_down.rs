//! The end of every launch, decided without IO: `Shutdown` to every agent
//! still running, a grace, an end for those that did not exit.
//!
//! Why a machine of its own and not the driver's loop: a won run, a time
//! limit, Ctrl-C and an error all end this way, and what it decides (whom
//! to tell, when the grace is over, whom to end) was timed by the driver's
//! wall clock alone, so no test could play it against agents that exit
//! late, at once or never. Here it takes the time as a number, as the
//! core does: the driver runs it on its clock (`driver::wind_down`), the
//! harness plays it in virtual time against its simulated agents after
//! every schedule's ending and checks each decision.
//!
//! Why apart from [`crate::LaunchCore`]: the core's log ends with its
//! ending (replay compares what the core decided); the wind-down's only
//! inputs are the agents' exits, which no recording holds.

use std::collections::BTreeSet;

/// What the shell does next to wind the agents down.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum WindStep {
    /// Send `Shutdown` to each of these agents (every one running).
    Shutdown(Vec<u32>),
    /// Ask the agents that may have missed the `Shutdown` to end (an agent
    /// never heard from, still opening its bus).
    AskToEnd,
    /// The grace is over: end these agents, still running.
    EndRest(Vec<u32>),
}

/// Where a wind-down is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    Tell,
    Ask,
    Grace,
    Done,
}

/// One wind-down: the agents still running, and the end of their grace.
#[derive(Clone, Debug)]
pub struct WindDown {
    running: BTreeSet<u32>,
    deadline: u64,
    stage: Stage,
}

impl WindDown {
    /// A wind-down started at `now` (µs) of the agents of `running`, who
    /// get `grace_us` to exit.
    pub fn new(now: u64, grace_us: u64, running: impl IntoIterator<Item = u32>) -> Self {
        Self {
            running: running.into_iter().collect(),
            deadline: now.saturating_add(grace_us),
            stage: Stage::Tell,
        }
    }

    /// Robot `id`'s agent was seen to have ended.
    pub fn ended(&mut self, id: u32) {
        self.running.remove(&id);
    }

    /// Every agent left counts as ended (a source that cannot see them
    /// leave, as agents on other hosts).
    pub fn all_ended(&mut self) {
        self.running.clear();
    }

    /// The agents not yet seen to end.
    pub fn running(&self) -> impl Iterator<Item = u32> + '_ {
        self.running.iter().copied()
    }

    /// When the grace is over, µs; none once the wind-down is done.
    pub fn deadline(&self) -> Option<u64> {
        (self.stage != Stage::Done).then_some(self.deadline)
    }

    /// Whether nothing is left to do.
    pub fn is_done(&self) -> bool {
        self.stage == Stage::Done
    }

    /// What to do at `now` (µs): each step once, in order; none while the
    /// grace runs and agents are left, and none once done.
    pub fn poll(&mut self, now: u64) -> Option<WindStep> {
        match self.stage {
            Stage::Tell => {
                self.stage = Stage::Ask;
                Some(WindStep::Shutdown(self.running().collect()))
            }
            Stage::Ask => {
                self.stage = Stage::Grace;
                Some(WindStep::AskToEnd)
            }
            Stage::Grace if self.running.is_empty() => {
                self.stage = Stage::Done;
                None
            }
            Stage::Grace if now >= self.deadline => {
                self.stage = Stage::Done;
                Some(WindStep::EndRest(std::mem::take(&mut self.running).into_iter().collect()))
            }
            Stage::Grace | Stage::Done => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_running_agent_is_told_then_asked_and_those_left_at_the_deadline_are_ended() {
        let mut w = WindDown::new(1_000, 500, [3, 1, 2]);
        assert_eq!(w.poll(1_000), Some(WindStep::Shutdown(vec![1, 2, 3])));
        assert_eq!(w.poll(1_000), Some(WindStep::AskToEnd));
        assert_eq!(w.deadline(), Some(1_500));
        w.ended(2);
        assert_eq!(w.poll(1_499), None, "the grace runs");
        assert_eq!(w.poll(1_500), Some(WindStep::EndRest(vec![1, 3])));
        assert!(w.is_done());
        assert_eq!((w.poll(9_999), w.deadline()), (None, None));
    }

    #[test]
    fn a_wind_down_ends_as_soon_as_the_last_agent_has_ended() {
        let mut w = WindDown::new(0, 1_000_000, [1, 2]);
        let _ = (w.poll(0), w.poll(0));
        w.ended(1);
        w.ended(1);
        assert_eq!(w.poll(10), None);
        assert!(!w.is_done());
        w.ended(2);
        assert_eq!(w.poll(20), None);
        assert!(w.is_done(), "done at 20 µs, long before the grace's end");
        let mut unseen = WindDown::new(0, 1_000_000, [1, 2]);
        let _ = (unseen.poll(0), unseen.poll(0));
        unseen.all_ended();
        assert_eq!((unseen.poll(1), unseen.is_done()), (None, true));
    }

    #[test]
    fn no_agent_running_tells_nobody_and_ends_nobody() {
        let mut w = WindDown::new(0, 0, []);
        assert_eq!(w.poll(0), Some(WindStep::Shutdown(vec![])));
        assert_eq!(w.poll(0), Some(WindStep::AskToEnd));
        assert_eq!(w.poll(0), None);
        assert!(w.is_done());
    }
}
