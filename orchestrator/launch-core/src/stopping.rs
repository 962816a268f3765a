//! A stop `now` under way, as the core keeps it (`stop.rs` holds its
//! rules): the answers awaited and the wait that re-sends `Stop`.

use super::wait::AnswerWait;
use std::collections::BTreeSet;

/// How long a stop `now` waits for every robot's answer, µs: past it the
/// launch ends anyway and names the robots that did not answer.
pub const STOP_WAIT_US: u64 = 1_000_000;

/// The first re-send of `Stop` to a silent robot, µs: a few control
/// periods of a simulated robot at speed 10, well under the stop's wait.
/// Not the answer time of the launch's other waits (`wait.rs`): a real-time
/// launch has none timed (its first re-send would be 100 ms), and a robot
/// whose agent had just started when the stop came (its commands not
/// subscribed yet) lost the first `Stop` (`bench stop`: the launch answered
/// after 110 ms instead of 10).
pub(super) const STOP_RESEND_US: u64 = 20_000;

/// A stop `now` under way: `Stop` sent, answers awaited.
#[derive(Clone, Debug)]
pub(super) struct Stopping {
    pub(super) wait: AnswerWait,
    /// The robots whose `StopDone` has not come.
    pub(super) awaiting: BTreeSet<u32>,
}
