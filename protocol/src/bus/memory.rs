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

use super::{copy_out, Bus, BusError, Limits, Publish, Subscribe};
use crate::naming::TopicName;
use core::sync::atomic::{AtomicU64, Ordering};
use core::time::Duration;
use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, Weak};
use std::time::Instant;

/// Locks a mutex even if a panicking thread poisoned it: the inbox and the
/// topic table stay consistent at every await point, so the data is usable.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

#[derive(Default)]
struct Hub {
    topics: Mutex<HashMap<TopicName, Vec<Weak<Inbox>>>>,
    next_publisher: AtomicU64,
}

struct Inbox {
    queue: Mutex<VecDeque<(u64, Vec<u8>)>>,
    ready: Condvar,
    buffer: usize,
}

impl Inbox {
    fn push(&self, publisher: u64, payload: &[u8]) {
        let mut queue = lock(&self.queue);
        let pending = queue.iter().filter(|(p, _)| *p == publisher).count();
        if pending >= self.buffer {
            if let Some(oldest) = queue.iter().position(|(p, _)| *p == publisher) {
                queue.remove(oldest);
            }
        }
        queue.push_back((publisher, payload.to_vec()));
        self.ready.notify_all();
    }
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

    fn publisher(&self, topic: &TopicName) -> Result<MemoryPublisher, BusError> {
        Ok(MemoryPublisher {
            hub: Arc::clone(&self.hub),
            topic: *topic,
            id: self.hub.next_publisher.fetch_add(1, Ordering::Relaxed),
            max_payload: self.limits.max_payload,
        })
    }

    fn subscriber(&self, topic: &TopicName) -> Result<MemorySubscriber, BusError> {
        let inbox = Arc::new(Inbox {
            queue: Mutex::new(VecDeque::new()),
            ready: Condvar::new(),
            buffer: self.limits.buffer,
        });
        lock(&self.hub.topics).entry(*topic).or_default().push(Arc::downgrade(&inbox));
        Ok(MemorySubscriber { inbox, max_payload: self.limits.max_payload })
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
            inboxes.retain(|weak| match weak.upgrade() {
                Some(inbox) => {
                    inbox.push(self.id, payload);
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
        match lock(&self.inbox.queue).pop_front() {
            Some((_, payload)) => copy_out(&payload, buf).map(Some),
            None => Ok(None),
        }
    }

    fn recv_timeout_into(&self, buf: &mut [u8], timeout: Duration) -> Result<Option<usize>, BusError> {
        let deadline = Instant::now().checked_add(timeout);
        let mut queue = lock(&self.inbox.queue);
        loop {
            if let Some((_, payload)) = queue.pop_front() {
                return copy_out(&payload, buf).map(Some);
            }
            let now = Instant::now();
            let left = match deadline {
                Some(d) if d <= now => return Ok(None),
                Some(d) => d - now,
                // A timeout too large for `Instant`: wait in long slices.
                None => Duration::from_secs(3600),
            };
            queue = self
                .inbox
                .ready
                .wait_timeout(queue, left)
                .map(|(guard, _)| guard)
                .unwrap_or_else(|poisoned| poisoned.into_inner().0);
        }
    }
}
