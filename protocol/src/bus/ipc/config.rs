//! The iceoryx2 bus's settings: sizes, port limits per topic, how a
//! subscriber wakes.
//!
//! Why a file of their own: the bus (`ipc.rs`) and its ports
//! (`ports.rs`, `fan_in.rs`) all read them, and the ports must not use the
//! file that uses them (no file cycles).

use super::root;
use crate::bus::Limits;
use crate::naming::TopicName;
use core::time::Duration;

/// How a subscriber waiting in `recv_timeout` learns that a sample arrived.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wake {
    /// Spin for `spin`, then sleep on the topic's iceoryx2 event listener;
    /// publishers notify after every send.
    Event {
        /// Busy-wait budget before sleeping.
        spin: Duration,
    },
    /// Spin for `spin`, then sleep in doubling steps up to `max_sleep`.
    Poll {
        /// Busy-wait budget before sleeping.
        spin: Duration,
        /// Longest single sleep (worst added latency once idle).
        max_sleep: Duration,
    },
}

impl Default for Wake {
    fn default() -> Self {
        Self::Event { spin: Duration::from_micros(20) }
    }
}

/// Sizes and behaviour of an [`IceoryxBus`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IpcConfig {
    /// Payload and buffer sizes (every process on a topic must agree).
    pub limits: Limits,
    /// Most publishers per topic: `from_agents` has one per agent.
    pub max_publishers: usize,
    /// Most subscribers per topic (orchestrator, recorder, monitors).
    pub max_subscribers: usize,
    /// Most nodes (processes or threads with a bus) per topic.
    pub max_nodes: usize,
    /// How waiting subscribers are woken.
    pub wake: Wake,
    /// iceoryx2 node name, shown by `iox2 node list` (default: none).
    pub node_name: Option<String>,
    /// Whether this process removes dead nodes' resources: when the bus is
    /// opened, in every service it opens, and when it closes (iceoryx2's
    /// `cleanup_dead_nodes_on_open`, node `cleanup_dead_nodes_on_creation`
    /// and `_on_destruction`). The orchestrator does; agents do not
    /// (`ipc_config` of the agent runtime): each check reads every node (of
    /// the service, or of the machine), so in every agent it cost start and
    /// exit time and heap that grew with the agents before it (5.7 KB each,
    /// kept by the allocator), and the orchestrator cleans up after every
    /// agent that does not end cleanly anyway.
    pub cleans_dead_nodes: bool,
    /// Isolation tag: this run's own iceoryx2 root and prefix (see
    /// [`root`]). Default: `$BYCOMS_IPC_ISOLATION`, else machine-wide.
    pub isolation: Option<String>,
    /// Topics with their own port limits (the first whose suffix matches
    /// a topic's name), instead of [`Self::max_publishers`] and
    /// [`Self::max_subscribers`]. Why: iceoryx2 gives every subscriber a
    /// slot per possible publisher and every publisher one per possible
    /// subscriber (~3.6 KB each, resident), so a robot's own topics sized
    /// like `from_agents` (one publisher per agent) cost memory that grows
    /// with the swarm in every process that opens them.
    pub port_limits: Vec<PortLimits>,
}

/// The port limits of the topics whose name ends with `suffix`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PortLimits {
    /// The end of the topic's name, e.g. `/pose`.
    pub suffix: &'static str,
    /// Most publishers (of a doorbell's event service: notifiers).
    pub max_publishers: usize,
    /// Most subscribers (of a doorbell's event service: listeners).
    pub max_subscribers: usize,
}

impl IpcConfig {
    /// The (publishers, subscribers) limits of `topic`.
    pub fn ports_of(&self, topic: &TopicName) -> (usize, usize) {
        self.port_limits
            .iter()
            .find(|l| topic.as_str().ends_with(l.suffix))
            .map_or((self.max_publishers, self.max_subscribers), |l| (l.max_publishers, l.max_subscribers))
    }
}

impl Default for IpcConfig {
    fn default() -> Self {
        Self {
            limits: Limits::default(),
            max_publishers: 64,
            max_subscribers: 16,
            max_nodes: 128,
            wake: Wake::default(),
            node_name: None,
            cleans_dead_nodes: true,
            isolation: root::tag_from_env(),
            port_limits: Vec::new(),
        }
    }
}
