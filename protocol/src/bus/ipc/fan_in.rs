//! The iceoryx2 fan-in: one receiver of many topics that share a doorbell.
//!
//! Why hints: the orchestrator reads every robot's report topic, up to a
//! thousand of them; polling each subscriber for every message cost about
//! 0.4 ms per message at 1000 topics (a round trip 17× the plain one,
//! `protocol/benches/bus_hop.rs`). A topic's publisher rings the shared
//! doorbell with its member's event id ([`TopicName::doorbell_member`], the
//! robot id, folded onto 63 event ids: `ports::member_event_id`), so the
//! fan-in reads only the topics that share the id that rang (1 at up to 63
//! robots, 16 at 1000). A notification
//! without a known id, a wait that ended without one, a reader that only
//! ever looks without waiting and has not looked everywhere for a wait
//! slice, and a bus without event wake-ups fall back to one round over
//! every topic, so nothing is ever left unread for longer than one wait
//! slice.
//!
//! Why a small fan-in skips the doorbell when it looks: reading the
//! doorbell without waiting is a swap of each of its 64 event counters and,
//! in iceoryx2 0.10, six system calls when nothing rang (its `try_wait`
//! and then its `empty_buffer` each set the socket non-blocking with two
//! `fcntl` and try a `recvfrom`): a few µs. A look at a topic's queue in
//! shared memory is tens of ns. A fan-in of at most [`SMALL`] topics (a
//! launch of up to 16 robots: its reports and its poses) therefore looks
//! at every topic instead, and reads the doorbell only when it sleeps on
//! it. That also spares the
//! publishers: iceoryx2 sends a notification (a `sendto`) only to a
//! listener that has taken the last one, so a doorbell left unread until
//! its reader sleeps costs its ringers nothing meanwhile. `perf sched` of
//! `bench launch`: the orchestrator and the moving robot's agent take
//! turns on one core, 12 and 6 µs a tick, and the orchestrator read its
//! doorbells about seven times a tick (issue 35).

use super::ports::{
    event_wait, member_event_id, pubsub_service, service_name, wait_for, waker, Bells, Slept, Waker,
    EVENT_WAIT_SLICE, EVERY_MEMBER,
};
use super::IpcConfig;
use crate::bus::{copy_out, BusError, Subscribe, FAN_IN_TAG};
use crate::naming::TopicName;
use core::cell::{Cell, RefCell};
use core::time::Duration;
use iceoryx2::port::listener::ListenerWaitError;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::Node;
use iceoryx2::service::Service as IoxService;
use std::collections::{BTreeMap, VecDeque};
use std::time::Instant;

/// The most topics a fan-in looks at one by one rather than read its
/// doorbell first (see the module docs). Why 16: a lockstep launch of 10
/// robots (`bench crowd`'s stuck crowd) had its ticks' median fall from
/// 15–18 to 9–10 µs with 16 instead of 8; at 50 robots, looking at all 50
/// topics (with 64) was no faster, and four ticks in four launches took
/// about 12 ms each (issue 35, docs/BENCHMARKS.md "Ninth pass").
pub(super) const SMALL: usize = 16;

/// A fan-in (see [`crate::bus::Bus::fan_in`]): one subscriber per topic,
/// woken by the topics' shared doorbell.
pub(super) fn open_fan_in<S: IoxService>(
    node: &Node<S>,
    config: &IpcConfig,
    topics: &[TopicName],
    bells: &Bells<S>,
) -> Result<IpcFanIn<S>, BusError> {
    let Some(first) = topics.first() else {
        return Err(BusError::InvalidConfig("a fan-in needs at least one topic"));
    };
    let bell = first.doorbell();
    if topics.iter().any(|t| t.doorbell() != bell) {
        return Err(BusError::InvalidConfig("the topics of a fan-in must share one doorbell"));
    }
    if u32::try_from(topics.len()).is_err() {
        return Err(BusError::InvalidConfig("more than 2^32 topics in a fan-in"));
    }
    let subscribers = topics
        .iter()
        .map(|topic| {
            pubsub_service(node, config, topic, &service_name(topic)?)?
                .subscriber_builder()
                .buffer_size(config.limits.buffer)
                .create()
                .map_err(|e| BusError::backend("create subscriber", Some(topic), e))
        })
        .collect::<Result<Vec<_>, BusError>>()?;
    let mut members: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (i, topic) in topics.iter().enumerate() {
        if let Some(m) = topic.doorbell_member() {
            members.entry(member_event_id(m)).or_default().push(i);
        }
    }
    Ok(IpcFanIn {
        subscribers,
        members,
        waker: waker(node, config, &bell, Some(EVERY_MEMBER), bells)?,
        bell,
        rang: RefCell::new(VecDeque::new()),
        queued: RefCell::new(vec![false; topics.len()]),
        round: Cell::new(true),
        last_round: Cell::new(Instant::now()),
        next: Cell::new(0),
        max_payload: config.limits.max_payload + FAN_IN_TAG,
    })
}

/// A fan-in of an [`super::IceoryxBus`]: subscribers of several topics
/// that share one doorbell, read where the doorbell says.
pub struct IpcFanIn<S: IoxService> {
    subscribers: Vec<Subscriber<S, [u8], ()>>,
    /// An event id → the indices of the topics whose members ring with it.
    members: BTreeMap<usize, Vec<usize>>,
    waker: Waker<S>,
    bell: TopicName,
    /// Topics that rang and may hold messages, oldest first, each once.
    rang: RefCell<VecDeque<usize>>,
    /// Whether topic i is in `rang`, at i.
    queued: RefCell<Vec<bool>>,
    /// Whether a round over every topic is due.
    round: Cell<bool>,
    /// When the last round found every topic empty.
    last_round: Cell<Instant>,
    /// Where the next round starts (no topic starves another).
    next: Cell<usize>,
    max_payload: usize,
}

impl<S: IoxService> IpcFanIn<S> {
    /// Notes which topics rang (a ring without a known member asks for a
    /// round).
    fn note(&self, id: usize) {
        let Some(topics) = self.members.get(&id) else { return self.round.set(true) };
        let mut queued = self.queued.borrow_mut();
        let mut rang = self.rang.borrow_mut();
        for &i in topics {
            // A topic already queued is read until empty anyway.
            if let Some(q) = queued.get_mut(i).filter(|q| !**q) {
                *q = true;
                rang.push_back(i);
            }
        }
    }

    /// The next message of a topic that rang, each read until empty, oldest
    /// ring first.
    fn take_rung(&self, buf: &mut [u8]) -> Result<Option<usize>, BusError> {
        loop {
            let Some(i) = self.rang.borrow().front().copied() else { return Ok(None) };
            if let Some(n) = self.take(i, buf)? {
                return Ok(Some(n));
            }
            self.rang.borrow_mut().pop_front();
            if let Some(q) = self.queued.borrow_mut().get_mut(i) {
                *q = false;
            }
        }
    }

    /// Forgets which topics rang (a small fan-in looks at all of them).
    fn forget_rings(&self) {
        self.rang.borrow_mut().clear();
        self.queued.borrow_mut().fill(false);
    }

    /// Takes the rings that came, without waiting.
    fn take_rings(&self) -> Result<(), BusError> {
        match &self.waker {
            Waker::Event { listener, .. } => {
                listener
                    .get()?
                    .try_wait(|a| self.note(a.id.as_value()))
                    .map_err(|e| BusError::backend("read doorbell", Some(&self.bell), e))?;
            }
            Waker::Poll { .. } => self.round.set(true),
        }
        Ok(())
    }

    /// The next message of topic `i` into `buf`, tagged.
    fn take(&self, i: usize, buf: &mut [u8]) -> Result<Option<usize>, BusError> {
        let Some(subscriber) = self.subscribers.get(i) else { return Ok(None) };
        match subscriber.receive() {
            Ok(Some(sample)) => {
                let len = sample.payload().len() + FAN_IN_TAG;
                let (tag, rest) = buf
                    .split_first_chunk_mut::<FAN_IN_TAG>()
                    .ok_or(BusError::BufferTooSmall { len, capacity: 0 })?;
                *tag = (i as u32).to_le_bytes();
                copy_out(sample.payload(), rest).map(|n| Some(n + FAN_IN_TAG))
            }
            Ok(None) => Ok(None),
            Err(e) => Err(BusError::backend("receive", Some(&self.bell), e)),
        }
    }

    /// The next message of any topic, one round from where the last one
    /// ended (no topic starves another).
    fn look_everywhere(&self, buf: &mut [u8]) -> Result<Option<usize>, BusError> {
        let n = self.subscribers.len();
        let first = self.next.get();
        for k in 0..n {
            let i = (first + k) % n;
            if let Some(len) = self.take(i, buf)? {
                self.next.set((i + 1) % n);
                return Ok(Some(len));
            }
        }
        Ok(None)
    }

    /// Sleeps on the doorbell for at most `left`, noting who rang.
    fn sleep(&self, left: Duration, poll_sleep: &mut Duration) -> Result<Slept, BusError> {
        match &self.waker {
            Waker::Event { listener, .. } => {
                match listener.get()?.timed_wait(|a| self.note(a.id.as_value()), event_wait(left)) {
                    // Nothing rang for a whole slice: look everywhere once.
                    Ok(0) => {
                        self.round.set(true);
                        Ok(Slept::Again)
                    }
                    Ok(_) => Ok(Slept::Again),
                    Err(ListenerWaitError::InterruptSignal) => Ok(Slept::Interrupted),
                    Err(e) => Err(BusError::backend("wait for event", Some(&self.bell), e)),
                }
            }
            Waker::Poll { .. } => {
                let slept = self.waker.sleep(&self.bell, left, poll_sleep, false);
                self.round.set(true);
                slept
            }
        }
    }
}

impl<S: IoxService> Subscribe for IpcFanIn<S> {
    fn max_payload(&self) -> usize {
        self.max_payload
    }

    fn try_recv_into(&self, buf: &mut [u8]) -> Result<Option<usize>, BusError> {
        if self.subscribers.len() <= SMALL {
            // Every topic, no doorbell (see the module docs); what rang
            // while it slept is among them.
            self.forget_rings();
            return self.look_everywhere(buf);
        }
        // The topics known to have rung first: the doorbell is read (a
        // system call and a swap of each event counter) only once they are
        // empty, so a burst of answers costs one read, not one per message.
        if let Some(n) = self.take_rung(buf)? {
            return Ok(Some(n));
        }
        self.take_rings()?;
        if let Some(n) = self.take_rung(buf)? {
            return Ok(Some(n));
        }
        if !self.round.get() {
            if self.last_round.get().elapsed() < EVENT_WAIT_SLICE {
                return Ok(None);
            }
            // A ring may have been lost (a publisher that does not ring):
            // look everywhere once a slice, waiting or not.
            self.round.set(true);
        }
        let got = self.look_everywhere(buf)?;
        if got.is_none() {
            self.round.set(false);
            self.last_round.set(Instant::now());
        }
        Ok(got)
    }

    fn recv_timeout_into(&self, buf: &mut [u8], timeout: Duration) -> Result<Option<usize>, BusError> {
        if let Waker::Event { listener, .. } = &self.waker {
            // Listen before looking, so nothing sent after the look is
            // slept through (a small fan-in reads its doorbell only here).
            listener.get()?;
        }
        let sleep = |left, poll_sleep: &mut Duration| self.sleep(left, poll_sleep);
        wait_for(self.waker.spin(), buf, timeout, |buf| self.try_recv_into(buf), sleep)
    }
}
