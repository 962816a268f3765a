//! The bus configuration every process of a swarm shares.
//!
//! [`ipc_config`] sizes the shared-memory services; every process of one
//! swarm (orchestrator, agents, gateways, test tools) must call it with the
//! same swarm size, since iceoryx2 services are created by the first
//! process and opened with the same limits by the others. [`zenoh_config`]
//! is the zenoh session of every process of a launch over zenoh.

use bycoms_protocol::bus::ipc::{IpcConfig, PortLimits};
use bycoms_protocol::bus::zenoh::{Congestion, Liveness, Mode, ZenohConfig};
use bycoms_protocol::bus::Limits;
use bycoms_protocol::MAX_MESSAGE_LEN;
use std::path::PathBuf;

/// Unread messages a subscriber keeps per publisher.
pub const BUS_BUFFER: usize = 64;

/// Publishers of a robot's pose topic, and ports of each side of its
/// command topic (see [`ipc_config`]).
pub const ROBOT_TOPIC_PORTS: usize = 8;

/// Listeners of the `poses` and `from_agents` doorbells, and notifiers of
/// the `to_agents` one (see [`ipc_config`]).
pub const DOORBELL_FEW: usize = 16;

/// The iceoryx2 configuration of a swarm of `swarm_size` robots.
///
/// Payloads are at most one protocol message. The doorbells of the
/// robots' topics (`TopicName::doorbell`: the event services that every
/// robot's reports, poses and commands ring) are one-sided: every agent
/// rings `poses` and `from_agents`, which only fan-ins (the orchestrator,
/// a bridge) and a few tools wait on ([`DOORBELL_FEW`] listeners), and
/// every agent waits on `to_agents`, which only the orchestrator and a few
/// tools ring ([`DOORBELL_FEW`] notifiers); the many side grows with the
/// swarm (plus headroom). The few side matters because iceoryx2 keeps a
/// resident slot (about 1.3 KB) per possible listener in every notifier:
/// sized like the swarm on both sides, the two notifiers of each agent held
/// 2.7 MB at 1000 robots. A reader takes a listener only once it waits
/// (`Listening` in the bus), so readers that only poll (a gateway's own
/// pose, `bench scale`) need none. A robot's own topics have few ports on either side
/// ([`ROBOT_TOPIC_PORTS`]): its pose is read by the orchestrator and tools
/// only (agents are sent their beacons instead of reading every earlier
/// robot's pose), and iceoryx2 keeps a resident slot (~3.6 KB) per
/// possible peer port in every port and sizes a publisher's shared data
/// segment by its subscribers, so sizing them like the swarm cost each
/// agent (k − 1) × (n + 132) slots (86 MB for robot 98 of 100, 262 MB for
/// robot 166 of 300). Stale resources are cleaned by
/// the orchestrator at start, not by every agent.
pub fn ipc_config(swarm_size: u32) -> IpcConfig {
    let n = swarm_size as usize;
    IpcConfig {
        limits: Limits { max_payload: MAX_MESSAGE_LEN, buffer: BUS_BUFFER },
        max_publishers: n + 4,
        max_subscribers: n + 4,
        max_nodes: n + 8,
        cleans_dead_nodes: false,
        port_limits: vec![
            // The doorbells (`TopicName::doorbell`): one side is every agent.
            PortLimits { suffix: "/poses", max_publishers: n + 4, max_subscribers: DOORBELL_FEW },
            PortLimits { suffix: "/from_agents", max_publishers: n + 4, max_subscribers: DOORBELL_FEW },
            PortLimits { suffix: "/to_agents", max_publishers: DOORBELL_FEW, max_subscribers: n + 4 },
            // One robot's pose: its agent (or the lab's mocap), the
            // orchestrator's relay of a dead robot, a duplicate agent, tools;
            // read by the orchestrator (and its gateway), a bridge, tools.
            PortLimits {
                suffix: "/pose",
                max_publishers: ROBOT_TOPIC_PORTS,
                max_subscribers: ROBOT_TOPIC_PORTS,
            },
            // Commands to one robot: from the orchestrator, to its agent (and
            // a duplicate being refused).
            PortLimits {
                suffix: "/to_agent",
                max_publishers: ROBOT_TOPIC_PORTS,
                max_subscribers: ROBOT_TOPIC_PORTS,
            },
            // One robot's reports: from its agent (and a duplicate being
            // refused), to the orchestrator, a bridge, tools.
            PortLimits {
                suffix: "/from_agent",
                max_publishers: ROBOT_TOPIC_PORTS,
                max_subscribers: ROBOT_TOPIC_PORTS,
            },
        ],
        ..IpcConfig::default()
    }
}

/// The zenoh configuration of every process of a launch over zenoh: the
/// orchestrator in `Mode::Router` (the rendezvous; it listens), agents in
/// `Mode::Client` (they connect to it, and fail at once with a clear error
/// when it is not there).
///
/// Same payload and buffer limits as over iceoryx2. Publishers block
/// instead of dropping under congestion: the lockstep clock needs every
/// `Tick` and `TickDone`, and the launch's traffic is a few small messages
/// per period, far below any link's capacity.
///
/// Every session uses [`Liveness::FAST`] (lease 400 ms, fast reconnect), so
/// a lost agent or orchestrator shows within 500 ms on the other side's
/// liveliness watch (this overrides a `base` file's lease settings).
pub fn zenoh_config(
    mode: Mode,
    listen: Vec<String>,
    connect: Vec<String>,
    base: Option<PathBuf>,
) -> ZenohConfig {
    ZenohConfig {
        limits: Limits { max_payload: MAX_MESSAGE_LEN, buffer: BUS_BUFFER },
        mode,
        listen,
        connect,
        congestion: Congestion::Block,
        base_config: base,
        liveness: Some(Liveness::FAST),
        ..ZenohConfig::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::{RobotId, Swarm};

    #[test]
    fn a_robot_s_own_topics_have_few_ports_on_their_other_side() {
        let config = ipc_config(300);
        let swarm = Swarm::new("s").expect("swarm");
        // A pose: few write it, few read it.
        assert_eq!(config.ports_of(swarm.pose(RobotId(7)).name()), (ROBOT_TOPIC_PORTS, ROBOT_TOPIC_PORTS));
        assert_eq!(
            config.ports_of(swarm.to_agent(RobotId(7)).name()),
            (ROBOT_TOPIC_PORTS, ROBOT_TOPIC_PORTS)
        );
        // A robot's reports: one agent, few readers; every agent rings
        // their doorbell.
        let reports = *swarm.from_agent(RobotId(7)).name();
        assert_eq!(config.ports_of(&reports), (ROBOT_TOPIC_PORTS, ROBOT_TOPIC_PORTS));
        assert_eq!(config.ports_of(&reports.doorbell()), (304, DOORBELL_FEW));
        assert_eq!(config.ports_of(&swarm.pose(RobotId(7)).name().doorbell()), (304, DOORBELL_FEW));
        assert_eq!(config.ports_of(&swarm.to_agent(RobotId(7)).name().doorbell()), (DOORBELL_FEW, 304));
        assert_eq!(config.ports_of(swarm.gate().name()), (304, 304));
    }
}
