//! What a launch needs of the machine, checked before anything starts.
//!
//! Why: over iceoryx2 every port is a handful of open files (shared-memory
//! segments and event sockets), and the orchestrator opens ports for all n
//! robots (each robot's commands, pose and reports; the agents are sent
//! their beacons and open a few ports each). With the
//! common `ulimit -n 1024` a 100-robot launch used to die after 30 s, at
//! robot 46, with "PublishSubscribeCreateError(InternalFailure)" and no word
//! about files. So before the bus is opened the launch estimates the open
//! files the busiest process needs, raises its own soft limit towards the
//! hard one when that suffices (the agents it starts inherit it), and
//! otherwise refuses, naming the limit and the fix.
//!
//! The estimate, measured on this project's iceoryx2 bus: each port the
//! orchestrator opens costs three files (the service's static config, its
//! dynamic config, the port's tag), plus its data segment and one
//! connection per port on the other side; a robot's three topics (commands,
//! pose, reports) cost it 15, its agent's wake-up on the shared `to_agents`
//! doorbell two more (a socket and the listener's management segment), and
//! its agent's standard error one pipe: 18 per robot (the orchestrator of a
//! 100-robot launch held 1 818 at its peak). Before the robots' topics
//! shared their wake-ups (`TopicName::doorbell`) it was 26. We count
//! [`FILES_PER_ROBOT`] per robot plus [`BASE_FILES`] for everything else
//! (the recording, the terminal, zenoh's runtime, libraries). Agents hold a
//! few dozen each (they close what they
//! inherit, `bycoms_runtime::inherited`). zenoh
//! needs a socket or two per agent, in-memory launches none.

use super::config::Transport;
use nix::sys::resource::{getrlimit, setrlimit, Resource};

/// Open files per robot over iceoryx2 (see the module docs).
pub const FILES_PER_ROBOT: u64 = 19;
/// Open files per robot over zenoh (a connection, a liveliness token).
pub const ZENOH_FILES_PER_ROBOT: u64 = 4;
/// Open files of a process besides its ports.
pub const BASE_FILES: u64 = 64;

/// The open files the busiest process of a launch of `robots` robots over
/// `transport` needs, by the estimate above.
pub fn files_needed(robots: u32, transport: Transport) -> u64 {
    let per_robot = match transport {
        Transport::Ipc => FILES_PER_ROBOT,
        Transport::Zenoh => ZENOH_FILES_PER_ROBOT,
        Transport::Memory => 0,
    };
    BASE_FILES + per_robot * u64::from(robots)
}

/// What [`ensure_open_files`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilesCheck {
    /// The soft limit was enough.
    Enough,
    /// The soft limit was raised from `.0` to `.1` (at most the hard limit).
    Raised(u64, u64),
}

/// Makes sure this process (and the agents it starts, which inherit its
/// limit) may open `needed` files: raises the soft limit when the hard one
/// allows, else says which limit stops the launch and how to lift it.
pub fn ensure_open_files(needed: u64, robots: u32) -> Result<FilesCheck, String> {
    let (soft, hard) =
        getrlimit(Resource::RLIMIT_NOFILE).map_err(|e| format!("cannot read the open-files limit: {e}"))?;
    decide(needed, robots, soft, hard, |to| {
        setrlimit(Resource::RLIMIT_NOFILE, to, hard)
            .map_err(|e| format!("cannot raise the open-files limit: {e}"))
    })
}

/// The decision of [`ensure_open_files`] for limits `soft` and `hard`,
/// with `raise` setting the soft limit (`orchestrator doctor` asks it
/// with a `raise` that does nothing).
pub fn decide(
    needed: u64,
    robots: u32,
    soft: u64,
    hard: u64,
    raise: impl FnOnce(u64) -> Result<(), String>,
) -> Result<FilesCheck, String> {
    if needed <= soft {
        return Ok(FilesCheck::Enough);
    }
    if needed > hard {
        return Err(format!(
            "a launch of {robots} robots needs about {needed} open files per process, and this shell allows at \
             most {hard} (the hard limit of `ulimit -n`): raise it (e.g. `ulimit -Hn {needed}` as root, or \
             `LimitNOFILE=` in a systemd unit), or launch fewer robots"
        ));
    }
    // Some headroom over the estimate, within the hard limit.
    let to = needed.saturating_mul(2).min(hard);
    raise(to)?;
    tracing::info!(from = soft, to, needed, "raised the open-files limit for the launch's ports");
    Ok(FilesCheck::Raised(soft, to))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_estimate_covers_what_launches_held_and_allows_what_ran() {
        // The orchestrator's peak open files, measured by `bench crowd`:
        // 1 823 at 100 robots, 5 430 at 300, 17 058 with 919 of 1000 alive.
        assert!(files_needed(100, Transport::Ipc) >= 1_823);
        assert!(files_needed(300, Transport::Ipc) >= 5_430);
        assert!(files_needed(1000, Transport::Ipc) >= 17_058);
        // And it does not refuse what fits: 1000 robots under this
        // machine's hard limit of 20 000; 3 robots under 1024.
        assert!(files_needed(1000, Transport::Ipc) < 20_000);
        assert!(files_needed(3, Transport::Ipc) < 1024);
        assert_eq!(files_needed(1000, Transport::Memory), BASE_FILES);
        assert!(files_needed(1000, Transport::Zenoh) < files_needed(1000, Transport::Ipc));
    }

    #[test]
    fn the_soft_limit_is_raised_within_the_hard_one_or_the_launch_refused() {
        let mut raised = None;
        assert_eq!(decide(500, 10, 1024, 4096, |_| unreachable!("enough")), Ok(FilesCheck::Enough));
        let got = decide(2464, 100, 1024, 1 << 20, |to| {
            raised = Some(to);
            Ok(())
        });
        assert_eq!(got, Ok(FilesCheck::Raised(1024, 4928)));
        assert_eq!(raised, Some(4928));
        assert_eq!(decide(3000, 100, 1024, 4096, |_| Ok(())), Ok(FilesCheck::Raised(1024, 4096)));
        let refused = decide(2464, 100, 1024, 2048, |_| unreachable!("refused first")).unwrap_err();
        assert!(
            refused.contains("2464 open files") && refused.contains("2048") && refused.contains("ulimit -Hn")
        );
    }

    #[test]
    fn this_process_may_open_what_a_small_launch_needs() {
        let needed = files_needed(3, Transport::Ipc);
        assert!(ensure_open_files(needed, 3).is_ok());
        let (soft, _) = getrlimit(Resource::RLIMIT_NOFILE).expect("limit");
        assert!(soft >= needed);
    }
}
