//! The one conformance suite of the agents seam (`launch::agents`): every
//! [`AgentSource`] passes it. An implementation supplies an
//! [`AgentFixture`] and calls [`run_all`] (see `agent_source_suite.rs`).

use bycoms_orchestrator::launch::agents::{AgentPlan, AgentSource, Gone, Started};
use bycoms_sim::agent_process::AgentArgs;
use std::time::{Duration, Instant};

/// How an implementation is put under test.
pub trait AgentFixture {
    /// A fresh source with these timeouts.
    fn source(&self, register_timeout: Duration, heartbeat_timeout: Duration) -> Box<dyn AgentSource>;
    /// Arguments and terrain text for robot `id`'s agent: one that stays
    /// alive and silent until ended, or (`ends_at_once`) one that ends by
    /// itself right after starting — `None` when agents of this kind cannot
    /// end on their own as far as the source can see.
    fn plan(&self, id: u32, ends_at_once: bool) -> Option<(AgentArgs, String)>;
}

/// A silent agent's plan (every fixture has one).
fn start(source: &mut dyn AgentSource, fixture: &dyn AgentFixture, id: u32, ends: bool) -> Option<Started> {
    let (args, terrain) = fixture.plan(id, ends)?;
    let plan = AgentPlan { args: &args, terrain_text: &terrain };
    Some(source.start(id, &plan).unwrap_or_else(|e| panic!("starting robot {id}: {e}")))
}

/// Polls (forced) until something is reported or `timeout` passes.
fn poll_until(source: &mut dyn AgentSource, timeout: Duration) -> Vec<(u32, Gone)> {
    let deadline = Instant::now() + timeout;
    loop {
        let gone = source.poll(true);
        if !gone.is_empty() || Instant::now() >= deadline {
            return gone;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Polls for `span` and collects everything reported.
fn poll_for(source: &mut dyn AgentSource, span: Duration) -> Vec<(u32, Gone)> {
    let deadline = Instant::now() + span;
    let mut all = Vec::new();
    while Instant::now() < deadline {
        all.extend(source.poll(true));
        std::thread::sleep(Duration::from_millis(5));
    }
    all
}

const LONG: Duration = Duration::from_secs(30);
const SHORT: Duration = Duration::from_millis(150);
const WAIT: Duration = Duration::from_secs(5);

/// Runs every check against `fixture`.
pub fn run_all(fixture: &dyn AgentFixture) {
    started_agents_run_and_nothing_is_lost(fixture);
    an_agent_that_never_registers_is_reported_once(fixture);
    an_agent_that_falls_silent_is_reported_once(fixture);
    a_killed_agent_is_not_reported(fixture);
    an_agent_that_ends_is_reported(fixture);
    wind_down_ends_everything_and_names_the_rest(fixture);
    unknown_robots_are_ignored(fixture);
}

fn started_agents_run_and_nothing_is_lost(fixture: &dyn AgentFixture) {
    let mut source = fixture.source(LONG, LONG);
    assert!(!source.kind().is_empty(), "a source names its kind");
    let started = start(&mut *source, fixture, 1, false).expect("every fixture has silent agents");
    assert!(source.is_running(1), "running after start");
    match started {
        Started::Process { pid } => assert_eq!(source.pid(1), Some(pid), "pid as started"),
        Started::Awaited | Started::Thread => assert_eq!(source.pid(1), None, "no local process, no pid"),
    }
    source.heard(1);
    assert_eq!(poll_for(&mut *source, Duration::from_millis(100)), [], "nothing lost");
    assert!(source.is_running(1));
}

fn an_agent_that_never_registers_is_reported_once(fixture: &dyn AgentFixture) {
    let mut source = fixture.source(SHORT, LONG);
    start(&mut *source, fixture, 2, false);
    let gone = poll_until(&mut *source, WAIT);
    assert_eq!(gone, [(2, Gone::NeverRegistered)], "the silent agent is reported as never registered");
    assert!(!source.is_running(2), "a reported agent is no longer running");
    assert_eq!(poll_for(&mut *source, Duration::from_millis(300)), [], "reported exactly once");
}

fn an_agent_that_falls_silent_is_reported_once(fixture: &dyn AgentFixture) {
    let mut source = fixture.source(LONG, SHORT);
    start(&mut *source, fixture, 3, false);
    // Heard often enough, it is never lost.
    let until = Instant::now() + Duration::from_millis(400);
    while Instant::now() < until {
        source.heard(3);
        assert_eq!(source.poll(true), [], "an agent heard from is alive");
        std::thread::sleep(Duration::from_millis(10));
    }
    let gone = poll_until(&mut *source, WAIT);
    assert_eq!(gone, [(3, Gone::Silent)], "silence after being heard is reported");
    assert!(!source.is_running(3));
    assert_eq!(poll_for(&mut *source, Duration::from_millis(300)), [], "reported exactly once");
}

fn a_killed_agent_is_not_reported(fixture: &dyn AgentFixture) {
    let mut source = fixture.source(LONG, LONG);
    start(&mut *source, fixture, 1, false);
    start(&mut *source, fixture, 2, false);
    assert!(source.kill(1), "killing a running agent");
    assert!(!source.kill(1), "a second kill finds nothing");
    assert!(!source.is_running(1) && source.pid(1).is_none());
    assert!(source.is_running(2), "the other agent is untouched");
    assert_eq!(poll_for(&mut *source, Duration::from_millis(200)), [], "a kill is not a loss to report");
}

fn an_agent_that_ends_is_reported(fixture: &dyn AgentFixture) {
    let mut source = fixture.source(LONG, LONG);
    if start(&mut *source, fixture, 4, true).is_none() {
        return; // this kind cannot see its agents end on their own
    }
    let gone = poll_until(&mut *source, WAIT);
    assert!(matches!(gone.as_slice(), [(4, Gone::Exited(_) | Gone::Disconnected)]), "{gone:?}");
    assert!(!source.is_running(4));
}

fn wind_down_ends_everything_and_names_the_rest(fixture: &dyn AgentFixture) {
    let mut source = fixture.source(LONG, LONG);
    start(&mut *source, fixture, 1, false);
    start(&mut *source, fixture, 2, false);
    let ends = start(&mut *source, fixture, 3, true).is_some();
    for id in 1..=3 {
        source.heard(id);
    }
    let grace = Duration::from_millis(500);
    let t0 = Instant::now();
    let mut killed = source.wind_down(grace);
    killed.sort_unstable();
    assert!(t0.elapsed() < grace + Duration::from_secs(3), "wind_down keeps to its grace");
    assert_eq!(killed, [1, 2], "the agents that did not end by themselves (robot 3 ends: {ends})");
    for id in 1..=3 {
        assert!(!source.is_running(id), "robot {id} still running after wind_down");
    }
    assert_eq!(source.poll(true), [], "nothing left to report");
}

fn unknown_robots_are_ignored(fixture: &dyn AgentFixture) {
    let mut source = fixture.source(SHORT, SHORT);
    source.heard(99);
    assert!(!source.is_running(99) && source.pid(99).is_none() && !source.kill(99));
    assert_eq!(poll_for(&mut *source, Duration::from_millis(300)), [], "nothing was started");
    assert_eq!(source.wind_down(Duration::from_millis(10)), Vec::<u32>::new());
}
