//! iceoryx2 publisher and subscriber ports behind the byte-level traits.
//!
//! Why the wait loop looks like this: a receive from shared memory costs
//! tens of nanoseconds, a sleep and wake-up through the kernel costs
//! microseconds. A subscriber that finds nothing therefore busy-waits for a
//! short budget (most lockstep replies arrive within it), then sleeps until
//! a publisher's notification or its own deadline. No wait is ever
//! unbounded, and a sleep on the event listener is capped at
//! [`EVENT_WAIT_SLICE`] so a publisher that never notifies (one configured
//! with [`Wake::Poll`]) still gets through.

use super::{IpcConfig, Wake};
use crate::bus::{copy_out, BusError, Publish, Subscribe};
use crate::naming::TopicName;
use core::time::Duration;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{AllocationStrategy, Node, ServiceName};
use iceoryx2::service::port_factory::{event, publish_subscribe};
use iceoryx2::service::Service as IoxService;
use std::time::Instant;

/// Longest single sleep on an event listener.
pub const EVENT_WAIT_SLICE: Duration = Duration::from_millis(10);
/// First sleep of [`Wake::Poll`] after the spin budget.
const POLL_FIRST_SLEEP: Duration = Duration::from_micros(20);
/// Stand-in deadline for timeouts too large for `Instant`.
const FAR_FUTURE: Duration = Duration::from_secs(3600);

fn pubsub_service<S: IoxService>(
    node: &Node<S>,
    config: &IpcConfig,
    topic: &TopicName,
    name: &ServiceName,
) -> Result<publish_subscribe::PortFactory<S, [u8], ()>, BusError> {
    node.service_builder(name)
        .publish_subscribe::<[u8]>()
        .history_size(0)
        .subscriber_max_buffer_size(config.limits.buffer)
        .enable_safe_overflow(true)
        .max_publishers(config.max_publishers)
        .max_subscribers(config.max_subscribers)
        .max_nodes(config.max_nodes)
        .open_or_create()
        .map_err(|e| BusError::backend("open publish-subscribe service", Some(topic), e))
}

fn event_service<S: IoxService>(
    node: &Node<S>,
    config: &IpcConfig,
    topic: &TopicName,
    name: &ServiceName,
) -> Result<event::PortFactory<S>, BusError> {
    node.service_builder(name)
        .event()
        .max_notifiers(config.max_publishers)
        .max_listeners(config.max_subscribers)
        .max_nodes(config.max_nodes)
        .open_or_create()
        .map_err(|e| BusError::backend("open event service", Some(topic), e))
}

pub(super) fn open_publisher<S: IoxService>(
    node: &Node<S>,
    config: &IpcConfig,
    topic: &TopicName,
    name: &ServiceName,
) -> Result<IpcPublisher<S>, BusError> {
    let publisher = pubsub_service(node, config, topic, name)?
        .publisher_builder()
        .initial_max_slice_len(config.limits.max_payload)
        .allocation_strategy(AllocationStrategy::Static)
        .create()
        .map_err(|e| BusError::backend("create publisher", Some(topic), e))?;
    let notifier = match config.wake {
        Wake::Event { .. } => Some(
            event_service(node, config, topic, name)?
                .notifier_builder()
                .create()
                .map_err(|e| BusError::backend("create notifier", Some(topic), e))?,
        ),
        Wake::Poll { .. } => None,
    };
    Ok(IpcPublisher { publisher, notifier, topic: *topic, max_payload: config.limits.max_payload })
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
    let waker = match config.wake {
        Wake::Event { spin } => Waker::Event {
            spin,
            listener: event_service(node, config, topic, name)?
                .listener_builder()
                .create()
                .map_err(|e| BusError::backend("create listener", Some(topic), e))?,
        },
        Wake::Poll { spin, max_sleep } => Waker::Poll { spin, max_sleep },
    };
    Ok(IpcSubscriber { subscriber, waker, topic: *topic, max_payload: config.limits.max_payload })
}

/// Publisher of an [`super::IceoryxBus`].
pub struct IpcPublisher<S: IoxService> {
    publisher: Publisher<S, [u8], ()>,
    notifier: Option<Notifier<S>>,
    topic: TopicName,
    max_payload: usize,
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
        if let Some(notifier) = &self.notifier {
            notifier.notify().map_err(|e| BusError::backend("notify", topic, e))?;
        }
        Ok(())
    }
}

enum Waker<S: IoxService> {
    Event { spin: Duration, listener: Listener<S> },
    Poll { spin: Duration, max_sleep: Duration },
}

/// Subscriber of an [`super::IceoryxBus`].
pub struct IpcSubscriber<S: IoxService> {
    subscriber: Subscriber<S, [u8], ()>,
    waker: Waker<S>,
    topic: TopicName,
    max_payload: usize,
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
        let start = Instant::now();
        let deadline = start.checked_add(timeout);
        let spin = match &self.waker {
            Waker::Event { spin, .. } | Waker::Poll { spin, .. } => *spin,
        };
        let mut sleep = POLL_FIRST_SLEEP;
        loop {
            if let Some(n) = self.try_recv_into(buf)? {
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
            match &self.waker {
                Waker::Event { listener, .. } => {
                    match listener.timed_wait(|_| {}, left.min(EVENT_WAIT_SLICE)) {
                        Ok(_) => {}
                        // A signal (e.g. Ctrl-C handled by a flag) cut the wait
                        // short: not a failure. Return early so the caller can
                        // look at its flags, like a wait that timed out.
                        Err(ListenerWaitError::InterruptSignal) => return self.try_recv_into(buf),
                        Err(e) => return Err(BusError::backend("wait for event", Some(&self.topic), e)),
                    }
                }
                Waker::Poll { max_sleep, .. } => {
                    std::thread::sleep(sleep.min(left));
                    sleep = (sleep * 2).min(*max_sleep);
                }
            }
        }
    }
}
