//! In-memory backend: the bus inside one process, for tests and for the
//! in-process runner.
//!
//! Why it exists: tests of the orchestrator and agents should not depend on
//! shared memory or a network, yet must see the same semantics as the real
//! transports; the conformance suite holds it to the same contract as
//! iceoryx2 (see [`crate::bus`]). A [`MemoryBus`] is cheap to clone; clones
//! share one hub, so threads holding clones talk to each other. Everything
//! is `Send + Sync`.
//!
//! Model: each subscriber owns an inbox (one FIFO, a mutex and a condvar).
//! Publishing copies the payload into the inbox of every live subscriber of
//! the topic; when one publisher already has [`Limits::buffer`] unread
//! messages in an inbox, its oldest is dropped, like iceoryx2's safe
//! overflow.

use super::inbox::{lock, Inbox};
use super::{Bus, BusError, Limits, Publish, Subscribe};
use crate::naming::TopicName;
use core::sync::atomic::{AtomicU64, Ordering};
use core::time::Duration;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, Weak};

/// An inbox of a topic, and the tag its messages get there (`None`: a
/// subscriber's, untagged; `Some(i)`: a fan-in's, topic index `i`).
type Reader = (Weak<Inbox>, Option<u32>);

#[derive(Default)]
struct Hub {
    topics: Mutex<HashMap<TopicName, Vec<Reader>>>,
    next_publisher: AtomicU64,
}

/// The in-memory bus. Clones share the same topics.
#[derive(Clone, Default)]
pub struct MemoryBus {
    hub: Arc<Hub>,
    limits: Limits,
}

impl MemoryBus {
    /// A new, empty bus with the given limits.
    pub fn new(limits: Limits) -> Result<Self, BusError> {
        if limits.max_payload == 0 {
            return Err(BusError::InvalidConfig("max_payload must be at least 1"));
        }
        if limits.buffer == 0 {
            return Err(BusError::InvalidConfig("buffer must be at least 1"));
        }
        Ok(Self { hub: Arc::default(), limits })
    }
}

impl Bus for MemoryBus {
    type Publisher = MemoryPublisher;
    type Subscriber = MemorySubscriber;
    type FanIn = MemorySubscriber;

    fn publisher(&self, topic: &TopicName) -> Result<MemoryPublisher, BusError> {
        Ok(MemoryPublisher {
            hub: Arc::clone(&self.hub),
            topic: *topic,
            id: self.hub.next_publisher.fetch_add(1, Ordering::Relaxed),
            max_payload: self.limits.max_payload,
        })
    }

    fn subscriber(&self, topic: &TopicName) -> Result<MemorySubscriber, BusError> {
        let inbox = Arc::new(Inbox::new(self.limits.buffer));
        lock(&self.hub.topics).entry(*topic).or_default().push((Arc::downgrade(&inbox), None));
        Ok(MemorySubscriber { inbox, max_payload: self.limits.max_payload })
    }

    fn fan_in(&self, topics: &[TopicName]) -> Result<MemorySubscriber, BusError> {
        let inbox = Arc::new(Inbox::new(self.limits.buffer));
        let mut hub = lock(&self.hub.topics);
        for (i, topic) in topics.iter().enumerate() {
            let tag =
                u32::try_from(i).map_err(|_| BusError::InvalidConfig("more than 2^32 topics in a fan-in"))?;
            hub.entry(*topic).or_default().push((Arc::downgrade(&inbox), Some(tag)));
        }
        Ok(MemorySubscriber { inbox, max_payload: self.limits.max_payload + super::FAN_IN_TAG })
    }

    fn limits(&self) -> Limits {
        self.limits
    }
}

/// Publisher of a [`MemoryBus`].
pub struct MemoryPublisher {
    hub: Arc<Hub>,
    topic: TopicName,
    id: u64,
    max_payload: usize,
}

impl Publish for MemoryPublisher {
    fn publish(&self, payload: &[u8]) -> Result<(), BusError> {
        if payload.len() > self.max_payload {
            return Err(BusError::PayloadTooLarge { len: payload.len(), max: self.max_payload });
        }
        let mut topics = lock(&self.hub.topics);
        if let Some(inboxes) = topics.get_mut(&self.topic) {
            inboxes.retain(|(weak, tag)| match weak.upgrade() {
                Some(inbox) => {
                    match tag {
                        Some(tag) => inbox.push_tagged(self.id, *tag, payload),
                        None => inbox.push(self.id, payload),
                    }
                    true
                }
                None => false,
            });
        }
        Ok(())
    }
}

/// Subscriber of a [`MemoryBus`].
pub struct MemorySubscriber {
    inbox: Arc<Inbox>,
    max_payload: usize,
}

impl Subscribe for MemorySubscriber {
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
