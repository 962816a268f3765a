//! iceoryx2 backend: the bus between processes on one machine, over shared
//! memory.
//!
//! Why iceoryx2: a hop between two processes must cost microseconds so the
//! lockstep runs over processes are not much slower than the in-process
//! simulator. iceoryx2 moves samples through shared memory with no broker
//! and no copies in the kernel.
//!
//! Mapping of the [`crate::bus`] contract onto iceoryx2 0.10:
//!
//! * a topic is a publish-subscribe service of dynamic byte slices
//!   (`[u8]`) under the topic's name; each publisher preallocates samples of
//!   [`Limits::max_payload`] bytes (static allocation strategy);
//! * `history_size(0)`: late subscribers see nothing stale;
//!   `subscriber_max_buffer_size(buffer)` and `enable_safe_overflow(true)`:
//!   a slow subscriber loses its oldest samples, a publisher never blocks;
//! * waking: with [`Wake::Event`] every topic also has an event service,
//!   its [`TopicName::doorbell`]: its own name, or for a robot's topics one
//!   shared per direction and swarm (`from_agents`, `to_agents`), because
//!   each event service a process opens costs it a handful of open files
//!   and the orchestrator opens every robot's topics. A publisher notifies
//!   after each send, on a shared doorbell only the listeners of its own
//!   robot and the fan-ins (`ports::Bell`), and a subscriber that found
//!   nothing spins briefly, then sleeps on its listener. With
//!   [`Wake::Poll`] there is no event service and a waiting subscriber spins,
//!   then sleeps in growing steps. The benchmark `benches/bus_hop.rs`
//!   measures both against raw iceoryx2. On the 2-core dev machine a hop
//!   costs ~0.8 µs p50 / ~1.1 µs p99 whenever the reply lands within the
//!   spin budget, for both strategies and for raw iceoryx2 with a spinning
//!   receiver; a sleeping receiver costs ~8 µs with the event (as raw
//!   iceoryx2's listener) but the polling sleep adds a ~50 µs p99.9 tail.
//!   Hence the default [`Wake::Event`] with a 20 µs spin. A reader that
//!   expects nothing soon (`Subscribe::recv_idle_into`: a parked robot's
//!   agent) skips the spin and sleeps its whole timeout in one wait on its
//!   listener: a thousand parked agents spinning 20 µs and waking every
//!   10 ms took 1.5 of the machine's two cores;
//! * all processes on a topic must use the same [`IpcConfig`] sizes: the
//!   first process creates the service with them and the others open it.
//!
//! [`IpcBus`] (`ipc::Service`) is the fast default; its bus and ports are
//! confined to the thread that created them (open one bus per thread).
//! [`IpcThreadsafeBus`] (`ipc_threadsafe::Service`) is `Send + Sync` at the
//! cost of a mutex per operation.
//!
//! A process that crashes leaves its node's shared memory and its ports
//! behind; [`cleanup_stale_resources`] removes what dead nodes left, and
//! [`IceoryxBus::new`] calls it first unless told not to. Where iceoryx2
//! keeps those files, and how a run isolates its own, is [`root`].

mod config;
mod fan_in;
mod ports;
pub mod root;
#[cfg(test)]
mod tests;

pub use config::{IpcConfig, PortLimits, Wake};
pub use fan_in::IpcFanIn;
pub use ports::{IpcPublisher, IpcSubscriber};

use super::{Bus, BusError, Limits};
use crate::naming::TopicName;
use iceoryx2::prelude::{
    ipc, ipc_threadsafe, CallbackProgression, Config, Node, NodeBuilder, NodeName, NodeState,
    SignalHandlingMode,
};
use iceoryx2::service::Service as IoxService;

/// What [`cleanup_stale_resources`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CleanupReport {
    /// Dead nodes whose resources were removed.
    pub cleaned: u64,
    /// Dead nodes that could not be removed (permissions, version).
    pub failed: u64,
}

/// Removes the shared-memory resources left by every dead node (a process
/// that crashed or was killed) of service flavour `S`. Call it at start;
/// nodes being cleaned by another process at the same time are skipped.
pub fn cleanup_stale_resources<S: IoxService>() -> Result<CleanupReport, BusError> {
    cleanup_stale_resources_in::<S>(&root::config(root::tag_from_env().as_deref())?)
}

/// [`cleanup_stale_resources`] under the iceoryx2 configuration `config`
/// (see [`root::config`]).
pub fn cleanup_stale_resources_in<S: IoxService>(config: &Config) -> Result<CleanupReport, BusError> {
    let mut report = CleanupReport::default();
    let listed = Node::<S>::list(config, |state| {
        if let NodeState::Dead(view) = state {
            match view.try_remove_stale_resources() {
                Ok(()) => report.cleaned += 1,
                Err(e) => {
                    use iceoryx2::node::NodeCleanupFailure as F;
                    if !matches!(e, F::ResourcesAlreadyCleanedUp | F::AnotherInstanceIsCleaningUpTheNode) {
                        report.failed += 1;
                    }
                }
            }
        }
        CallbackProgression::Continue
    });
    listed.map_err(|e| BusError::backend("list nodes", None, e))?;
    Ok(report)
}

/// The iceoryx2 bus of service flavour `S`; see [`IpcBus`].
pub struct IceoryxBus<S: IoxService> {
    node: Node<S>,
    config: IpcConfig,
    bells: ports::Bells<S>,
}

/// The single-threaded (fastest) iceoryx2 bus.
pub type IpcBus = IceoryxBus<ipc::Service>;
/// The thread-safe iceoryx2 bus: bus and ports are `Send + Sync`.
pub type IpcThreadsafeBus = IceoryxBus<ipc_threadsafe::Service>;

impl<S: IoxService> IceoryxBus<S> {
    /// Opens a node with `config` (cleaning dead nodes first if asked).
    pub fn new(config: IpcConfig) -> Result<Self, BusError> {
        let l = config.limits;
        if l.max_payload == 0 || l.buffer == 0 {
            return Err(BusError::InvalidConfig("max_payload and buffer must be at least 1"));
        }
        if config.max_publishers == 0 || config.max_subscribers == 0 || config.max_nodes == 0 {
            return Err(BusError::InvalidConfig(
                "max_publishers, max_subscribers and max_nodes must be at least 1",
            ));
        }
        let mut iox = root::config(config.isolation.as_deref())?;
        iox.global.service.cleanup_dead_nodes_on_open = config.cleans_dead_nodes;
        iox.global.node.cleanup_dead_nodes_on_creation = config.cleans_dead_nodes;
        iox.global.node.cleanup_dead_nodes_on_destruction = config.cleans_dead_nodes;
        if config.cleans_dead_nodes {
            cleanup_stale_resources_in::<S>(&iox)?;
        }
        let mut builder = NodeBuilder::new().config(&iox).signal_handling_mode(SignalHandlingMode::Disabled);
        if let Some(name) = &config.node_name {
            let name = NodeName::new(name).map_err(|e| BusError::backend("name node", None, e))?;
            builder = builder.name(&name);
        }
        let node = builder.create::<S>().map_err(|e| BusError::backend("create node", None, e))?;
        Ok(Self { node, config, bells: ports::Bells::default() })
    }

    /// The configuration the bus was opened with.
    pub fn config(&self) -> &IpcConfig {
        &self.config
    }

    /// Removes dead nodes' resources through this bus's node.
    pub fn cleanup_dead_nodes(&self) -> CleanupReport {
        let state = self.node.try_cleanup_dead_nodes();
        CleanupReport { cleaned: state.cleanups, failed: state.failed_cleanups }
    }
}

impl<S: IoxService> Bus for IceoryxBus<S> {
    type Publisher = IpcPublisher<S>;
    type Subscriber = IpcSubscriber<S>;
    type FanIn = IpcFanIn<S>;

    fn publisher(&self, topic: &TopicName) -> Result<IpcPublisher<S>, BusError> {
        ports::open_publisher(&self.node, &self.config, topic, &ports::service_name(topic)?, &self.bells)
    }

    fn subscriber(&self, topic: &TopicName) -> Result<IpcSubscriber<S>, BusError> {
        ports::open_subscriber(&self.node, &self.config, topic, &ports::service_name(topic)?, &self.bells)
    }

    fn fan_in(&self, topics: &[TopicName]) -> Result<IpcFanIn<S>, BusError> {
        fan_in::open_fan_in(&self.node, &self.config, topics, &self.bells)
    }

    fn limits(&self) -> Limits {
        self.config.limits
    }
}
