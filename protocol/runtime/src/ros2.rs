//! A ROS 2 node and its publishers on a zenoh session, as rmw_zenoh puts
//! them there: what any process of ours that talks to a ROS 2 graph shares
//! (the launch's `--ros2` output, a ground robot's agent sending its
//! velocity commands).
//!
//! Why here: `bycoms-ros2` is sans-IO (names, tokens, GIDs, attachments,
//! CDR, each pinned without a network), and the launch is not something a
//! robot's agent may depend on; what lies between them — declaring the
//! tokens and the zenoh publisher, putting each message with its next
//! attachment, keeping the tokens as long as the publisher lives — is
//! written once, here. Waiting for routes to subscribers, and anything
//! else a caller needs before it publishes, stays with the caller: this
//! module never waits.
//!
//! A transient-local publisher (`Qos::transient_local(depth)`: the map,
//! `/tf_static`, the beacons) is *latched*: it keeps its last `depth`
//! samples and answers a late joiner's history query with them, as
//! rmw_zenoh's publishers do through zenoh-ext's `AdvancedPublisher`. That
//! one is behind zenoh's `unstable` API, so the cache is made here from
//! stable pieces (a [`zenoh::query::Queryable`] on the cache's key, a
//! liveliness token on the same key, a timestamp on every sample, the
//! rmw_zenoh attachment kept with it); the keys, the query's parameters and
//! which zenoh-ext and rmw_zenoh files were followed are in
//! [`bycoms_ros2::latched`]. It is here, in the one publisher builder,
//! because the launch and a robot's agent share it: any transient-local
//! publisher of ours answers late joiners.
//!
//! The ids follow rmw_zenoh's: the node is entity 0 of its session's
//! context, its publishers 1, 2, … in the order they are declared. The
//! node's token lives as long as the [`Ros2Node`] or any of its
//! [`Ros2Publisher`]s; neither keeps the session open (zenoh's publishers
//! and tokens hold it weakly, and so do these).

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, PoisonError};

use bycoms_ros2::latched::{cache_key_expr, HistoryQuery};
use bycoms_ros2::msgs::RosMessage;
use bycoms_ros2::rmw_zenoh::policy;
use bycoms_ros2::rmw_zenoh::{
    is_fully_qualified, liveliness_token, Attachment, Endpoint, EntityKind, Node, Publisher, Qos, TokenError,
};
use bycoms_ros2::types::TypeDescription;
use thiserror::Error;
use zenoh::liveliness::LivelinessToken;
use zenoh::query::{Query, Queryable};
use zenoh::time::{Timestamp, TimestampId, NTP64};
use zenoh::Wait;

/// Why a node or a publisher could not be declared, or a message not sent.
#[derive(Debug, Error)]
pub enum Ros2Error {
    /// A namespace, node or topic name that is not a ROS 2 one.
    #[error("ros2: {what} {name:?} is not a ROS 2 name (`/a/b`: letters, digits, `_`)")]
    Name {
        /// `namespace`, `node name` or `topic`.
        what: &'static str,
        /// The name given.
        name: String,
    },
    /// A token that rmw_zenoh would not make either.
    #[error("ros2: {0}")]
    Token(#[from] TokenError),
    /// zenoh refused a declaration.
    #[error("ros2: cannot declare {what}: {source}")]
    Declare {
        /// What (`the publisher of /tf`, `a liveliness token`).
        what: String,
        /// zenoh's error.
        source: zenoh::Error,
    },
    /// A publisher asked of another session than its node's.
    #[error("ros2: node {node} is on zenoh session {node_zid}, not {zid}")]
    OtherSession {
        /// The node's name.
        node: String,
        /// The node's session.
        node_zid: String,
        /// The session given.
        zid: String,
    },
    /// A message of another type than the publisher's.
    #[error("ros2: {topic} publishes {declared}, not {given}")]
    Type {
        /// The topic.
        topic: String,
        /// Its type.
        declared: &'static str,
        /// The message's.
        given: &'static str,
    },
    /// zenoh did not take a sample.
    #[error("ros2: a sample on {key} was not sent: {source}")]
    Put {
        /// The key expression.
        key: String,
        /// zenoh's error.
        source: zenoh::Error,
    },
}

/// A ROS 2 node on a zenoh session: its liveliness token (what `ros2 node
/// list` finds) and the ids of its publishers.
#[derive(Debug)]
pub struct Ros2Node {
    node: Node,
    token: Arc<LivelinessToken>,
    next_id: u64,
}

impl Ros2Node {
    /// Declares node `name` in `namespace` (`/` for the root one) of ROS 2
    /// domain `domain_id` on `session`.
    pub fn declare(
        session: &zenoh::Session,
        domain_id: u32,
        namespace: &str,
        name: &str,
    ) -> Result<Self, Ros2Error> {
        check_name("namespace", namespace, is_fully_qualified(namespace, true))?;
        let single = !name.contains('/') && is_fully_qualified(&format!("/{name}"), false);
        check_name("node name", name, single)?;
        let node = Node {
            domain_id,
            zid: session.zid().to_string(),
            id: 0,
            enclave: "/".into(),
            namespace: namespace.into(),
            name: name.into(),
        };
        let token = declare_token(session, liveliness_token(&node, None)?)?;
        tracing::debug!(domain_id, namespace, node = name, "ros2: node declared");
        Ok(Self { node, token: Arc::new(token), next_id: 1 })
    }

    /// The node as its token names it.
    pub fn node(&self) -> &Node {
        &self.node
    }

    /// Declares a publisher of `description`'s type on `topic` (fully
    /// qualified: `/bycoms/robot_3/cmd_vel`) with `qos`, on `session` (the
    /// node's): the zenoh publisher on the topic's key expression, then its
    /// liveliness token (what `ros2 topic list` finds).
    pub fn publisher(
        &mut self,
        session: &zenoh::Session,
        topic: &str,
        description: &'static TypeDescription,
        qos: Qos,
    ) -> Result<Ros2Publisher, Ros2Error> {
        let zid = session.zid().to_string();
        if zid != self.node.zid {
            let node = self.node.name.clone();
            return Err(Ros2Error::OtherSession { node, node_zid: self.node.zid.clone(), zid });
        }
        check_name("topic", topic, is_fully_qualified(topic, false))?;
        let endpoint = Endpoint {
            id: self.next_id,
            kind: EntityKind::Publisher,
            topic: topic.into(),
            ros_type: description.name.into(),
            type_hash: description.rihs01(),
            qos,
        };
        let wire = Publisher::new(&self.node, &endpoint)?;
        let publisher = session
            .declare_publisher(wire.key_expr.clone())
            .wait()
            .map_err(|source| Ros2Error::Declare { what: format!("the publisher of {topic}"), source })?;
        let latch = match qos.durability == policy::TRANSIENT_LOCAL {
            true => Some(Latch::declare(session, &wire.key_expr, qos.depth, topic)?),
            false => None,
        };
        let token = declare_token(session, wire.token.clone())?;
        self.next_id += 1;
        Ok(Ros2Publisher {
            _token: token,
            _node: Arc::clone(&self.token),
            topic: topic.into(),
            description,
            wire,
            publisher,
            latch,
        })
    }
}

/// One ROS 2 publisher: its zenoh publisher, its rmw_zenoh wire state
/// (key expression, GID, sequence numbers) and its token, with its node's.
#[derive(Debug)]
pub struct Ros2Publisher {
    // Dropped first: the graph stops listing it before its data stops.
    _token: LivelinessToken,
    _node: Arc<LivelinessToken>,
    topic: String,
    description: &'static TypeDescription,
    wire: Publisher,
    publisher: zenoh::pubsub::Publisher<'static>,
    latch: Option<Latch>,
}

/// One sample as a latched publisher keeps it: what a late joiner gets is
/// the very sample (payload, attachment, timestamp), so a subscriber that
/// got it live and again from the cache delivers it once.
#[derive(Debug, Clone)]
struct Cached {
    payload: Vec<u8>,
    attachment: Vec<u8>,
    timestamp: Timestamp,
}

/// A transient-local publisher's cache of its last `depth` samples, its
/// queryable and its liveliness token (see the module docs).
struct Latch {
    cache: Arc<Mutex<VecDeque<Cached>>>,
    depth: usize,
    id: TimestampId,
    last: NTP64,
    _queryable: Queryable<()>,
    _token: LivelinessToken,
}

impl std::fmt::Debug for Latch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Latch").field("depth", &self.depth).finish_non_exhaustive()
    }
}

impl Latch {
    /// The cache of the publisher on `key_expr` (of `topic`), keeping
    /// `depth` samples (at least one): its queryable first, then its token
    /// (zenoh-ext's order), so a subscriber that sees the token finds the
    /// queryable.
    fn declare(session: &zenoh::Session, key_expr: &str, depth: u64, topic: &str) -> Result<Self, Ros2Error> {
        let depth = usize::try_from(depth.max(1)).unwrap_or(usize::MAX);
        let cache_key = cache_key_expr(key_expr, &session.zid().to_string());
        let cache = Arc::new(Mutex::new(VecDeque::<Cached>::new()));
        let answers = Arc::clone(&cache);
        let data_key = key_expr.to_owned();
        let queryable = session
            .declare_queryable(cache_key.clone())
            .callback(move |query| answer(&query, &data_key, &answers))
            .wait()
            .map_err(|source| Ros2Error::Declare { what: format!("the cache of {topic}"), source })?;
        let token = declare_token(session, cache_key)?;
        let id = TimestampId::from(session.zid());
        Ok(Self { cache, depth, id, last: NTP64(0), _queryable: queryable, _token: token })
    }

    /// The next sample's timestamp: the wall clock with the session's id,
    /// always later than the last (a subscriber delivers a timestamped
    /// sample only if it is newer than the last of its source).
    fn next_timestamp(&mut self) -> Timestamp {
        let since = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
        let now = NTP64::from(since);
        self.last = if now > self.last { now } else { NTP64(self.last.0 + 1) };
        Timestamp::new(self.last, self.id)
    }

    /// Keeps `sample`, dropping the oldest past `depth`.
    fn keep(&self, sample: Cached) {
        let mut cache = self.cache.lock().unwrap_or_else(PoisonError::into_inner);
        if cache.len() >= self.depth {
            cache.pop_front();
        }
        cache.push_back(sample);
    }
}

/// Answers a history query from `cache`: the samples its `_max` and `_sn`
/// choose ([`HistoryQuery`]), oldest first, each on the topic's key
/// `data_key` with its attachment and timestamp. (zenoh-ext asks for
/// congestion control `Block` on its replies; zenoh 1.10 ignores a reply's
/// own and uses the query's.)
fn answer(query: &Query, data_key: &str, cache: &Mutex<VecDeque<Cached>>) {
    let params = query.parameters();
    let chosen = HistoryQuery::new(params.get("_max"), params.get("_sn"));
    let samples: Vec<Cached> = {
        let cache = cache.lock().unwrap_or_else(PoisonError::into_inner);
        cache.range(chosen.answer(cache.len())).cloned().collect()
    };
    for sample in samples {
        let reply =
            query.reply(data_key, sample.payload).attachment(sample.attachment).timestamp(sample.timestamp);
        if let Err(e) = reply.wait() {
            tracing::warn!(key = data_key, error = %e, "ros2: a late joiner's history query was not answered");
        }
    }
}

impl Ros2Publisher {
    /// Publishes `message`, which must be of the publisher's type.
    pub fn publish<M: RosMessage>(&mut self, message: &M) -> Result<Attachment, Ros2Error> {
        if M::DESCRIPTION.name != self.description.name {
            return Err(Ros2Error::Type {
                topic: self.topic.clone(),
                declared: self.description.name,
                given: M::DESCRIPTION.name,
            });
        }
        self.put(&message.to_cdr())
    }

    /// Puts one message's CDR (encapsulation header included) with the
    /// next attachment, stamped with the system clock as rmw_zenoh stamps
    /// it; returns that attachment.
    /// A latched publisher also keeps it, with a timestamp, for late joiners.
    pub fn put(&mut self, cdr: &[u8]) -> Result<Attachment, Ros2Error> {
        let attachment = self.wire.next_attachment(wall_clock_ns());
        let bytes = attachment.encode().to_vec();
        let mut put = self.publisher.put(cdr.to_vec()).attachment(bytes.clone());
        if let Some(latch) = &mut self.latch {
            let timestamp = latch.next_timestamp();
            // Kept before it is put, as zenoh-ext's cache does.
            latch.keep(Cached { payload: cdr.to_vec(), attachment: bytes, timestamp });
            put = put.timestamp(timestamp);
        }
        put.wait().map_err(|source| Ros2Error::Put { key: self.wire.key_expr.clone(), source })?;
        Ok(attachment)
    }

    /// Whether it keeps its last samples for late joiners (transient local).
    pub fn latched(&self) -> bool {
        self.latch.is_some()
    }

    /// Whether a subscriber matches it now (zenoh drops a put at its
    /// source until one does: a caller that must not lose its first
    /// samples waits for this).
    pub fn matching(&self) -> bool {
        self.publisher.matching_status().wait().is_ok_and(|m| m.matching())
    }

    /// Waits up to `timeout` for a subscriber to match it (zenoh tells a
    /// matching listener when the route arrives: no polling); whether one
    /// does.
    pub fn wait_matching(&self, timeout: std::time::Duration) -> bool {
        // The listener first, then the status: a route that arrives in
        // between is told to the listener.
        let Ok(listener) = self.publisher.matching_listener().wait() else { return self.matching() };
        let deadline = std::time::Instant::now() + timeout;
        let mut matched = self.matching();
        while !matched {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            match listener.recv_timeout(left) {
                Ok(Some(status)) => matched = status.matching(),
                // Timed out, or the publisher is gone.
                _ => return self.matching(),
            }
        }
        true
    }

    /// The fully qualified topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// Its wire state: key expression, token, GID.
    pub fn wire(&self) -> &Publisher {
        &self.wire
    }
}

/// Nanoseconds since the UNIX epoch (rmw_zenoh's `get_system_time_in_ns`).
pub fn wall_clock_ns() -> i64 {
    let since = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    i64::try_from(since.as_nanos()).unwrap_or(i64::MAX)
}

fn check_name(what: &'static str, name: &str, ok: bool) -> Result<(), Ros2Error> {
    if ok {
        Ok(())
    } else {
        Err(Ros2Error::Name { what, name: name.into() })
    }
}

fn declare_token(session: &zenoh::Session, token: String) -> Result<LivelinessToken, Ros2Error> {
    session
        .liveliness()
        .declare_token(token)
        .wait()
        .map_err(|source| Ros2Error::Declare { what: "a liveliness token".into(), source })
}

#[cfg(test)]
mod tests;
