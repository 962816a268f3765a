//! Typed publish/subscribe: the one codec over the byte-level bus.
//!
//! Why a separate layer: backends only move bytes, so they stay small and
//! the conformance suite can test them with raw payloads. Processes use
//! this layer instead, with the topics of [`crate::naming`], which carry
//! their message type: `bus.typed_publisher(&swarm.gate())` can only
//! publish [`crate::msg::GateEvent`]s. Messages are encoded into a stack
//! buffer of [`MAX_MESSAGE_LEN`] bytes; nothing is allocated per message.

use super::{Bus, BusError, Publish, Subscribe};
use crate::naming::Topic;
use crate::{decode, encode, Message, MAX_MESSAGE_LEN};
use core::marker::PhantomData;
use core::time::Duration;

/// Publishes messages of type `M`.
pub struct TypedPublisher<P, M> {
    inner: P,
    _message: PhantomData<fn(M)>,
}

impl<P: Publish, M: Message> TypedPublisher<P, M> {
    /// Wraps a byte publisher.
    pub fn new(inner: P) -> Self {
        Self { inner, _message: PhantomData }
    }

    /// Encodes and publishes one message.
    pub fn publish(&self, msg: &M) -> Result<(), BusError> {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        let bytes = encode(msg, &mut buf)?;
        self.inner.publish(bytes)
    }

    /// Encodes and publishes one message without waking sleeping readers:
    /// another publish on this topic follows at once
    /// ([`Publish::publish_quietly`]).
    pub fn publish_quietly(&self, msg: &M) -> Result<(), BusError> {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        let bytes = encode(msg, &mut buf)?;
        self.inner.publish_quietly(bytes)
    }

    /// The byte publisher underneath.
    pub fn inner(&self) -> &P {
        &self.inner
    }
}

/// Receives messages of type `M`.
pub struct TypedSubscriber<S, M> {
    inner: S,
    _message: PhantomData<fn() -> M>,
}

impl<S: Subscribe, M: Message> TypedSubscriber<S, M> {
    /// Wraps a byte subscriber.
    pub fn new(inner: S) -> Self {
        Self { inner, _message: PhantomData }
    }

    /// The next message, if one is pending. A message that does not decode
    /// is consumed and reported as [`BusError::Codec`]; the next call goes
    /// on with the following message.
    pub fn try_recv(&self) -> Result<Option<M>, BusError> {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        match self.inner.try_recv_into(&mut buf)? {
            Some(n) => Ok(Some(decode(&buf[..n])?)),
            None => Ok(None),
        }
    }

    /// The next message, waiting up to `timeout`; `None` when it passed.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Option<M>, BusError> {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        match self.inner.recv_timeout_into(&mut buf, timeout)? {
            Some(n) => Ok(Some(decode(&buf[..n])?)),
            None => Ok(None),
        }
    }

    /// [`TypedSubscriber::recv_timeout`] for a reader that expects nothing
    /// soon ([`Subscribe::recv_idle_into`]).
    pub fn recv_idle(&self, timeout: Duration) -> Result<Option<M>, BusError> {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        match self.inner.recv_idle_into(&mut buf, timeout)? {
            Some(n) => Ok(Some(decode(&buf[..n])?)),
            None => Ok(None),
        }
    }

    /// The byte subscriber underneath.
    pub fn inner(&self) -> &S {
        &self.inner
    }
}

/// Receives messages of type `M` from several topics at once (a fan-in),
/// each with the index of its topic.
pub struct TypedFanIn<S, M> {
    inner: S,
    _message: PhantomData<fn() -> M>,
}

impl<S: Subscribe, M: Message> TypedFanIn<S, M> {
    /// Wraps a byte fan-in ([`Bus::fan_in`]).
    pub fn new(inner: S) -> Self {
        Self { inner, _message: PhantomData }
    }

    /// The next message and its topic's index, waiting up to `timeout`;
    /// `None` when it passed. A message that does not decode is consumed
    /// and reported as [`BusError::Codec`].
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Option<(usize, M)>, BusError> {
        let mut buf = [0u8; MAX_MESSAGE_LEN + super::FAN_IN_TAG];
        match self.inner.recv_timeout_into(&mut buf, timeout)? {
            Some(n) => {
                let (topic, payload) =
                    super::untag(&buf[..n]).ok_or(BusError::Codec(crate::CodecError::Truncated))?;
                Ok(Some((topic, decode(payload)?)))
            }
            None => Ok(None),
        }
    }

    /// [`TypedFanIn::recv_timeout`] without waiting.
    pub fn try_recv(&self) -> Result<Option<(usize, M)>, BusError> {
        self.recv_timeout(Duration::ZERO)
    }
}

/// Typed constructors on every [`Bus`].
pub trait BusExt: Bus {
    /// A publisher for the message type of `topic`.
    fn typed_publisher<M: Message>(
        &self,
        topic: &Topic<M>,
    ) -> Result<TypedPublisher<Self::Publisher, M>, BusError> {
        Ok(TypedPublisher::new(self.publisher(topic.name())?))
    }

    /// A subscriber for the message type of `topic`.
    fn typed_subscriber<M: Message>(
        &self,
        topic: &Topic<M>,
    ) -> Result<TypedSubscriber<Self::Subscriber, M>, BusError> {
        Ok(TypedSubscriber::new(self.subscriber(topic.name())?))
    }

    /// One receiver of the message type of `topics`, for all of them.
    fn typed_fan_in<M: Message>(&self, topics: &[Topic<M>]) -> Result<TypedFanIn<Self::FanIn, M>, BusError> {
        let names: Vec<_> = topics.iter().map(|t| *t.name()).collect();
        Ok(TypedFanIn::new(self.fan_in(&names)?))
    }
}

impl<B: Bus + ?Sized> BusExt for B {}
