//! Publishers and subscribers of the zenoh bus (see [`super`] for why they
//! look like this).

use super::{Congestion, ZenohConfig};
use crate::bus::inbox::Inbox;
use crate::bus::{BusError, Publish, Subscribe};
use crate::naming::{Route, Swarm, TopicName};
use ::zenoh::handlers::{RingChannel, RingChannelHandler};
use ::zenoh::key_expr::KeyExpr;
use ::zenoh::pubsub::{Publisher, Subscriber};
use ::zenoh::qos::CongestionControl;
use ::zenoh::sample::Sample;
use ::zenoh::{Session, Wait as _};
use core::time::Duration;
use std::sync::Arc;

/// Publisher id of messages that carry no (valid) attachment.
const FOREIGN_PUBLISHER: u64 = 0;

fn key_expr(topic: &TopicName) -> Result<KeyExpr<'static>, BusError> {
    // Topic names are valid key expressions by construction (naming rules).
    KeyExpr::try_from(topic.as_str().to_owned())
        .map_err(|e| super::text::backend("name key", Some(topic.as_str().to_owned()), None, &e))
}

/// The publisher id carried in a sample's attachment, if it has one.
fn publisher_of(sample: &Sample) -> u64 {
    sample
        .attachment()
        .and_then(|a| <[u8; 8]>::try_from(a.to_bytes().as_ref()).ok())
        .map_or(FOREIGN_PUBLISHER, u64::from_le_bytes)
}

pub(super) fn open_publisher(
    session: &Session,
    config: &ZenohConfig,
    topic: &TopicName,
    id: u64,
) -> Result<ZenohPublisher, BusError> {
    let congestion = match config.congestion {
        Congestion::Drop => CongestionControl::Drop,
        Congestion::Block => CongestionControl::Block,
    };
    let inner = session
        .declare_publisher(key_expr(topic)?)
        .congestion_control(congestion)
        .express(config.express)
        .wait()
        .map_err(|e| super::text::backend("open publisher", Some(topic.as_str().to_owned()), None, &e))?;
    Ok(ZenohPublisher { inner, id: id.to_le_bytes(), topic: *topic, max_payload: config.limits.max_payload })
}

pub(super) fn open_subscriber(
    session: &Session,
    config: &ZenohConfig,
    topic: &TopicName,
) -> Result<ZenohSubscriber, BusError> {
    let inbox = Arc::new(Inbox::new(config.limits.buffer));
    let inner = vec![declare(session, topic, &inbox, None)?];
    Ok(ZenohSubscriber { _inner: inner, inbox, max_payload: config.limits.max_payload })
}

/// A subscriber of every topic of `topics`, its messages tagged with the
/// topic's index (see [`crate::bus::Bus::fan_in`]).
pub(super) fn open_fan_in(
    session: &Session,
    config: &ZenohConfig,
    topics: &[TopicName],
) -> Result<ZenohSubscriber, BusError> {
    let inbox = Arc::new(Inbox::new(config.limits.buffer));
    let inner = topics
        .iter()
        .enumerate()
        .map(|(i, topic)| {
            let tag =
                u32::try_from(i).map_err(|_| BusError::InvalidConfig("more than 2^32 topics in a fan-in"))?;
            declare(session, topic, &inbox, Some(tag))
        })
        .collect::<Result<Vec<_>, BusError>>()?;
    Ok(ZenohSubscriber {
        _inner: inner,
        inbox,
        max_payload: config.limits.max_payload + crate::bus::FAN_IN_TAG,
    })
}

/// Declares a subscriber of `topic` whose samples go into `inbox`, tagged
/// with `tag` when it is part of a fan-in.
fn declare(
    session: &Session,
    topic: &TopicName,
    inbox: &Arc<Inbox>,
    tag: Option<u32>,
) -> Result<Subscriber<()>, BusError> {
    let sink = Arc::clone(inbox);
    session
        .declare_subscriber(key_expr(topic)?)
        .callback(move |sample: Sample| {
            let payload = sample.payload().to_bytes();
            match tag {
                Some(tag) => sink.push_tagged(publisher_of(&sample), tag, &payload),
                None => sink.push(publisher_of(&sample), &payload),
            }
        })
        .wait()
        .map_err(|e| super::text::backend("open subscriber", Some(topic.as_str().to_owned()), None, &e))
}

pub(super) fn open_swarm_subscriber(
    session: &Session,
    config: &ZenohConfig,
    swarm: &Swarm,
) -> Result<SwarmSubscriber, BusError> {
    let pattern = swarm.everything();
    let key = KeyExpr::try_from(pattern.as_str().to_owned())
        .map_err(|e| super::text::backend("name key", None, Some(&pattern), &e))?;
    // Every robot's topics share this one queue: room for `buffer` each of
    // a few hundred topics before the oldest message is dropped.
    let capacity = config.limits.buffer.saturating_mul(256);
    let inner = session
        .declare_subscriber(key)
        .with(RingChannel::new(capacity))
        .wait()
        .map_err(|e| super::text::backend("open subscriber", None, Some(&pattern), &e))?;
    Ok(SwarmSubscriber { inner, swarm: *swarm })
}

/// Publisher of a [`super::ZenohBus`].
pub struct ZenohPublisher {
    inner: Publisher<'static>,
    id: [u8; 8],
    topic: TopicName,
    max_payload: usize,
}

impl Publish for ZenohPublisher {
    fn publish(&self, payload: &[u8]) -> Result<(), BusError> {
        if payload.len() > self.max_payload {
            return Err(BusError::PayloadTooLarge { len: payload.len(), max: self.max_payload });
        }
        self.inner
            .put(payload)
            .attachment(self.id)
            .wait()
            .map_err(|e| super::text::backend("publish", Some(self.topic.as_str().to_owned()), None, &e))
    }
}

/// Subscriber of a [`super::ZenohBus`] (of one topic, or of several: a
/// fan-in); dropping it undeclares it.
pub struct ZenohSubscriber {
    _inner: Vec<Subscriber<()>>,
    inbox: Arc<Inbox>,
    max_payload: usize,
}

impl Subscribe for ZenohSubscriber {
    fn max_payload(&self) -> usize {
        self.max_payload
    }

    fn try_recv_into(&self, buf: &mut [u8]) -> Result<Option<usize>, BusError> {
        self.inbox.try_pop_into(buf)
    }

    fn recv_timeout_into(&self, buf: &mut [u8], timeout: Duration) -> Result<Option<usize>, BusError> {
        self.inbox.pop_timeout_into(buf, timeout)
    }
}

/// One message seen by a [`SwarmSubscriber`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SwarmMessage {
    /// The key it was published on.
    pub key: String,
    /// Which topic of the swarm that is; `None` for keys under the swarm
    /// that the naming module does not know.
    pub route: Option<Route>,
    /// The payload (one encoded message).
    pub payload: Vec<u8>,
}

/// Every message of one swarm (`bycoms/<swarm>/**`), with its topic.
pub struct SwarmSubscriber {
    inner: Subscriber<RingChannelHandler<Sample>>,
    swarm: Swarm,
}

impl SwarmSubscriber {
    fn convert(&self, sample: Sample) -> SwarmMessage {
        let key = sample.key_expr().as_str().to_owned();
        SwarmMessage { route: self.swarm.route(&key), key, payload: sample.payload().to_bytes().into_owned() }
    }

    /// The next message, waiting up to `timeout`; `None` when it passed.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Option<SwarmMessage>, BusError> {
        match self.inner.handler().recv_timeout(timeout) {
            Ok(sample) => Ok(sample.map(|s| self.convert(s))),
            Err(e) => Err(super::text::backend("receive", None, None, &e)),
        }
    }

    /// The next message if one is pending.
    pub fn try_recv(&self) -> Result<Option<SwarmMessage>, BusError> {
        match self.inner.handler().try_recv() {
            Ok(sample) => Ok(sample.map(|s| self.convert(s))),
            Err(e) => Err(super::text::backend("receive", None, None, &e)),
        }
    }
}
