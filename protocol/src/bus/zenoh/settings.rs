//! The run's settings, handed over zenoh: the orchestrator answers queries
//! on `bycoms/<swarm>/settings` ([`Swarm::settings`]) with the encoded
//! settings, and an agent asks.
//!
//! Why a queryable and not a message: the settings carry the terrain's
//! text, far beyond one bus message (≤ 64 bytes), and an agent needs them
//! once, before it registers, whenever it starts (before or after the
//! launch began). A queryable answers each asker on its own; nothing is
//! kept in a storage and nothing is published to the swarm's watchers.
//!
//! This module knows only bytes: what they encode (and their fingerprint,
//! the `settings` of `Register`) is the agent crate's
//! (`bycoms_sim_agent::settings`; PROTOCOL.md, "The run's
//! settings"). The answer is the payload as served, one reply per query.
//!
//! Who asks: an agent names its robot in the query (selector parameter
//! `robot=K`). The server answers only the launch's robots (1..=N): an
//! asker for another robot gets an error reply saying why, and is counted
//! ([`SettingsServer::refused`]), because its `Register` would go to a
//! topic the launch does not read and it would otherwise run unseen. A
//! query without the parameter (an agent of an older build) still gets the
//! settings.

use super::ZenohBus;
use crate::bus::BusError;
use crate::naming::Swarm;
use crate::RobotId;
use ::zenoh::query::{Query, Queryable};
use ::zenoh::Wait as _;
use core::sync::atomic::{AtomicU64, Ordering};
use core::time::Duration;
use std::sync::Arc;

/// The selector parameter that names the asker's robot.
pub const ROBOT_PARAMETER: &str = "robot";

/// How many refusals are logged before thinning out (then every 1000th).
const LOG_FIRST: u64 = 5;

/// The orchestrator's answer to settings queries; dropping it undeclares
/// the queryable.
pub struct SettingsServer {
    _queryable: Queryable<()>,
    refused: Arc<AtomicU64>,
}

impl SettingsServer {
    /// How many queries were refused so far (askers for a robot outside
    /// the launch, or a `robot` parameter that is no robot id).
    pub fn refused(&self) -> u64 {
        self.refused.load(Ordering::Relaxed)
    }
}

/// What the orchestrator answered.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SettingsAnswer {
    /// The run's settings, encoded.
    Settings(Vec<u8>),
    /// This asker is refused, and why (the orchestrator's words).
    Refused(String),
}

/// Why the asker of `parameter` (the query's `robot` value; `None`: an
/// older agent, which is answered) is refused by a launch of robots
/// 1..=`robots`, if it is.
fn refusal(parameter: Option<&str>, robots: u32) -> Option<String> {
    let value = parameter?;
    match value.parse::<u32>() {
        Ok(k) if (1..=robots).contains(&k) => None,
        Ok(k) => Some(format!("robot {k} is not one of the launch's robots (it has robots 1 to {robots})")),
        Err(_) => Some(format!("{value:?} is no robot id (the launch has robots 1 to {robots})")),
    }
}

impl ZenohBus {
    /// Answers every query on `swarm`'s settings key with `encoded`, for as
    /// long as the returned value lives; a query naming a robot outside
    /// 1..=`robots` gets an error reply instead, and is counted.
    pub fn serve_settings(
        &self,
        swarm: &Swarm,
        encoded: Vec<u8>,
        robots: u32,
    ) -> Result<SettingsServer, BusError> {
        let key = swarm.settings();
        let payload: Arc<[u8]> = encoded.into();
        let refused = Arc::new(AtomicU64::new(0));
        let count = refused.clone();
        let queryable = self
            .session()
            .declare_queryable(key.as_str().to_owned())
            .callback(move |query: Query| {
                let sent = match refusal(query.parameters().get(ROBOT_PARAMETER), robots) {
                    None => query.reply(query.key_expr().clone(), payload.to_vec()).wait(),
                    Some(why) => {
                        let n = count.fetch_add(1, Ordering::Relaxed) + 1;
                        if n <= LOG_FIRST || n.is_multiple_of(1000) {
                            tracing::warn!(n, "an agent asked for the run's settings and was refused: {why}");
                        }
                        query.reply_err(why.into_bytes()).wait()
                    }
                };
                // A reply that cannot go (the asker left) concerns only
                // the asker; it asks again.
                if let Err(e) = sent {
                    tracing::debug!(error = %super::zenoh_error(&e), "a settings reply was not sent");
                }
            })
            .wait()
            .map_err(|e| {
                super::text::backend("declare settings queryable", Some(key.to_string()), None, &e)
            })?;
        tracing::debug!(key = key.as_str(), "zenoh: serving the run's settings");
        Ok(SettingsServer { _queryable: queryable, refused })
    }

    /// Asks for `swarm`'s settings once as the agent of `robot` (`None`: no
    /// robot named, as an older agent asks), waiting up to `timeout` for an
    /// answer: the first reply, or `None` when nobody answered in time (no
    /// orchestrator of that swarm yet). An error reply is a refusal.
    pub fn fetch_settings(
        &self,
        swarm: &Swarm,
        robot: Option<RobotId>,
        timeout: Duration,
    ) -> Result<Option<SettingsAnswer>, BusError> {
        let key = swarm.settings();
        let failed = |e: &dyn core::fmt::Display| {
            super::text::backend("query settings", Some(key.to_string()), None, e)
        };
        let selector = match robot {
            Some(id) => format!("{}?{ROBOT_PARAMETER}={}", key.as_str(), id.0),
            None => key.as_str().to_owned(),
        };
        let replies = self.session().get(selector).timeout(timeout).wait().map_err(|e| failed(&e))?;
        // The channel ends (an error) when the query is complete or timed
        // out with no reply.
        let Ok(reply) = replies.recv() else { return Ok(None) };
        Ok(Some(match reply.into_result() {
            Ok(sample) => SettingsAnswer::Settings(sample.payload().to_bytes().into_owned()),
            Err(e) => SettingsAnswer::Refused(String::from_utf8_lossy(&e.payload().to_bytes()).into_owned()),
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::refusal;

    #[test]
    fn only_the_launchs_robots_and_older_agents_are_answered() {
        assert_eq!(refusal(None, 3), None, "an older agent names no robot");
        assert_eq!(refusal(Some("1"), 3), None);
        assert_eq!(refusal(Some("3"), 3), None);
        let nine = refusal(Some("9"), 3).expect("robot 9 of 3 is refused");
        assert_eq!(nine, "robot 9 is not one of the launch's robots (it has robots 1 to 3)");
        assert!(refusal(Some("0"), 3).is_some(), "robot ids start at 1");
        let bad = refusal(Some("x"), 3).expect("no robot id");
        assert!(bad.contains("\"x\" is no robot id"), "{bad}");
    }
}
