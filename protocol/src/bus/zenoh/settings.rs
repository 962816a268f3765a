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
//! (`bycoms_sim::sim_agent::settings`; PROTOCOL.md, "The run's
//! settings"). The answer is the payload as served, one reply per query.

use super::ZenohBus;
use crate::bus::BusError;
use crate::naming::Swarm;
use ::zenoh::query::{Query, Queryable};
use ::zenoh::Wait as _;
use core::time::Duration;
use std::sync::Arc;

/// The orchestrator's answer to settings queries; dropping it undeclares
/// the queryable.
pub struct SettingsServer {
    _queryable: Queryable<()>,
}

impl ZenohBus {
    /// Answers every query on `swarm`'s settings key with `encoded`, for as
    /// long as the returned value lives.
    pub fn serve_settings(&self, swarm: &Swarm, encoded: Vec<u8>) -> Result<SettingsServer, BusError> {
        let key = swarm.settings();
        let payload: Arc<[u8]> = encoded.into();
        let queryable = self
            .session()
            .declare_queryable(key.as_str().to_owned())
            .callback(move |query: Query| {
                // A reply that cannot go (the asker left) concerns only
                // the asker; it asks again.
                if let Err(e) = query.reply(query.key_expr().clone(), payload.to_vec()).wait() {
                    tracing::debug!(error = %super::zenoh_error(&e), "a settings reply was not sent");
                }
            })
            .wait()
            .map_err(|e| {
                super::text::backend("declare settings queryable", Some(key.to_string()), None, &e)
            })?;
        tracing::debug!(key = key.as_str(), "zenoh: serving the run's settings");
        Ok(SettingsServer { _queryable: queryable })
    }

    /// Asks for `swarm`'s settings once, waiting up to `timeout` for an
    /// answer: the first reply's payload, or `None` when nobody answered in
    /// time (no orchestrator of that swarm yet). A reply that is an error
    /// is an error.
    pub fn fetch_settings(&self, swarm: &Swarm, timeout: Duration) -> Result<Option<Vec<u8>>, BusError> {
        let key = swarm.settings();
        let failed = |e: &dyn core::fmt::Display| {
            super::text::backend("query settings", Some(key.to_string()), None, e)
        };
        let replies =
            self.session().get(key.as_str().to_owned()).timeout(timeout).wait().map_err(|e| failed(&e))?;
        // The channel ends (an error) when the query is complete or timed
        // out with no reply.
        let Ok(reply) = replies.recv() else { return Ok(None) };
        match reply.into_result() {
            Ok(sample) => Ok(Some(sample.payload().to_bytes().into_owned())),
            Err(e) => Err(failed(&String::from_utf8_lossy(&e.payload().to_bytes()))),
        }
    }
}
