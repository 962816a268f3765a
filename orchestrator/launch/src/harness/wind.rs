//! The launch's wind-down after its ending, played in virtual time.
//!
//! Why: every launch ends by telling its running agents `Shutdown`,
//! giving them a grace and ending the rest (`driver::wind_down`, on the
//! wall clock), and that was never played against agents that leave at
//! once, late or never. Here the core's own [`WindDown`] decides, with the
//! grace the launch's config gives ([`super::super::config::SupervisionConfig::shutdown_grace_for`]),
//! while each running agent leaves at a time drawn from the schedule's
//! seed (or hangs); a simulated agent leaves by its own core's `Shutdown`
//! rule. [`check`](super::check) holds each decision against the draw.

use super::world::World;
use super::*;
use crate::core::{WindDown, WindStep};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// One agent in eight hangs: it never leaves after `Shutdown`.
const HANG_ONE_IN: u32 = 8;
/// Mixed into the schedule's seed for the draw of leaving times, so that
/// the schedule's own draws (and every earlier seed's launch) stay as they
/// were.
const WIND_SEED: u64 = 0x7769_6e64;

/// What the wind-down did, for the checks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WoundDown {
    /// When it started (the launch's end), µs.
    pub started_us: u64,
    /// The grace the launch's config gives the agents that ran, µs.
    pub grace_us: u64,
    /// Each agent that ran at the end, with when it leaves after
    /// `Shutdown` (none: it hangs), in id order.
    pub leaves: Vec<(u32, Option<u64>)>,
    /// The agents told `Shutdown`.
    pub told: Vec<u32>,
    /// Whether the agents that may have missed it were asked to end.
    pub asked: bool,
    /// The agents ended after the grace.
    pub ended: Vec<u32>,
    /// When it was done, µs.
    pub done_us: u64,
    /// Simulated agents that did not leave on `Shutdown`, their core told.
    pub stayed: Vec<u32>,
}

impl World<'_> {
    /// Winds the agents still running down as the launch does, in virtual
    /// time (`Report::wound`).
    pub(super) fn wind_down(&mut self) {
        let running: Vec<u32> = (1..=self.case.robots).filter(|&id| self.alive(id)).collect();
        let grace = self.launch.cfg.supervision.shutdown_grace_for(running.len());
        let grace_us = u64::try_from(grace.as_micros()).unwrap_or(u64::MAX);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(self.schedule.seed ^ WIND_SEED);
        let start = self.now;
        let leaves: Vec<(u32, Option<u64>)> = running
            .iter()
            .map(|&id| {
                let hangs = rng.gen_range(0..HANG_ONE_IN) == 0;
                (id, (!hangs).then(|| start + rng.gen_range(0..=grace_us + grace_us / 2)))
            })
            .collect();
        let mut wound = WoundDown { started_us: start, grace_us, leaves, ..WoundDown::default() };
        let mut winding = WindDown::new(start, grace_us, running);
        let mut now = start;
        // Each pass lets an agent leave or reaches the grace's end: a
        // wind-down that takes more passes than that does not end.
        for pass in 0.. {
            if pass > 2 * wound.leaves.len() + 4 {
                self.report.failure = Some(format!("the wind-down started at {start} µs does not end"));
                break;
            }
            match winding.poll(now) {
                Some(WindStep::Shutdown(ids)) => wound.told = ids,
                Some(WindStep::AskToEnd) => wound.asked = true,
                Some(WindStep::EndRest(ids)) => {
                    wound.ended = ids;
                    break;
                }
                None if winding.is_done() => break,
                None => now = self.leave_next(&mut winding, &mut wound, now),
            }
        }
        wound.done_us = now;
        self.report.wound = Some(wound);
    }

    /// Moves on to the next agent's leaving or the grace's end, whichever
    /// comes first, and lets every agent due by then leave; the new time.
    fn leave_next(&mut self, winding: &mut WindDown, wound: &mut WoundDown, now: u64) -> u64 {
        let leaving = |id: u32| wound.leaves.iter().find(|l| l.0 == id).and_then(|l| l.1);
        let running: Vec<u32> = winding.running().collect();
        let next = running.iter().filter_map(|&id| leaving(id)).chain(winding.deadline()).min();
        let now = next.map_or(now, |t| t.max(now));
        for id in running.into_iter().filter(|&id| leaving(id).is_some_and(|t| t <= now)) {
            if let Some(agent) = self.agents.get_mut(id as usize - 1).and_then(Option::as_mut) {
                agent.command(&ToAgent::Shutdown, &mut Vec::new());
                if agent.alive {
                    wound.stayed.push(id);
                }
            }
            winding.ended(id);
        }
        now
    }
}
