//! The checks of this host: open-files and memory limits for the planned
//! robot count, the gateways' UDP ports free (`bycoms_runtime::doctor::host`,
//! shared with `gateway doctor`), iceoryx2 leftovers of dead swarms, and the
//! NatNet server answering.
//!
//! Why with the launch's own numbers: the open-files decision is
//! `launch::limits`'s (the doctor asks it with a `raise` that does
//! nothing), so the doctor says exactly what the launch would do; the
//! memory estimate is the worst per-robot figure `bench crowd` measured
//! (docs/BENCHMARKS.md).

use super::Finding;
use bycoms_launch::config::Transport;
use bycoms_launch::limits::{decide, files_needed, FilesCheck};
use bycoms_mocap::{ClientConfig, NatNetClient};
use bycoms_runtime::words::count;
use std::time::Duration;

/// Memory of a launch besides its robots, MB (the orchestrator of a
/// 300-robot launch held 81 MB; with the recording and the view, more).
pub const BASE_MB: u64 = 256;
/// Memory per robot, MB: the worst per-robot PSS `bench crowd` measured
/// (5.8 MB at 1000 robots over iceoryx2).
pub const MB_PER_ROBOT: u64 = 6;

/// The open-files finding for `robots` robots over `transport` with the
/// limits `soft` and `hard`.
pub fn open_files(robots: u32, transport: Transport, soft: u64, hard: u64) -> Finding {
    const CHECK: &str = "open-files";
    let needed = files_needed(robots, transport);
    match decide(needed, robots, soft, hard, |_| Ok(())) {
        Ok(FilesCheck::Enough) => Finding::ok(CHECK, format!("{robots} robots need about {needed} open files; the limit is {soft}")),
        Ok(FilesCheck::Raised(_, to)) => Finding::ok(
            CHECK,
            format!("{robots} robots need about {needed} open files; the launch raises the limit from {soft} to {to}"),
        ),
        Err(cause) => Finding::error(CHECK, cause, format!("ulimit -Hn {needed} (as root), or LimitNOFILE={needed}")),
    }
}

/// This process's open-files limits.
pub fn open_files_here(robots: u32, transport: Transport) -> Finding {
    match nix::sys::resource::getrlimit(nix::sys::resource::Resource::RLIMIT_NOFILE) {
        Ok((soft, hard)) => open_files(robots, transport, soft, hard),
        Err(e) => {
            Finding::warn("open-files", format!("cannot read the open-files limit: {e}"), "run on Linux")
        }
    }
}

/// The memory finding for `robots` robots with `available_mb` available.
pub fn memory(robots: u32, available_mb: u64) -> Finding {
    const CHECK: &str = "memory";
    let needed = BASE_MB + MB_PER_ROBOT * u64::from(robots);
    if needed <= available_mb {
        return Finding::ok(
            CHECK,
            format!("{robots} robots need about {needed} MB; {available_mb} MB available"),
        );
    }
    Finding::error(
        CHECK,
        format!("{robots} robots need about {needed} MB and only {available_mb} MB are available"),
        "close other programs, or launch fewer robots",
    )
}

/// `MemAvailable` of `/proc/meminfo`, MB.
pub fn available_mb() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024)
}

/// Whether each robot's gateway address can be bound here (every host's check).
pub use bycoms_runtime::doctor::host::udp_ports;

/// Dead nodes iceoryx2 still keeps files of (on this process's bus:
/// `BYCOMS_IPC_ISOLATION` selects it), and unheld swarm lock files.
pub fn iceoryx2_leftovers() -> Finding {
    use iceoryx2::node::{Node, NodeState};
    use iceoryx2::prelude::CallbackProgression;
    const CHECK: &str = "iceoryx2";
    bycoms_runtime::cli::quiet_iceoryx2();
    let tag = bycoms_protocol::bus::ipc::root::tag_from_env();
    let config = match bycoms_protocol::bus::ipc::root::config(tag.as_deref()) {
        Ok(config) => config,
        Err(e) => {
            return Finding::error(
                CHECK,
                e.to_string(),
                "set BYCOMS_IPC_ISOLATION to 1-48 letters, digits, - or _",
            )
        }
    };
    let mut dead = 0u64;
    let listed = Node::<iceoryx2::service::ipc::Service>::list(&config, |state| {
        if let NodeState::Dead(_) = state {
            dead += 1;
        }
        CallbackProgression::Continue
    });
    match listed {
        Err(e) => Finding::warn(
            CHECK,
            format!("cannot list iceoryx2 nodes: {e:?}"),
            "check /dev/shm and the temporary directory's permissions",
        ),
        Ok(()) => leftovers(dead),
    }
}

/// The finding of `dead` dead iceoryx2 nodes on this host.
pub fn leftovers(dead: u64) -> Finding {
    const CHECK: &str = "iceoryx2";
    if dead == 0 {
        return Finding::ok(CHECK, "no leftovers of dead swarms");
    }
    Finding::warn(
        CHECK,
        format!("{} (killed launches or agents) left files in /dev/shm", count(dead, "dead iceoryx2 node")),
        "orchestrator doctor --clean (the next launch also removes them when it opens the bus)",
    )
}

/// Whether the NatNet server of `client` answers within `timeout` per attempt.
pub fn natnet(client: &ClientConfig, timeout: Duration) -> Finding {
    const CHECK: &str = "natnet";
    let mut bounded = client.clone();
    bounded.reply_timeout_ms =
        bounded.reply_timeout_ms.min(u64::try_from(timeout.as_millis()).unwrap_or(u64::MAX));
    match NatNetClient::connect(&bounded) {
        Ok(c) => Finding::ok(CHECK, format!("NatNet server {} answers ({})", client.server, c.server_info().app_name)),
        Err(e) => Finding::error(
            CHECK,
            e.to_string(),
            "start Motive's streaming (Edit > Settings > Streaming: Broadcast Frame Data) and check [mocap.natnet.client] server and local",
        ),
    }
}
