//! Agents spawned here: one child process per robot (the default source).
//!
//! Why polling: a child that exits, crashes or is killed (even by `kill
//! -9`) is seen by `try_wait` the next time the driver's loop polls (every
//! pass, at most 10 ms apart). A child that is alive but hung only shows by
//! its silence: that is the launch core's heartbeat timer
//! (`orchestrator/launch-core/src/timers.rs`), which ends it with [`AgentSource::kill`].
//!
//! Agents are spawned from a thread of their own ([`Spawner`]: their
//! children inherit none of the launch's files), in their own process group
//! (a Ctrl-C in the terminal reaches the orchestrator only, which then shuts
//! them down in order), with `--parent-pid` so they exit if the
//! orchestrator dies. Their standard error passes through ours
//! ([`StderrTap`]), and the last error line of an agent that is gone is the
//! launch's reason for it. Dropping the
//! [`Spawned`] source kills and reaps every child still running: whatever
//! way the launch ends, it leaves no process behind.

use super::spawner::{Request, Spawn, Spawner};
use super::stderr_tap::StderrTap;
use super::{AgentError, AgentPlan, AgentProperties, AgentSource, Gone, Started, TICKS_AT_ONCE};
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::process::Child;
use std::time::Duration;

/// How an agent executable is invoked.
#[derive(Clone, Debug)]
pub struct AgentCommand {
    /// The executable.
    pub program: PathBuf,
    /// Arguments before the agent's flags (`["sim-agent"]` when the
    /// orchestrator runs agents itself).
    pub prefix: Vec<String>,
    /// The launch's own `sim-agent` (beside it, or itself): of its build,
    /// it takes `ToAgent::Ticks`. An executable chosen by name may be
    /// another build or another program, which is sent one `Tick` a period.
    pub own: bool,
}

/// The running agent processes, by robot id.
pub struct Spawned {
    command: AgentCommand,
    children: BTreeMap<u32, Child>,
    /// Each child's standard error, passed through, its last error kept.
    taps: BTreeMap<u32, StderrTap>,
    /// The last error lines of agents reported gone, not yet taken.
    said: BTreeMap<u32, String>,
    /// Agents heard from (registered): the others may have missed `Shutdown`.
    heard: BTreeSet<u32>,
    /// Where they are started from (once the first one is): a thread whose
    /// children inherit none of the launch's files.
    spawner: Option<Spawner>,
}

/// The name it had before the agents seam (`bench scale` still uses it).
pub type Supervisor = Spawned;

/// Longest wait for an exited child's stderr to end.
const LAST_WORDS: Duration = Duration::from_millis(100);

impl Spawned {
    /// A source starting agents with `command`.
    pub fn new(command: AgentCommand) -> Self {
        Self {
            command,
            children: BTreeMap::new(),
            taps: BTreeMap::new(),
            said: BTreeMap::new(),
            heard: BTreeSet::new(),
            spawner: None,
        }
    }

    /// Starts robot `robot`'s agent with `flags`, writing `stdin_text` (the
    /// terrain) to its standard input. Returns its pid.
    pub fn spawn(&mut self, robot: u32, flags: &[String], stdin_text: &str) -> Result<u32, AgentError> {
        let program = self.command.program.clone();
        let failed =
            |source| AgentError::Spawn { program: self.command.program.display().to_string(), source };
        let spawner = match &mut self.spawner {
            Some(spawner) => spawner,
            empty => empty.insert(Spawner::start().map_err(failed)?),
        };
        let args = self.command.prefix.iter().chain(flags).cloned().collect();
        let request = Request {
            program,
            args,
            stdin_text: stdin_text.to_owned(),
            tap_name: format!("agent-{robot}-stderr"),
        };
        let Spawn { child, tap, written } = spawner.spawn(request).map_err(failed)?;
        let pid = child.id();
        self.taps.insert(robot, tap);
        self.children.insert(robot, child);
        self.heard.remove(&robot);
        // A child that died at once closes the pipe; that shows up as its
        // exit in the next poll, with its own message on stderr.
        if let Err(source) = written {
            if source.kind() != std::io::ErrorKind::BrokenPipe {
                return Err(AgentError::Handoff { robot, source });
            }
        }
        Ok(pid)
    }

    fn end(&mut self, robot: u32) -> bool {
        self.heard.remove(&robot);
        self.taps.remove(&robot);
        match self.children.remove(&robot) {
            Some(mut child) => {
                let _ = child.kill();
                let _ = child.wait();
                true
            }
            None => false,
        }
    }

    /// Asks the agents never heard from to end (SIGTERM: their lifeline
    /// ends them in order, exit 130). Why: an agent still starting (the
    /// next robot's, started ahead while the previous one moves) may not
    /// have its command topic open yet, so the `Shutdown` the launch sent
    /// at its end was lost on it; it used to be killed after the whole
    /// grace, "did not exit after Shutdown", at the end of healthy runs.
    fn terminate_unheard(&mut self) {
        use nix::sys::signal::{kill, Signal};
        use nix::unistd::Pid;
        for (id, child) in &self.children {
            if self.heard.contains(id) {
                continue;
            }
            if let Ok(pid) = i32::try_from(child.id()) {
                // Already gone: seen by `try_wait` next.
                let _ = kill(Pid::from_raw(pid), Signal::SIGTERM);
            }
        }
    }

    fn kill_all(&mut self) {
        let ids: Vec<u32> = self.children.keys().copied().collect();
        for id in ids {
            self.end(id);
        }
    }
}

/// What spawned agents are: started one at a time on this host, over a
/// bus that keeps every command; agents of the launch's own build
/// (`own_build`) take a creeping robot's ticks many at once.
pub fn properties(own_build: bool) -> AgentProperties {
    AgentProperties {
        keeps_commands: true,
        ticks_at_once: if own_build { TICKS_AT_ONCE } else { 1 },
        ..AgentProperties::of_kind("spawned")
    }
}

impl AgentSource for Spawned {
    fn properties(&self) -> AgentProperties {
        properties(self.command.own)
    }

    fn start(&mut self, id: u32, plan: &AgentPlan<'_>) -> Result<Started, AgentError> {
        let args = plan.joining.sim_agent(id, plan.settings);
        let pid = self.spawn(id, &args.to_flags(), &plan.settings.terrain)?;
        Ok(Started::Process { pid })
    }

    fn heard(&mut self, id: u32) {
        if self.children.contains_key(&id) {
            self.heard.insert(id);
        }
    }

    fn is_running(&self, id: u32) -> bool {
        self.children.contains_key(&id)
    }

    fn pid(&self, id: u32) -> Option<u32> {
        self.children.get(&id).map(Child::id)
    }

    /// Finds the agents whose process exited, with their last words, and
    /// reaps them.
    fn poll(&mut self) -> Vec<(u32, Gone)> {
        let mut gone = Vec::new();
        for (&robot, child) in &mut self.children {
            if let Ok(Some(status)) = child.try_wait() {
                gone.push((robot, Gone::Exited(status)));
            }
        }
        for (robot, _) in &gone {
            // Its last words may still be in the pipe: wait for its end
            // (briefly: a grandchild could hold it open).
            if let Some(words) = self.taps.get(robot).and_then(|t| t.last_error(LAST_WORDS)) {
                self.said.insert(*robot, words);
            }
            // Reaps (or re-reaps, harmlessly) the exited.
            self.end(*robot);
        }
        gone
    }

    fn last_error(&mut self, id: u32) -> Option<String> {
        self.said.remove(&id)
    }

    fn kill(&mut self, id: u32) -> bool {
        self.end(id)
    }

    fn ask_to_end(&mut self) {
        self.terminate_unheard();
    }

    fn reap(&mut self) -> bool {
        let exited: Vec<u32> = self
            .children
            .iter_mut()
            .filter_map(|(id, c)| (!matches!(c.try_wait(), Ok(None))).then_some(*id))
            .collect();
        for id in exited {
            self.end(id);
        }
        !self.children.is_empty()
    }

    fn end_rest(&mut self) -> Vec<u32> {
        let killed: Vec<u32> = self.children.keys().copied().collect();
        self.kill_all();
        killed
    }
}

impl Drop for Spawned {
    fn drop(&mut self) {
        self.kill_all();
    }
}
