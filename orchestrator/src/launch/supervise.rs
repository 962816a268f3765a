//! Agent processes: start them, watch them, end them.
//!
//! Why polling and heartbeats both: a child that exits, crashes or is
//! killed (even by `kill -9`) is seen by `try_wait` the next time the loop
//! polls — every few milliseconds — while a child that is alive but hung
//! only shows by its silence, so a registered agent that sends nothing for
//! `heartbeat_timeout` is killed and treated as dead too.
//!
//! Agents are spawned from the thread that runs the launch (the main
//! thread), in their own process group (a Ctrl-C in the terminal reaches the
//! orchestrator only, which then shuts them down in order), with
//! `--parent-pid` so they exit if the orchestrator dies. Dropping the
//! [`Supervisor`] kills and reaps every child still running: whatever way
//! the launch ends, it leaves no process behind.

use anyhow::{Context, Result};
use std::collections::BTreeMap;
use std::io::Write;
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// How an agent executable is invoked.
#[derive(Clone, Debug)]
pub struct AgentCommand {
    /// The executable.
    pub program: PathBuf,
    /// Arguments before the agent's flags (`["sim-agent"]` when the
    /// orchestrator runs agents itself).
    pub prefix: Vec<String>,
}

/// Why an agent is gone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gone {
    /// The process exited (or was killed by a signal).
    Exited(ExitStatus),
    /// Registered, alive, but silent past the heartbeat timeout (killed).
    Silent,
    /// Never registered within the registration timeout (killed).
    NeverRegistered,
    /// Did not answer a lockstep tick in time (killed).
    NoTickReply,
    /// Did not report its start pose in time after `Deploy` (killed).
    NoStartPose,
}

impl std::fmt::Display for Gone {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Exited(status) => write!(f, "its process ended ({status})"),
            Self::Silent => write!(f, "it fell silent (no heartbeat) and was killed"),
            Self::NeverRegistered => write!(f, "it did not register in time and was killed"),
            Self::NoTickReply => write!(f, "it did not answer a lockstep tick in time and was killed"),
            Self::NoStartPose => {
                write!(f, "it did not report its start pose in time after being deployed and was killed")
            }
        }
    }
}

struct Tracked {
    child: Child,
    spawned: Instant,
    last_heard: Option<Instant>,
}

/// The running agent processes, by robot id.
pub struct Supervisor {
    command: AgentCommand,
    children: BTreeMap<u32, Tracked>,
    register_timeout: Duration,
    heartbeat_timeout: Duration,
    last_poll: Instant,
}

/// Least time between two `try_wait` sweeps.
const POLL_EVERY: Duration = Duration::from_millis(5);

impl Supervisor {
    /// A supervisor starting agents with `command`.
    pub fn new(command: AgentCommand, register_timeout: Duration, heartbeat_timeout: Duration) -> Self {
        Self {
            command,
            children: BTreeMap::new(),
            register_timeout,
            heartbeat_timeout,
            last_poll: Instant::now(),
        }
    }

    /// Starts robot `robot`'s agent with `flags`, writing `stdin_text` (the
    /// terrain) to its standard input. Returns its pid.
    pub fn spawn(&mut self, robot: u32, flags: &[String], stdin_text: &str) -> Result<u32> {
        let mut child = Command::new(&self.command.program)
            .args(&self.command.prefix)
            .args(flags)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .process_group(0)
            .spawn()
            .with_context(|| format!("cannot start the agent {}", self.command.program.display()))?;
        let pid = child.id();
        let written = match child.stdin.take() {
            Some(mut stdin) => stdin.write_all(stdin_text.as_bytes()),
            None => Ok(()),
        };
        self.children.insert(robot, Tracked { child, spawned: Instant::now(), last_heard: None });
        // A child that died at once closes the pipe; that shows up as its
        // exit in the next poll, with its own message on stderr.
        if let Err(e) = written {
            if e.kind() != std::io::ErrorKind::BrokenPipe {
                return Err(e).with_context(|| format!("cannot hand the terrain to robot {robot}'s agent"));
            }
        }
        Ok(pid)
    }

    /// Notes that robot `robot` sent something (registration, heartbeat, ...).
    pub fn heard(&mut self, robot: u32) {
        if let Some(t) = self.children.get_mut(&robot) {
            t.last_heard = Some(Instant::now());
        }
    }

    /// Whether robot `robot`'s agent is running (spawned and not yet gone).
    pub fn is_running(&self, robot: u32) -> bool {
        self.children.contains_key(&robot)
    }

    /// The pid of robot `robot`'s running agent.
    pub fn pid(&self, robot: u32) -> Option<u32> {
        self.children.get(&robot).map(|t| t.child.id())
    }

    /// Finds the agents that are gone (exited, silent, never registered);
    /// kills and reaps the hung ones. At most one sweep per few ms unless
    /// `force`.
    pub fn poll(&mut self, force: bool) -> Vec<(u32, Gone)> {
        let now = Instant::now();
        if !force && now.duration_since(self.last_poll) < POLL_EVERY {
            return Vec::new();
        }
        self.last_poll = now;
        let mut gone = Vec::new();
        for (&robot, t) in &mut self.children {
            let verdict = match t.child.try_wait() {
                Ok(Some(status)) => Some(Gone::Exited(status)),
                Ok(None) | Err(_) => match t.last_heard {
                    Some(heard) if now.duration_since(heard) > self.heartbeat_timeout => Some(Gone::Silent),
                    None if now.duration_since(t.spawned) > self.register_timeout => {
                        Some(Gone::NeverRegistered)
                    }
                    _ => None,
                },
            };
            if let Some(v) = verdict {
                if !matches!(v, Gone::Exited(_)) {
                    let _ = t.child.kill();
                    let _ = t.child.wait();
                }
                gone.push((robot, v));
            }
        }
        for (robot, _) in &gone {
            self.children.remove(robot);
        }
        gone
    }

    /// Kills and reaps robot `robot`'s agent; whether it was running.
    pub fn kill(&mut self, robot: u32) -> bool {
        match self.children.remove(&robot) {
            Some(mut t) => {
                let _ = t.child.kill();
                let _ = t.child.wait();
                true
            }
            None => false,
        }
    }

    /// Waits up to `grace` for every agent to exit (after `Shutdown` was
    /// sent), then kills the rest. Returns the robots that had to be killed.
    pub fn wind_down(&mut self, grace: Duration) -> Vec<u32> {
        let deadline = Instant::now() + grace;
        while !self.children.is_empty() && Instant::now() < deadline {
            self.children.retain(|_, t| matches!(t.child.try_wait(), Ok(None)));
            std::thread::sleep(Duration::from_millis(2));
        }
        let killed: Vec<u32> = self.children.keys().copied().collect();
        self.kill_all();
        killed
    }

    fn kill_all(&mut self) {
        for t in self.children.values_mut() {
            let _ = t.child.kill();
            let _ = t.child.wait();
        }
        self.children.clear();
    }
}

impl Drop for Supervisor {
    fn drop(&mut self) {
        self.kill_all();
    }
}
