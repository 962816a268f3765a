//! The emulated lab's OptiTrack: its bodies served by NatNet
//! (`sim-agent lab --natnet ADDR`), instead of true poses on the bus.
//!
//! Why a second mocap output: a real lab's orchestrator learns where the
//! robots are from Motive, not from the robots; with `--natnet` the lab is
//! seen the same way, through the real binary format and real sockets
//! (`bycoms_natnet_server`, the same server `natnet-serve` runs), and the
//! lab publishes nothing on the bus. Robot k is rigid body `robot<k>`
//! (streaming id k); a robot waiting off the arena is streamed untracked
//! (tracking-valid off, as Motive sends a body out of the volume). Motive's
//! frame is Y-up: lab (x, y) is at (x, 0, −y) and a heading is a yaw about
//! +Y. Frames are stamped in lab time (`--speed`), at `rate_hz` of lab time.

use super::world::Lab;
use bycoms_natnet_server::{BodyConfig, BodyPose, Faults, NatNetServer, ServerConfig, ServerError};
use std::net::SocketAddr;

/// The rigid-body name of robot `id` (1-based).
pub fn body_name(id: u32) -> String {
    format!("robot{id}")
}

/// The lab's bodies on a NatNet server.
pub struct NatNetOut {
    server: NatNetServer,
}

impl NatNetOut {
    /// Serves `robots` bodies on command address `command` at `rate_hz` of
    /// lab time, the lab running `speed` × real time.
    pub fn start(
        command: SocketAddr,
        robots: u32,
        rate_hz: f64,
        speed: f64,
        faults: Faults,
    ) -> Result<Self, ServerError> {
        let bodies = (1..=robots)
            .map(|id| BodyConfig { name: body_name(id), id: id as i32, position: [0.0; 3], yaw_deg: 0.0 })
            .collect();
        let config =
            ServerConfig { rate_hz, app_name: "bycoms emulated lab".into(), multicast: None, bodies, faults };
        let server = NatNetServer::start_at_speed(config, command, speed)?;
        for id in 1..=robots {
            server.set_seen(id as i32, false);
        }
        Ok(Self { server })
    }

    /// Where clients send commands.
    pub fn command_addr(&self) -> SocketAddr {
        self.server.command_addr()
    }

    /// Shows the cameras every body as it is now.
    pub fn update(&self, lab: &Lab) {
        for (robot, pose) in lab.poses() {
            let id = robot.0 as i32;
            match pose {
                Some(b) => {
                    let pose = BodyPose::yawed([b.x as f32, 0.0, -b.y as f32], b.heading as f32);
                    self.server.set_pose(id, pose);
                    self.server.set_seen(id, true);
                }
                None => {
                    self.server.set_seen(id, false);
                }
            }
        }
    }
}
