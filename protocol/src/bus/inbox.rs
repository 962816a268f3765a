//! A subscriber's inbox: the bounded per-publisher FIFO that the in-memory
//! and zenoh backends share.
//!
//! Why shared: both backends get messages pushed from another thread (the
//! publisher's, or zenoh's network task) and must keep the same contract
//! (see [`crate::bus`]): per-publisher order, at most [`Limits::buffer`]
//! unread messages per publisher with the oldest overwritten, and a
//! receiver that can wait with a timeout. One mutex-protected queue and a
//! condvar do that; the publisher side never blocks for longer than one
//! queue push.
//!
//! [`Limits::buffer`]: super::Limits::buffer

use super::{copy_out, BusError};
use core::time::Duration;
use std::collections::VecDeque;
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::Instant;

/// Locks a mutex even if a panicking thread poisoned it: the queue stays
/// consistent between statements, so the data is usable.
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Unread messages of one subscriber, tagged with their publisher.
pub(crate) struct Inbox {
    queue: Mutex<VecDeque<(u64, Vec<u8>)>>,
    ready: Condvar,
    buffer: usize,
}

impl Inbox {
    /// An empty inbox holding up to `buffer` messages per publisher.
    pub(crate) fn new(buffer: usize) -> Self {
        Self { queue: Mutex::new(VecDeque::new()), ready: Condvar::new(), buffer }
    }

    /// Appends a message of `publisher`, dropping that publisher's oldest
    /// unread message when it already has `buffer` of them.
    pub(crate) fn push(&self, publisher: u64, payload: &[u8]) {
        self.push_parts(publisher, &[], payload);
    }

    /// [`Inbox::push`] for a fan-in: the message is the topic's index
    /// `tag` ([`super::FAN_IN_TAG`] bytes) followed by the payload.
    pub(crate) fn push_tagged(&self, publisher: u64, tag: u32, payload: &[u8]) {
        self.push_parts(publisher, &tag.to_le_bytes(), payload);
    }

    fn push_parts(&self, publisher: u64, head: &[u8], payload: &[u8]) {
        let mut message = Vec::with_capacity(head.len() + payload.len());
        message.extend_from_slice(head);
        message.extend_from_slice(payload);
        let mut queue = lock(&self.queue);
        let pending = queue.iter().filter(|(p, _)| *p == publisher).count();
        if pending >= self.buffer {
            if let Some(oldest) = queue.iter().position(|(p, _)| *p == publisher) {
                queue.remove(oldest);
            }
        }
        queue.push_back((publisher, message));
        // Wake after unlocking: a waiter woken under the lock would only
        // block again on the mutex (one more sleep and wake per message).
        // Every waiter takes one message, so one wake per message suffices.
        drop(queue);
        self.ready.notify_one();
    }

    /// Takes the oldest message into `buf`, if there is one.
    pub(crate) fn try_pop_into(&self, buf: &mut [u8]) -> Result<Option<usize>, BusError> {
        match lock(&self.queue).pop_front() {
            Some((_, payload)) => copy_out(&payload, buf).map(Some),
            None => Ok(None),
        }
    }

    /// Takes the oldest message into `buf`, waiting up to `timeout`.
    pub(crate) fn pop_timeout_into(
        &self,
        buf: &mut [u8],
        timeout: Duration,
    ) -> Result<Option<usize>, BusError> {
        let deadline = Instant::now().checked_add(timeout);
        let mut queue = lock(&self.queue);
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
                .ready
                .wait_timeout(queue, left)
                .map(|(guard, _)| guard)
                .unwrap_or_else(|poisoned| poisoned.into_inner().0);
        }
    }
}
