//! A lab of two robots on the emulated NatNet server, read back over
//! loopback UDP: the fixture of this crate's tests and of the launch's
//! NatNet pose source's tests (`bycoms-launch`, through the feature
//! `testing`).

use crate::{ArenaTransform, ClientConfig, NatNetPoseSource, NatNetSourceConfig, TrackerConfig};
use bycoms_natnet_server::{BodyConfig, Faults, NatNetServer, ServerConfig};
use bycoms_protocol::RobotId;
use std::collections::BTreeMap;

/// The emulated server's frame rate.
pub const RATE: f64 = 120.0;
/// Arena units per metre.
pub const SCALE: f64 = 10.0;

/// The lab: robots 1 and 2 as rigid bodies 11 and 12, with `faults`.
pub fn lab(faults: Faults) -> ServerConfig {
    ServerConfig {
        rate_hz: RATE,
        app_name: "lab".into(),
        multicast: None,
        bodies: vec![
            BodyConfig { name: "robot1".into(), id: 11, position: [0.0; 3], yaw_deg: 0.0 },
            BodyConfig { name: "robot2".into(), id: 12, position: [2.0, 0.0, 0.0], yaw_deg: 0.0 },
        ],
        faults,
    }
}

/// The lab's two robots read from `server` over loopback UDP.
pub fn udp_config(server: &NatNetServer) -> NatNetSourceConfig {
    use std::net::Ipv4Addr;
    NatNetSourceConfig {
        client: ClientConfig {
            server: server.command_addr(),
            local: Ipv4Addr::LOCALHOST.into(),
            multicast: None,
            reply_timeout_ms: 1000,
        },
        arena: ArenaTransform { scale: SCALE, ..ArenaTransform::default() },
        bodies: BTreeMap::from([("robot1".to_string(), RobotId(1)), ("robot2".to_string(), RobotId(2))]),
        tracker: TrackerConfig { max_speed: 1.5, jump_slack: 0.2, lost_after_us: 500_000 },
    }
}

/// [`udp_config`]'s source, connected.
pub fn udp_source(server: &NatNetServer) -> NatNetPoseSource {
    NatNetPoseSource::connect(&udp_config(server)).unwrap()
}
