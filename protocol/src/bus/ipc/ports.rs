//! iceoryx2 publisher and subscriber ports behind the byte-level traits.
//!
//! Why the wait loop looks like this: a receive from shared memory costs
//! tens of nanoseconds, a sleep and wake-up through the kernel costs
//! microseconds. A subscriber that finds nothing therefore busy-waits for a
//! short budget (most lockstep replies arrive within it), then sleeps until
//! a publisher's notification or its own deadline. The busy-wait yields
//! the processor between looks (`sched_yield`, well under a microsecond)
//! instead of spinning in place: with more busy processes than cores (a
//! lockstep launch on two cores: orchestrator, agents, a build), a reader
//! spinning in place held the core the process that must answer it was
//! waiting for, until the scheduler took it away; yielding hands it over
//! at once. `bench launch`: a tick 78–82 → 25–30 µs at load 3.6, 85–98
//! → 36–52 µs at load 4.5 (issue 35, docs/BENCHMARKS.md "Third pass"). No wait is ever
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

/// The largest event id of every event service. A report topic rings its
/// doorbell with the event id of its robot ([`member_event_id`]), so a
/// fan-in knows which few topics to read.
///
/// Why so few ids, and not one per robot: iceoryx2 keeps a counter per
/// event id in every listener, and every wake-up of a listener swaps each
/// of them back to zero (`CountingBitSet::reset_all`), whether it rang or
/// not. With an id per robot (up to the publisher limit, which grows with
/// the swarm) that was 1 000 atomic swaps per wake-up of every agent and of
/// the fan-in at 1 000 robots, and 256 at 3: 18 % of a lockstep launch's
/// samples (`perf`, issue 35). With 64 a fan-in reads the few topics that
/// share the id that rang (one in 63 of them) instead.
pub(super) const EVENT_ID_MAX: usize = 63;

/// The event id robot `member` rings its doorbell with: 1 to
/// [`EVENT_ID_MAX`], round robin; 0 is a ring from no known member.
pub(super) fn member_event_id(member: u32) -> usize {
    1 + (member.saturating_sub(1) as usize) % EVENT_ID_MAX
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
        .event_id_max_value(EVENT_ID_MAX)
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
/// [`Bell`]), made when the bus's first publisher of the family opens; and
/// the families' event services, opened once per bus and shared by its
/// ringers and readers.
///
/// Why the services are shared: iceoryx2 keeps two files open per service
/// handle (its static and dynamic parts), and none close-on-exec; a bus
/// whose every subscriber opened its doorbell's service held 2 000 more
/// files at 1000 robots (`bench scale`'s pose readers), which every agent
/// it started inherited and closed (issue 35).
pub(super) struct Bells<S: IoxService> {
    open: Mutex<std::collections::HashMap<TopicName, Arc<Bell<S>>>>,
    services: Mutex<std::collections::HashMap<TopicName, Arc<event::PortFactory<S>>>>,
}

impl<S: IoxService> Default for Bells<S> {
    fn default() -> Self {
        Self { open: Mutex::new(Default::default()), services: Mutex::new(Default::default()) }
    }
}

impl<S: IoxService> Bells<S> {
    /// The event service of `doorbell`, opened on the first call.
    pub(super) fn service(
        &self,
        node: &Node<S>,
        config: &IpcConfig,
        doorbell: &TopicName,
    ) -> Result<Arc<event::PortFactory<S>>, BusError> {
        let mut services = self.services.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(service) = services.get(doorbell) {
            return Ok(Arc::clone(service));
        }
        let service = Arc::new(event_service(node, config, doorbell, &service_name(doorbell)?)?);
        services.insert(*doorbell, Arc::clone(&service));
        Ok(service)
    }

    /// The ringer of `topic`'s doorbell family.
    fn bell(&self, node: &Node<S>, config: &IpcConfig, topic: &TopicName) -> Result<Arc<Bell<S>>, BusError> {
        let doorbell = topic.doorbell();
        let mut open = self.open.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(bell) = open.get(&doorbell) {
            return Ok(Arc::clone(bell));
        }
        let service = self.service(node, config, &doorbell)?;
        let notifier = service
            .notifier_builder()
            .create()
            .map_err(|e| BusError::backend("create notifier", Some(&doorbell), e))?;
        let bell =
            Arc::new(Bell { service, notifier, doorbell, listeners: Mutex::new(Listeners::default()) });
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
    service: Arc<event::PortFactory<S>>,
    notifier: Notifier<S>,
    doorbell: TopicName,
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
        let id = member_event_id(member);
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
    bells: &Bells<S>,
) -> Result<IpcSubscriber<S>, BusError> {
    let subscriber = pubsub_service(node, config, topic, name)?
        .subscriber_builder()
        .buffer_size(config.limits.buffer)
        .create()
        .map_err(|e| BusError::backend("create subscriber", Some(topic), e))?;
    let member = topic.doorbell_member().map(|m| m.to_string());
    let waker = waker(node, config, &topic.doorbell(), member.as_deref(), bells)?;
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
    bells: &Bells<S>,
) -> Result<Waker<S>, BusError> {
    Ok(match config.wake {
        Wake::Event { spin } => {
            let service = bells.service(node, config, bell)?;
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
    service: Arc<event::PortFactory<S>>,
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

impl<S: IoxService> IpcPublisher<S> {
    /// Puts one payload into shared memory, without a ring.
    fn put(&self, payload: &[u8]) -> Result<(), BusError> {
        if payload.len() > self.max_payload {
            return Err(BusError::PayloadTooLarge { len: payload.len(), max: self.max_payload });
        }
        let topic = Some(&self.topic);
        let sample = self
            .publisher
            .loan_slice_uninit(payload.len())
            .map_err(|e| BusError::backend("loan sample", topic, e))?;
        sample.write_from_slice(payload).send().map_err(|e| BusError::backend("send", topic, e))?;
        Ok(())
    }
}

impl<S: IoxService> Publish for IpcPublisher<S> {
    fn publish_quietly(&self, payload: &[u8]) -> Result<(), BusError> {
        self.put(payload)
    }

    fn publish(&self, payload: &[u8]) -> Result<(), BusError> {
        self.put(payload)?;
        let topic = Some(&self.topic);
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
        self.wait(buf, timeout, self.waker.spin(), false)
    }

    fn recv_idle_into(&self, buf: &mut [u8], timeout: Duration) -> Result<Option<usize>, BusError> {
        self.wait(buf, timeout, Duration::ZERO, true)
    }
}

impl<S: IoxService> IpcSubscriber<S> {
    /// Receives within `timeout`: busy-waits for `spin`, then sleeps (one
    /// sleep for all of what is left when `idle`).
    fn wait(
        &self,
        buf: &mut [u8],
        timeout: Duration,
        spin: Duration,
        idle: bool,
    ) -> Result<Option<usize>, BusError> {
        if let Waker::Event { listener, .. } = &self.waker {
            // Listen before looking, so nothing sent after the look is slept through.
            listener.get()?;
        }
        let sleep = |left, poll_sleep: &mut Duration| self.waker.sleep(&self.topic, left, poll_sleep, idle);
        wait_for(spin, buf, timeout, |buf| self.try_recv_into(buf), sleep)
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
            // Yield, not `spin_loop`: see the module docs.
            std::thread::yield_now();
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
mod tests;
