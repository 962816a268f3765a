//! iceoryx2 publisher and subscriber ports behind the byte-level traits.
//!
//! Why the wait loop looks like this: a receive from shared memory costs
//! tens of nanoseconds, a sleep and wake-up through the kernel costs
//! microseconds. A subscriber that finds nothing therefore busy-waits for a
//! short budget (most lockstep replies arrive within it), then sleeps until
//! a publisher's notification or its own deadline. No wait is ever
//! unbounded, and a sleep on the event listener is capped at
//! [`EVENT_WAIT_SLICE`] so a publisher that never notifies (one configured
//! with [`Wake::Poll`]) still gets through, and floored at
//! [`MIN_EVENT_WAIT`] because iceoryx2 turns a shorter timeout into none
//! (a wait without end).

use super::{IpcConfig, Wake};
use crate::bus::{copy_out, BusError, Publish, Subscribe};
use crate::naming::TopicName;
use core::cell::OnceCell;
use core::time::Duration;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::{ListenerKey, Notifier, NotifierNotifyError};
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{AllocationStrategy, CallbackProgression, EventId, Node, PortName, ServiceName};
use iceoryx2::service::port_factory::{event, publish_subscribe, PortFactory as _};
use iceoryx2::service::Service as IoxService;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

/// Longest single sleep on an event listener.
pub const EVENT_WAIT_SLICE: Duration = Duration::from_millis(10);
/// Shortest sleep on an event listener: iceoryx2 0.10 waits on a Unix
/// datagram socket whose `SO_RCVTIMEO` it sets from the timeout truncated
/// to whole microseconds (`AsTimeval` in iceoryx2-bb-posix), and a zero
/// `SO_RCVTIMEO` means "never time out". A wait of 1 to 999 ns therefore
/// blocked until the next notification, forever if none came.
pub const MIN_EVENT_WAIT: Duration = Duration::from_micros(1);
/// First sleep of [`Wake::Poll`] after the spin budget.
const POLL_FIRST_SLEEP: Duration = Duration::from_micros(20);
/// Stand-in deadline for timeouts too large for `Instant`.
const FAR_FUTURE: Duration = Duration::from_secs(3600);

pub(super) fn pubsub_service<S: IoxService>(
    node: &Node<S>,
    config: &IpcConfig,
    topic: &TopicName,
    name: &ServiceName,
) -> Result<publish_subscribe::PortFactory<S, [u8], ()>, BusError> {
    let (publishers, subscribers) = config.ports_of(topic);
    node.service_builder(name)
        .publish_subscribe::<[u8]>()
        .history_size(0)
        .subscriber_max_buffer_size(config.limits.buffer)
        .enable_safe_overflow(true)
        .max_publishers(publishers)
        .max_subscribers(subscribers)
        .max_nodes(config.max_nodes)
        .open_or_create()
        .map_err(|e| BusError::backend("open publish-subscribe service", Some(topic), e))
}

/// The largest event id of every event service: a report topic rings its
/// doorbell with its robot's id (up to the bus's publisher limit, which
/// grows with the swarm), so a fan-in knows which topic to read.
pub(super) fn event_id_max(config: &IpcConfig) -> usize {
    config.max_publishers.max(255)
}

pub(super) fn event_service<S: IoxService>(
    node: &Node<S>,
    config: &IpcConfig,
    topic: &TopicName,
    name: &ServiceName,
) -> Result<event::PortFactory<S>, BusError> {
    let (publishers, subscribers) = config.ports_of(topic);
    node.service_builder(name)
        .event()
        .event_id_max_value(event_id_max(config))
        .max_notifiers(publishers)
        .max_listeners(subscribers)
        .max_nodes(config.max_nodes)
        .open_or_create()
        .map_err(|e| BusError::backend("open event service", Some(topic), e))
}

pub(super) fn open_publisher<S: IoxService>(
    node: &Node<S>,
    config: &IpcConfig,
    topic: &TopicName,
    name: &ServiceName,
    bells: &Bells<S>,
) -> Result<IpcPublisher<S>, BusError> {
    let publisher = pubsub_service(node, config, topic, name)?
        .publisher_builder()
        .initial_max_slice_len(config.limits.max_payload)
        .allocation_strategy(AllocationStrategy::Static)
        .create()
        .map_err(|e| BusError::backend("create publisher", Some(topic), e))?;
    let ring = match (config.wake, topic.doorbell_member()) {
        (Wake::Poll { .. }, _) => Ring::Nobody,
        (Wake::Event { .. }, Some(member)) => Ring::Member { bell: bells.bell(node, config, topic)?, member },
        (Wake::Event { .. }, None) => Ring::Everyone(
            event_service(node, config, topic, name)?
                .notifier_builder()
                .create()
                .map_err(|e| BusError::backend("create notifier", Some(topic), e))?,
        ),
    };
    Ok(IpcPublisher { publisher, ring, topic: *topic, max_payload: config.limits.max_payload })
}

/// The shared ringers of a bus's doorbell families, one per family (see
/// [`Bell`]), made when the bus's first publisher of the family opens.
pub(super) struct Bells<S: IoxService> {
    open: Mutex<std::collections::HashMap<TopicName, Arc<Bell<S>>>>,
}

impl<S: IoxService> Default for Bells<S> {
    fn default() -> Self {
        Self { open: Mutex::new(std::collections::HashMap::new()) }
    }
}

impl<S: IoxService> Bells<S> {
    /// The ringer of `topic`'s doorbell family.
    fn bell(&self, node: &Node<S>, config: &IpcConfig, topic: &TopicName) -> Result<Arc<Bell<S>>, BusError> {
        let doorbell = topic.doorbell();
        let mut open = self.open.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(bell) = open.get(&doorbell) {
            return Ok(Arc::clone(bell));
        }
        let service = event_service(node, config, &doorbell, &service_name(&doorbell)?)?;
        let notifier = service
            .notifier_builder()
            .create()
            .map_err(|e| BusError::backend("create notifier", Some(&doorbell), e))?;
        let bell = Arc::new(Bell {
            id_max: event_id_max(config),
            service,
            notifier,
            doorbell,
            listeners: Mutex::new(Listeners::default()),
        });
        open.insert(doorbell, Arc::clone(&bell));
        Ok(bell)
    }
}

/// How often a [`Bell`] looks again at who listens, whatever happened.
const LOOK_AGAIN: Duration = Duration::from_millis(100);
/// How often, at most, a [`Bell`] looks for a member it knows no listener
/// of (a topic nobody reads yet must not cost a look at every send).
const LOOK_FOR_MISSING: Duration = Duration::from_millis(10);

/// One notifier on a doorbell family's event service, shared by every
/// publisher of the family in this bus, that wakes only the readers of the
/// member that sent and the family's fan-ins.
///
/// Why: a notifier holds a socket per listener, so one notifier per
/// publisher on a family with a listener per robot (every agent listens on
/// `to_agents`) would hold n² sockets; and a plain notify wakes every
/// listener of the service, so every agent would wake for every other's
/// command. Listeners are named by what they read (`PortName`): a
/// subscriber by its topic's member id (`"7"`), a fan-in `"*"`; any other
/// name is woken by every ring. The keys of the listeners are looked up
/// when the number of listeners changes, when a key turns out stale, when a
/// member has none (at most every [`LOOK_FOR_MISSING`]) and every
/// [`LOOK_AGAIN`]. A reader the bell missed still wakes within one
/// [`EVENT_WAIT_SLICE`].
pub(super) struct Bell<S: IoxService> {
    service: event::PortFactory<S>,
    notifier: Notifier<S>,
    doorbell: TopicName,
    id_max: usize,
    listeners: Mutex<Listeners>,
}

/// Who listens on a [`Bell`]'s doorbell, as last looked up.
#[derive(Default)]
struct Listeners {
    /// A member id → its readers' listeners.
    members: BTreeMap<u32, Vec<ListenerKey>>,
    /// Listeners woken by every ring (fan-ins, unnamed).
    everyone: Vec<ListenerKey>,
    /// The number of listeners at the last look.
    count: usize,
    looked: Option<Instant>,
    stale: bool,
}

/// The name of a listener that reads every member of its family.
pub(super) const EVERY_MEMBER: &str = "*";

impl<S: IoxService> Bell<S> {
    /// Wakes the readers of `member` and the family's fan-ins.
    fn ring(&self, member: u32) -> Result<(), BusError> {
        let id = member as usize;
        if id > self.id_max {
            // An id the event service cannot carry: wake everyone, who look
            // at every topic when the id is not theirs.
            return self
                .notifier
                .notify()
                .map(drop)
                .map_err(|e| BusError::backend("notify", Some(&self.doorbell), e));
        }
        let mut listeners = self.listeners.lock().unwrap_or_else(PoisonError::into_inner);
        let now = Instant::now();
        let count = self.service.dynamic_config().number_of_listeners();
        let since = listeners.looked.map(|t| now.duration_since(t));
        let missing = !listeners.members.contains_key(&member);
        let mut look = listeners.stale
            || count != listeners.count
            || since.is_none_or(|s| s >= LOOK_AGAIN || (missing && s >= LOOK_FOR_MISSING));
        // A key that turned out stale (its reader left, maybe another came
        // in its place) gets one more look, so the send still wakes.
        for _ in 0..2 {
            if look {
                listeners.look(&self.notifier, count, now);
            }
            let mut stale = false;
            let keys = listeners.members.get(&member).into_iter().flatten().chain(&listeners.everyone);
            for key in keys {
                match self.notifier.notify_single_listener_with_custom_event_id(key, EventId::new(id)) {
                    Ok(()) => {}
                    Err(NotifierNotifyError::InvalidListenerKey) => stale = true,
                    Err(e) => return Err(BusError::backend("notify", Some(&self.doorbell), e)),
                }
            }
            listeners.stale = stale;
            if !stale {
                break;
            }
            look = true;
        }
        Ok(())
    }
}

impl Listeners {
    /// Looks up the listeners' keys anew.
    fn look<S: IoxService>(&mut self, notifier: &Notifier<S>, count: usize, now: Instant) {
        self.members.clear();
        self.everyone.clear();
        notifier.for_each_listener(|monofier, details| {
            let key = monofier.listener_key();
            match details.listener_name.as_str().parse::<u32>() {
                Ok(member) => self.members.entry(member).or_default().push(key),
                Err(_) => self.everyone.push(key),
            }
            CallbackProgression::Continue
        });
        self.count = count;
        self.looked = Some(now);
        self.stale = false;
    }
}

pub(super) fn open_subscriber<S: IoxService>(
    node: &Node<S>,
    config: &IpcConfig,
    topic: &TopicName,
    name: &ServiceName,
) -> Result<IpcSubscriber<S>, BusError> {
    let subscriber = pubsub_service(node, config, topic, name)?
        .subscriber_builder()
        .buffer_size(config.limits.buffer)
        .create()
        .map_err(|e| BusError::backend("create subscriber", Some(topic), e))?;
    let member = topic.doorbell_member().map(|m| m.to_string());
    let waker = waker(node, config, &topic.doorbell(), member.as_deref())?;
    Ok(IpcSubscriber { subscriber, waker, topic: *topic, max_payload: config.limits.max_payload })
}

/// How a reader of `bell`'s topics is woken: on `bell`'s event service
/// (its publishers ring it), or by polling. A reader of one member of a
/// doorbell family names its listener by the member (see [`Bell`]), a
/// fan-in by [`EVERY_MEMBER`]. The listener itself is made at the reader's
/// first wait ([`Listening`]).
pub(super) fn waker<S: IoxService>(
    node: &Node<S>,
    config: &IpcConfig,
    bell: &TopicName,
    member: Option<&str>,
) -> Result<Waker<S>, BusError> {
    Ok(match config.wake {
        Wake::Event { spin } => {
            let service = event_service(node, config, bell, &service_name(bell)?)?;
            let name = member.map(PortName::new).transpose();
            let name = name.map_err(|e| BusError::backend("name listener", Some(bell), e))?;
            Waker::Event {
                spin,
                listener: Box::new(Listening { service, name, bell: *bell, listener: OnceCell::new() }),
            }
        }
        Wake::Poll { spin, max_sleep } => Waker::Poll { spin, max_sleep },
    })
}

/// A doorbell listener, made when its reader first waits.
///
/// Why not at once: a doorbell's listener slots are sized for the readers
/// that wait (every agent on `to_agents`, a few fan-ins on `poses` and
/// `from_agents`, see `ipc_config` of the agent runtime), and every
/// notifier of the doorbell keeps a resident slot per possible listener.
/// A reader that only ever reads without waiting (a gateway's own pose, a
/// bench's pose readers) therefore takes no slot, and the `poses` and
/// `from_agents` doorbells, which every agent rings, need few. A message
/// sent before the listener exists is not lost: it waits in the
/// subscriber's queue, and the first wait looks there before it sleeps.
pub(super) struct Listening<S: IoxService> {
    service: event::PortFactory<S>,
    name: Option<PortName>,
    bell: TopicName,
    listener: OnceCell<Listener<S>>,
}

impl<S: IoxService> Listening<S> {
    /// The listener, made on the first call.
    pub(super) fn get(&self) -> Result<&Listener<S>, BusError> {
        if let Some(listener) = self.listener.get() {
            return Ok(listener);
        }
        let mut builder = self.service.listener_builder();
        if let Some(name) = &self.name {
            builder = builder.name(name);
        }
        let listener =
            builder.create().map_err(|e| BusError::backend("create listener", Some(&self.bell), e))?;
        Ok(self.listener.get_or_init(|| listener))
    }
}

/// The iceoryx2 service name of `topic` (the same text).
pub(super) fn service_name(topic: &TopicName) -> Result<ServiceName, BusError> {
    ServiceName::new(topic.as_str()).map_err(|e| BusError::backend("name service", Some(topic), e))
}

/// Publisher of an [`super::IceoryxBus`].
pub struct IpcPublisher<S: IoxService> {
    publisher: Publisher<S, [u8], ()>,
    ring: Ring<S>,
    topic: TopicName,
    max_payload: usize,
}

/// Whom a publisher wakes after a send.
enum Ring<S: IoxService> {
    /// Nobody: readers poll ([`Wake::Poll`]).
    Nobody,
    /// Every listener of the topic's own event service.
    Everyone(Notifier<S>),
    /// The readers of `member` in its doorbell family, and the fan-ins.
    Member { bell: Arc<Bell<S>>, member: u32 },
}

impl<S: IoxService> Publish for IpcPublisher<S> {
    fn publish(&self, payload: &[u8]) -> Result<(), BusError> {
        if payload.len() > self.max_payload {
            return Err(BusError::PayloadTooLarge { len: payload.len(), max: self.max_payload });
        }
        let topic = Some(&self.topic);
        let sample = self
            .publisher
            .loan_slice_uninit(payload.len())
            .map_err(|e| BusError::backend("loan sample", topic, e))?;
        sample.write_from_slice(payload).send().map_err(|e| BusError::backend("send", topic, e))?;
        match &self.ring {
            Ring::Nobody => Ok(()),
            Ring::Everyone(notifier) => {
                notifier.notify().map(drop).map_err(|e| BusError::backend("notify", topic, e))
            }
            Ring::Member { bell, member } => bell.ring(*member),
        }
    }
}

pub(super) enum Waker<S: IoxService> {
    Event { spin: Duration, listener: Box<Listening<S>> },
    Poll { spin: Duration, max_sleep: Duration },
}

/// The timeout handed to an event listener for `left` until the deadline:
/// at most [`EVENT_WAIT_SLICE`] and never less than [`MIN_EVENT_WAIT`] (a
/// deadline within the last microsecond is overslept by under 1 µs instead
/// of not at all, but never by forever).
pub(super) fn event_wait(left: Duration) -> Duration {
    left.clamp(MIN_EVENT_WAIT, EVENT_WAIT_SLICE)
}

/// The timeout of one sleep on an event listener: [`event_wait`], or for an
/// `idle` reader ([`Subscribe::recv_idle_into`]) all of `left` in one sleep
/// (still at least [`MIN_EVENT_WAIT`]).
fn listener_wait(left: Duration, idle: bool) -> Duration {
    if idle {
        left.max(MIN_EVENT_WAIT)
    } else {
        event_wait(left)
    }
}

/// How a sleep of [`IpcSubscriber::sleep`] ended.
pub(super) enum Slept {
    /// Woken by a notification or the timeout: look again.
    Again,
    /// Cut short by a signal.
    Interrupted,
}

/// Subscriber of an [`super::IceoryxBus`].
pub struct IpcSubscriber<S: IoxService> {
    subscriber: Subscriber<S, [u8], ()>,
    waker: Waker<S>,
    topic: TopicName,
    max_payload: usize,
}

impl<S: IoxService> Waker<S> {
    /// Sleeps until a notification or for at most `left` (`left` > 0);
    /// `poll_sleep` is [`Wake::Poll`]'s current step.
    /// An `idle` sleep on the event listener is not cut into
    /// [`EVENT_WAIT_SLICE`]s ([`Subscribe::recv_idle_into`]).
    pub(super) fn sleep(
        &self,
        topic: &TopicName,
        left: Duration,
        poll_sleep: &mut Duration,
        idle: bool,
    ) -> Result<Slept, BusError> {
        match self {
            Waker::Event { listener, .. } => {
                match listener.get()?.timed_wait(|_| {}, listener_wait(left, idle)) {
                    Ok(_) => Ok(Slept::Again),
                    Err(ListenerWaitError::InterruptSignal) => Ok(Slept::Interrupted),
                    Err(e) => Err(BusError::backend("wait for event", Some(topic), e)),
                }
            }
            Waker::Poll { max_sleep, .. } => {
                std::thread::sleep((*poll_sleep).min(left));
                *poll_sleep = (*poll_sleep * 2).min(*max_sleep);
                Ok(Slept::Again)
            }
        }
    }
}

impl<S: IoxService> Subscribe for IpcSubscriber<S> {
    fn max_payload(&self) -> usize {
        self.max_payload
    }

    fn try_recv_into(&self, buf: &mut [u8]) -> Result<Option<usize>, BusError> {
        match self.subscriber.receive() {
            Ok(Some(sample)) => copy_out(sample.payload(), buf).map(Some),
            Ok(None) => Ok(None),
            Err(e) => Err(BusError::backend("receive", Some(&self.topic), e)),
        }
    }

    fn recv_timeout_into(&self, buf: &mut [u8], timeout: Duration) -> Result<Option<usize>, BusError> {
        if let Waker::Event { listener, .. } = &self.waker {
            // Listen before looking, so nothing sent after the look is slept through.
            listener.get()?;
        }
        let sleep = |left, poll_sleep: &mut Duration| self.waker.sleep(&self.topic, left, poll_sleep, false);
        wait_for(self.waker.spin(), buf, timeout, |buf| self.try_recv_into(buf), sleep)
    }

    fn recv_idle_into(&self, buf: &mut [u8], timeout: Duration) -> Result<Option<usize>, BusError> {
        if let Waker::Event { listener, .. } = &self.waker {
            listener.get()?;
        }
        let sleep = |left, poll_sleep: &mut Duration| self.waker.sleep(&self.topic, left, poll_sleep, true);
        wait_for(Duration::ZERO, buf, timeout, |buf| self.try_recv_into(buf), sleep)
    }
}

impl<S: IoxService> Waker<S> {
    /// The busy-wait budget before sleeping.
    pub(super) fn spin(&self) -> Duration {
        match self {
            Waker::Event { spin, .. } | Waker::Poll { spin, .. } => *spin,
        }
    }
}

/// Receives with `try_recv` until a message comes or `timeout` passes:
/// spin for `spin`, then `sleep` for at most what is left (see the module
/// docs); `sleep` gets [`Wake::Poll`]'s current step.
pub(super) fn wait_for(
    spin: Duration,
    buf: &mut [u8],
    timeout: Duration,
    try_recv: impl Fn(&mut [u8]) -> Result<Option<usize>, BusError>,
    sleep: impl Fn(Duration, &mut Duration) -> Result<Slept, BusError>,
) -> Result<Option<usize>, BusError> {
    let start = Instant::now();
    let deadline = start.checked_add(timeout);
    let mut poll_sleep = POLL_FIRST_SLEEP;
    loop {
        if let Some(n) = try_recv(buf)? {
            return Ok(Some(n));
        }
        let now = Instant::now();
        let left = match deadline {
            Some(d) => d.saturating_duration_since(now),
            None => FAR_FUTURE,
        };
        if left.is_zero() {
            return Ok(None);
        }
        if now.duration_since(start) < spin {
            core::hint::spin_loop();
            continue;
        }
        if let Slept::Interrupted = sleep(left, &mut poll_sleep)? {
            // A signal (e.g. Ctrl-C handled by a flag) cut the wait
            // short: not a failure. Return early so the caller can look
            // at its flags, like a wait that timed out.
            return try_recv(buf);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::ipc::root::Isolated;
    use crate::bus::ipc::{IpcBus, IpcConfig};
    use crate::bus::Bus;
    use crate::naming::TopicName;
    use std::sync::mpsc;

    /// The event ids waiting on `sub`'s listener (taken, without waiting).
    fn rings(sub: &IpcSubscriber<iceoryx2::prelude::ipc::Service>) -> Vec<usize> {
        let mut ids = Vec::new();
        match &sub.waker {
            Waker::Event { listener, .. } => {
                let listener = listener.get().expect("the reader has waited, so it listens");
                listener.try_wait(|a| ids.push(a.id.as_value())).expect("read listener");
            }
            Waker::Poll { .. } => panic!("the default bus wakes by events"),
        }
        ids.sort_unstable();
        ids.dedup();
        ids
    }

    /// `sub` waits once (a microsecond, nothing is there): from now on it
    /// has a listener on its doorbell, as a reader has after its first wait.
    fn waits(sub: &IpcSubscriber<iceoryx2::prelude::ipc::Service>) {
        let mut buf = [0u8; 16];
        assert_eq!(sub.recv_timeout_into(&mut buf, Duration::from_micros(1)).expect("wait"), None);
        assert!(matches!(&sub.waker, Waker::Event { listener, .. } if listener.listener.get().is_some()));
    }

    /// On a shared doorbell a send wakes only the readers of its own robot
    /// (and fan-ins), also readers that came, left and came back after the
    /// bell last looked; one notifier serves all the bus's publishers of
    /// the family.
    #[test]
    fn a_shared_doorbell_wakes_only_the_robot_that_was_sent_to() {
        let iso = Isolated::new("bells");
        let config = IpcConfig { isolation: Some(iso.tag().to_owned()), ..IpcConfig::default() };
        let swarm = crate::Swarm::new("bells").expect("valid swarm");
        let topic = |k| *swarm.to_agent(crate::RobotId(k)).name();
        let bus = IpcBus::new(config.clone()).expect("iceoryx2 node");
        let agents = IpcBus::new(config).expect("iceoryx2 node");
        let one = agents.subscriber(&topic(1)).expect("subscriber");
        let two = agents.subscriber(&topic(2)).expect("subscriber");
        waits(&one);
        waits(&two);
        let to_one = bus.publisher(&topic(1)).expect("publisher");
        let to_two = bus.publisher(&topic(2)).expect("publisher");
        assert_eq!(bus.bells.open.lock().expect("lock").len(), 1, "one ringer for the family");
        to_one.publish(b"tick").expect("publish");
        assert_eq!((rings(&one), rings(&two)), (vec![1], vec![]));
        to_two.publish(b"tick").expect("publish");
        to_two.publish(b"tick").expect("publish");
        assert_eq!((rings(&one), rings(&two)), (vec![], vec![2]));
        // A reader that joins later is woken by the next send.
        let three = agents.subscriber(&topic(3)).expect("subscriber");
        waits(&three);
        let to_three = bus.publisher(&topic(3)).expect("publisher");
        to_three.publish(b"tick").expect("publish");
        assert_eq!((rings(&one), rings(&two), rings(&three)), (vec![], vec![], vec![3]));
        // Robot 1's reader is replaced (same number of listeners).
        drop(one);
        let one = agents.subscriber(&topic(1)).expect("subscriber");
        waits(&one);
        to_one.publish(b"tick").expect("publish");
        assert_eq!((rings(&one), rings(&two), rings(&three)), (vec![1], vec![], vec![]));
        let mut buf = [0u8; 16];
        assert_eq!(one.try_recv_into(&mut buf).expect("receive"), Some(4), "the message is there");
    }

    /// A wait of less than a microsecond on the event listener returns.
    ///
    /// iceoryx2 0.10 waits on a Unix datagram socket with `SO_RCVTIMEO`
    /// set from the timeout truncated to whole microseconds, and a zero
    /// `SO_RCVTIMEO` means "never time out": a wait of 1 to 999 ns blocked
    /// until the next notification. A real-time agent whose deadline fell
    /// within that last microsecond hung until its orchestrator next sent
    /// it something, which a stuck robot's orchestrator never does, and it
    /// was killed as "fell silent" (issue 17).
    ///
    /// No notification ever comes here unless the wait hangs: then the
    /// test publishes one to free the waiting thread and fails.
    #[test]
    fn a_sub_microsecond_event_wait_times_out() {
        let iso = Isolated::new("subusec");
        let config = IpcConfig { isolation: Some(iso.tag().to_owned()), ..IpcConfig::default() };
        let topic = TopicName::parse("bycoms/subusec/wait").expect("valid topic");
        let (opened_tx, opened_rx) = mpsc::channel();
        let (done_tx, done_rx) = mpsc::channel();
        let waiter = {
            let config = config.clone();
            std::thread::spawn(move || {
                let bus = IpcBus::new(config).expect("iceoryx2 node");
                let sub = bus.subscriber(&topic).expect("subscriber");
                opened_tx.send(()).expect("main thread waits");
                let mut results = Vec::new();
                for ns in [1, 500, 999] {
                    let mut poll = POLL_FIRST_SLEEP;
                    results.push(matches!(
                        sub.waker.sleep(&sub.topic, Duration::from_nanos(ns), &mut poll, false),
                        Ok(Slept::Again)
                    ));
                }
                let _ = done_tx.send(results);
            })
        };
        opened_rx.recv_timeout(Duration::from_secs(30)).expect("the subscriber opens");
        let outcome = done_rx.recv_timeout(Duration::from_secs(10));
        if outcome.is_err() {
            // Free the hung waiter (one notification per hung wait) so the
            // test ends, then fail.
            let bus = IpcBus::new(config).expect("iceoryx2 node");
            let publisher = bus.publisher(&topic).expect("publisher");
            let freed = (0..3).any(|_| {
                publisher.publish(b"wake").expect("publish");
                done_rx.recv_timeout(Duration::from_secs(5)).is_ok()
            });
            if freed {
                waiter.join().expect("waiter thread");
            }
            panic!("a wait of under 1 µs on the event listener hung until a notification came");
        }
        waiter.join().expect("waiter thread");
        let results = outcome.expect("checked above");
        assert_eq!(results, vec![true, true, true], "every wait ended without error");
    }

    #[test]
    fn an_idle_reader_sleeps_once_for_the_whole_wait() {
        let ms = Duration::from_millis;
        assert_eq!(listener_wait(ms(50), true), ms(50));
        assert_eq!(listener_wait(ms(50), false), EVENT_WAIT_SLICE);
        assert_eq!(listener_wait(ms(5), false), ms(5));
        assert_eq!(listener_wait(Duration::from_nanos(10), true), MIN_EVENT_WAIT);
        assert_eq!(listener_wait(Duration::from_nanos(10), false), MIN_EVENT_WAIT);
    }

    /// An idle wait is still ended by a notification: a message sent while
    /// a reader waits for a minute idly reaches it at once.
    #[test]
    fn an_idle_wait_is_woken_by_a_message() {
        let iso = Isolated::new("idlewait");
        let config = IpcConfig { isolation: Some(iso.tag().to_owned()), ..IpcConfig::default() };
        let topic = TopicName::parse("bycoms/idlewait/wait").expect("valid topic");
        let (waiting_tx, waiting_rx) = mpsc::channel();
        let (done_tx, done_rx) = mpsc::channel();
        let reader = {
            let config = config.clone();
            std::thread::spawn(move || {
                let bus = IpcBus::new(config).expect("iceoryx2 node");
                let sub = bus.subscriber(&topic).expect("subscriber");
                let mut buf = [0u8; 16];
                // Listening before the publisher exists: nothing to take yet.
                assert_eq!(sub.try_recv_into(&mut buf).expect("look"), None);
                waiting_tx.send(()).expect("main thread waits");
                let got = sub.recv_idle_into(&mut buf, Duration::from_secs(60)).expect("idle wait");
                let _ = done_tx.send(got.map(|n| buf[..n].to_vec()));
            })
        };
        waiting_rx.recv_timeout(Duration::from_secs(30)).expect("the reader opens");
        let bus = IpcBus::new(config).expect("iceoryx2 node");
        let publisher = bus.publisher(&topic).expect("publisher");
        publisher.publish(b"shutdown").expect("publish");
        let got = done_rx
            .recv_timeout(Duration::from_secs(20))
            .expect("the idle reader was not woken by the message within 20 s of its 60 s wait");
        assert_eq!(got.as_deref(), Some(&b"shutdown"[..]));
        reader.join().expect("reader thread");
    }

    /// A reader takes a slot of its doorbell's listeners only when it first
    /// waits: readers that never wait are not limited by the slots, a
    /// message sent before a reader waits is still received, and a waiting
    /// reader beyond the slots gets an error that names the doorbell.
    #[test]
    fn a_reader_listens_on_its_doorbell_only_once_it_waits() {
        let iso = Isolated::new("lazybell");
        let swarm = crate::Swarm::new("lazy").expect("valid swarm");
        let topic = |k| *swarm.pose(crate::RobotId(k)).name();
        let config = IpcConfig {
            isolation: Some(iso.tag().to_owned()),
            port_limits: vec![crate::bus::ipc::PortLimits {
                suffix: "/poses",
                max_publishers: 8,
                max_subscribers: 1,
            }],
            ..IpcConfig::default()
        };
        let bus = IpcBus::new(config).expect("iceoryx2 node");
        let readers: Vec<_> = (1..=3).map(|k| bus.subscriber(&topic(k)).expect("subscriber")).collect();
        let writers: Vec<_> = (1..=3).map(|k| bus.publisher(&topic(k)).expect("publisher")).collect();
        for w in &writers {
            w.publish(b"pose").expect("publish");
        }
        let mut buf = [0u8; 16];
        for r in &readers {
            assert_eq!(r.try_recv_into(&mut buf).expect("receive"), Some(4), "read without waiting");
        }
        // One waits (the doorbell's one listener slot); its message sent
        // before it waited is received.
        writers[0].publish(b"pose").expect("publish");
        let wait = Duration::from_millis(100);
        assert_eq!(readers[0].recv_timeout_into(&mut buf, wait).expect("wait"), Some(4));
        assert_eq!(readers[0].recv_timeout_into(&mut buf, Duration::from_micros(1)).expect("wait"), None);
        // A second reader that waits finds no slot left.
        let err = readers[1].recv_timeout_into(&mut buf, Duration::from_micros(1)).expect_err("no slot left");
        assert!(err.to_string().contains("poses"), "{err}");
    }
}
