//! Latched (`TRANSIENT_LOCAL`) topics as rmw_zenoh serves them to late
//! joiners, sans-IO: the key expression of a publisher's cache (its
//! queryable and its liveliness token) and which cached samples answer a
//! history query.
//!
//! Why: rmw_zenoh gives a transient-local publisher zenoh-ext's
//! `AdvancedPublisher` with a cache of `depth` samples and publisher
//! detection; a transient-local subscriber is an `AdvancedSubscriber` that
//! asks every cache for its history and watches the caches' tokens for
//! publishers that come later. zenoh-ext 1.10's advanced publisher is
//! behind its `unstable` feature (and zenoh's `unstable` and `internal`),
//! which the product does not enable: the cache is rebuilt here from
//! zenoh's stable pieces (a queryable, a liveliness token, sample
//! timestamps and attachments) by `bycoms_runtime::ros2`, and this module
//! holds the names and the rules, pinned without a network.
//!
//! What was followed (zenoh-ext 1.10.2 from crates.io; ros2/rmw_zenoh):
//!
//! * rmw_zenoh `rmw_zenoh_cpp/src/detail/rmw_publisher_data.cpp` (commit
//!   3e19ec730c52): a `TRANSIENT_LOCAL` publisher gets
//!   `publisher_detection`, a cache of `max_samples = depth`, and, when it
//!   is also `RELIABLE`, sample-miss detection with sporadic heartbeats
//!   (500 ms);
//! * rmw_zenoh `rmw_zenoh_cpp/src/detail/rmw_subscription_data.cpp`
//!   (commit 04df82fd985f): a `TRANSIENT_LOCAL` subscription gets
//!   `subscriber_detection`, a query timeout of `u64::MAX` ms,
//!   `history(detect_late_publishers, max_samples = depth)` and, when
//!   `RELIABLE`, `recovery(heartbeat)`;
//! * zenoh-ext `src/advanced_publisher.rs` (`AdvancedPublisher::new`): the
//!   cache's queryable and the token are both `<key>/@adv/pub/<zid>/<eid or
//!   uhlc>/<meta or _>`; a publisher that numbers its samples (sample-miss
//!   detection) writes its entity id and puts a `SourceInfo` (its id and
//!   sequence number) on each sample, one that does not writes `uhlc` and
//!   puts a timestamp on each (from its session's HLC);
//! * zenoh-ext `src/advanced_cache.rs` (`AdvancedCache::new`): a query's
//!   `_sn` range keeps only samples whose `SourceInfo` number is in it
//!   (`..` or no `_sn`: all), `_max` keeps the newest `_max` of those, the
//!   replies go oldest first, each the cached sample itself (its key, the
//!   topic's; payload; attachment; timestamp), congestion control `Block`;
//! * zenoh-ext `src/advanced_subscriber.rs` (`AdvancedSubscriber::new`,
//!   `handle_sample`): the first query is `<key>/@adv/**?_max=<depth>`,
//!   accepting replies on any key (the topic's); each token of
//!   `<key>/@adv/pub/**` is queried again (`<token>?_max=<depth>`); a
//!   sample without `SourceInfo` but with a timestamp is delivered only if
//!   newer than the last one delivered from that timestamp's id, so the
//!   same cached sample answered twice (both queries) is delivered once.
//!
//! `SourceInfo` is unstable in zenoh 1.10 (`PublicationBuilder::source_info`
//! is `#[zenoh_macros::unstable]`), so ours is the timestamped form: the
//! token and queryable say `uhlc`, every sample of a latched topic carries
//! a timestamp with the session's id, and there is no sample-miss detection
//! (no heartbeats, nothing for `recovery` to recover: a subscriber set up
//! for it simply gets none). A `_sn` range other than `..` is answered with
//! nothing, as zenoh-ext's cache answers it for samples without a number.
//! A `_time` range (sent only by a subscriber with `max_age`, which
//! rmw_zenoh does not set) is not applied: its parser is unstable too.

/// The cache's key suffix (zenoh-ext's `KE_ADV_PREFIX / KE_PUB / zid /
/// KE_UHLC / KE_EMPTY`) for a publisher of session `zid`.
pub fn cache_suffix(zid: &str) -> String {
    format!("@adv/pub/{zid}/uhlc/_")
}

/// The key expression of a latched publisher's cache (its queryable and
/// its liveliness token): the topic's key expression, then [`cache_suffix`].
pub fn cache_key_expr(topic_key_expr: &str, zid: &str) -> String {
    format!("{topic_key_expr}/{}", cache_suffix(zid))
}

/// The parameters of a history query that choose what a cache answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HistoryQuery {
    /// `_max`: at most this many, the newest.
    pub max: Option<u32>,
    /// `_sn` named a range of sequence numbers (not `..`): our samples have
    /// none, so none is in it.
    pub numbered: bool,
}

impl HistoryQuery {
    /// The query whose `_max` and `_sn` parameters are these (zenoh-ext
    /// reads an unparsable `_max` as none, and an `_sn` whose two ends do
    /// not parse as `..`, all).
    pub fn new(max: Option<&str>, sn: Option<&str>) -> Self {
        let max = max.and_then(|m| m.parse::<u32>().ok());
        let numbered = sn.is_some_and(|range| {
            let mut ends = range.split("..");
            let start = ends.next().and_then(|s| s.parse::<u32>().ok());
            // No `..`: a single number, both ends.
            let end = ends.next().map_or(start, |s| s.parse::<u32>().ok());
            start.is_some() || end.is_some()
        });
        Self { max, numbered }
    }

    /// Which of `cached` samples (oldest first) answer it, in the order
    /// they are replied: oldest first, the newest `max`.
    pub fn answer(&self, cached: usize) -> std::ops::Range<usize> {
        if self.numbered {
            return 0..0;
        }
        let n = self.max.map_or(cached, |m| cached.min(m as usize));
        cached - n..cached
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cache_sits_under_the_topics_key_as_zenoh_ext_names_a_timestamped_publishers() {
        let key = "0/map/nav_msgs::msg::dds_::OccupancyGrid_/RIHS01_abc";
        assert_eq!(
            cache_key_expr(key, "aac3178e146ba6f1fc6e6a4085e77f21"),
            "0/map/nav_msgs::msg::dds_::OccupancyGrid_/RIHS01_abc/@adv/pub/aac3178e146ba6f1fc6e6a4085e77f21/uhlc/_"
        );
    }

    #[test]
    fn a_history_query_gets_the_newest_max_oldest_first() {
        let q = |max, sn| HistoryQuery::new(max, sn);
        assert_eq!(q(None, None).answer(3), 0..3, "no _max: all");
        assert_eq!(q(Some("1"), None).answer(3), 2..3, "the newest");
        assert_eq!(q(Some("10"), None).answer(3), 0..3);
        assert_eq!(q(Some("0"), None).answer(3), 3..3);
        assert_eq!(q(Some("x"), None).answer(2), 0..2, "an unparsable _max is none");
        assert_eq!(q(Some("1"), None).answer(0), 0..0, "an empty cache");
        assert_eq!(q(None, Some("..")).answer(2), 0..2, "`..`: every number");
        for numbered in ["3..", "..7", "2..5", "4"] {
            assert_eq!(
                q(Some("1"), Some(numbered)).answer(2),
                0..0,
                "{numbered}: our samples have no number"
            );
        }
    }
}
