//! The checks of a host's own resources every doctor shares: a UDP port
//! free for a gateway, and the open-files limit for what a process needs.
//!
//! Why bind to check a port: whether a gateway can listen is what the
//! gateway finds when it binds, so the doctor does exactly that (and lets
//! go at once); an address of another host or one held by a gateway or an
//! emulated lab left running fails here as it would fail there.

use super::Finding;
use std::net::{SocketAddr, UdpSocket};

/// Open files an agent process needs (a `sim-agent`, a gateway): it
/// closes what it inherits (`inherited`) and holds its robot's ports, a
/// zenoh session and its standard streams. Measured over zenoh on
/// loopback, mid-run: a `sim-agent` held 22, a gateway 23 (with its
/// robot's UDP socket); this is the orchestrator's allowance for a
/// process besides its ports (`launch::limits::BASE_FILES`), room to spare.
pub const AGENT_FILES: u64 = 64;

/// Whether each robot's gateway address (`(robot, address)`) can be bound here.
pub fn udp_ports(gateways: &[(u32, SocketAddr)]) -> Vec<Finding> {
    const CHECK: &str = "udp-ports";
    let mut found = Vec::new();
    for &(robot, addr) in gateways {
        if let Err(e) = UdpSocket::bind(addr) {
            let fix = match e.kind() {
                std::io::ErrorKind::AddrInUse => {
                    format!("stop what holds it (`ss -ulpn 'sport = :{}'`: a gateway or emulated lab left running), or give robot {robot} another gateway port", addr.port())
                }
                _ => format!("give robot {robot} a gateway address of this host in the robots file"),
            };
            found.push(Finding::error(
                CHECK,
                format!("robot {robot}'s gateway cannot bind {addr}: {e}"),
                fix,
            ));
        }
    }
    if found.is_empty() {
        let free = match gateways {
            [(robot, addr)] => format!("robot {robot}'s gateway UDP port {addr} is free"),
            many => format!("the {} gateways' UDP ports are free", many.len()),
        };
        found.push(Finding::ok(CHECK, free));
    }
    found
}

/// The open-files finding of a process that needs `needed` files under the
/// limits `soft` and `hard` (agents do not raise their own limit: the soft
/// one is what they get).
pub fn open_files(needed: u64, soft: u64, hard: u64) -> Finding {
    const CHECK: &str = "open-files";
    if soft >= needed {
        return Finding::ok(
            CHECK,
            format!("this agent needs about {needed} open files; the limit is {soft}"),
        );
    }
    let cause = format!("this agent needs about {needed} open files and the limit is {soft} (hard {hard})");
    let fix = if hard >= needed {
        format!("ulimit -n {needed} in the agent's shell, or LimitNOFILE={needed} in its unit")
    } else {
        format!("ulimit -Hn {needed} (as root), or LimitNOFILE={needed} in its unit")
    };
    Finding::error(CHECK, cause, fix)
}

/// [`open_files`] with this process's limits.
pub fn open_files_here(needed: u64) -> Finding {
    match nix::sys::resource::getrlimit(nix::sys::resource::Resource::RLIMIT_NOFILE) {
        Ok((soft, hard)) => open_files(needed, soft, hard),
        Err(e) => {
            Finding::warn("open-files", format!("cannot read the open-files limit: {e}"), "run on Linux")
        }
    }
}
