//! The one conformance suite of the agents seam (`launch::agents`): every
//! [`AgentSource`] passes it. An implementation supplies an
//! [`AgentFixture`] and calls [`run_all`] (see `agent_source_suite.rs`).
//!
//! Why every method is checked against what the fixture states
//! ([`Expected`]): the engine decides from the property methods
//! (`all_at_once`, `needs_placement`, `stop_when_stuck`, `wants_poses`, `senses_beacons`,
//! `held_when_unreachable`, `robot_link_grace`, the words of `start_hint`
//! and `ended_by`), so a property that changes must fail a test, not only a
//! behaviour.
//!
//! What is checked here is IO: agents started, seen to end, killed, wound
//! down, dropped, their tokens reported. No check has a timing threshold: a
//! source reads no clock and decides no deadline. The supervision rules
//! (registration and heartbeat timeouts, link grace, quiet, robot-link
//! grace) are the launch core's timers, tested in virtual time
//! (`orchestrator/launch-core/src/timers.rs` and the harness's schedules); here it is only
//! checked that a source reports no silent agent by itself.
//!
//! A check that cannot apply to an implementation (an agent that ends by
//! itself, where nothing is started here) is named in the returned
//! [`Report`] with the reason, never skipped silently (see `suites/mod.rs`).

use super::Report;
use bycoms_launch::agents::{AgentPlan, AgentSource, Gone, Joining, Started};
use bycoms_launch::driver::wind_down;
use bycoms_sim_agent::RunSettings;
use std::time::{Duration, Instant};

/// What [`AgentSource::start`] starts for this kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Starts {
    /// A process on this host ([`Started::Process`], with its pid).
    Process,
    /// Nothing here: the agent is expected ([`Started::Awaited`]).
    Awaited,
    /// A thread of this process ([`Started::Thread`]).
    Thread,
}

impl Starts {
    fn is(self, started: &Started) -> bool {
        matches!(
            (self, started),
            (Self::Process, Started::Process { .. })
                | (Self::Awaited, Started::Awaited)
                | (Self::Thread, Started::Thread)
        )
    }
}

/// Whether an agent of this kind can end by itself as far as its source
/// sees, and how [`AgentSource::poll`] then reports it.
#[derive(Clone, Copy, Debug)]
pub enum EndsByItself {
    /// Its process exits with `code`: [`Gone::Exited`].
    Exits {
        /// The exit code the fixture's ending agent exits with.
        code: i32,
    },
    /// Its thread ends: [`Gone::ThreadEnded`].
    ThreadEnds,
    /// Its link goes: its liveliness token is withdrawn, reported by
    /// [`AgentSource::tokens`] (the core decides what it means).
    Disconnects,
    /// It cannot: the checks that need one are not applicable, for this
    /// reason.
    Cannot {
        /// Why not.
        why: &'static str,
    },
}

/// What an implementation is expected to be and do (stated by its fixture,
/// checked by the suite).
#[derive(Clone, Copy, Debug)]
pub struct Expected {
    /// `AgentProperties::kind`.
    pub kind: &'static str,
    /// `AgentProperties::all_at_once`.
    pub all_at_once: bool,
    /// `AgentProperties::needs_placement`.
    pub needs_placement: bool,
    /// `AgentProperties::stop_when_stuck`.
    pub stop_when_stuck: bool,
    /// `AgentProperties::wants_poses`.
    pub wants_poses: bool,
    /// `AgentProperties::senses_beacons`.
    pub senses_beacons: bool,
    /// Words `AgentProperties::start_hint` contains; `None`: it is empty.
    pub start_hint: Option<&'static str>,
    /// Words `AgentProperties::ended_by` contains.
    pub ended_by: &'static str,
    /// What [`AgentSource::start`] starts.
    pub starts: Starts,
    /// Whether (and how) an agent can be seen ending by itself.
    pub ends_by_itself: EndsByItself,
    /// `AgentProperties::held_when_unreachable`.
    pub held_when_unreachable: bool,
    /// `AgentProperties::robot_link_grace`.
    pub robot_link_grace: Option<Duration>,
}

/// How an implementation is put under test.
pub trait AgentFixture {
    /// What the implementation is expected to be and do.
    fn expected(&self) -> Expected;
    /// A fresh source.
    fn source(&self) -> Box<dyn AgentSource>;
    /// How robot `id`'s agent joins and what it runs: one that stays
    /// alive and silent until ended, or (`ends_by_itself`) one that ends by
    /// itself right after starting. Asked for an ending agent only when
    /// [`Expected::ends_by_itself`] says it can; called after
    /// [`AgentFixture::source`], for the source made last.
    fn plan(&self, id: u32, ends_by_itself: bool) -> (Joining, RunSettings);
}

/// Starts robot `id`'s agent (silent, or ending by itself).
fn start(source: &mut dyn AgentSource, fixture: &dyn AgentFixture, id: u32, ends: bool) -> Started {
    let (joining, settings) = fixture.plan(id, ends);
    let plan = AgentPlan { joining: &joining, settings: &settings };
    source.start(id, &plan).unwrap_or_else(|e| panic!("starting robot {id}: {e}"))
}

/// What a source reports an agent's end with: [`AgentSource::poll`]'s
/// [`Gone`], or a withdrawn token from [`AgentSource::tokens`].
#[derive(Debug, PartialEq)]
enum Ended {
    Gone(u32, Gone),
    TokenWithdrawn(u32),
}

/// The ends a source reports now: agents gone, tokens withdrawn (an
/// absence is checked at one instant: a source decides nothing over time;
/// a token that comes is no end).
fn reported(source: &mut dyn AgentSource) -> Vec<Ended> {
    let mut ended: Vec<Ended> = source.poll().into_iter().map(|(id, g)| Ended::Gone(id, g)).collect();
    ended.extend(source.tokens().into_iter().filter(|(_, up)| !up).map(|(id, _)| Ended::TokenWithdrawn(id)));
    ended
}

/// Polls until an end is reported; panics after `timeout` (a bound on the
/// wait for IO, not a rule: a process's exit takes what the OS takes).
fn ended_within(source: &mut dyn AgentSource, timeout: Duration) -> Vec<Ended> {
    let deadline = Instant::now() + timeout;
    loop {
        let ended = reported(source);
        if !ended.is_empty() {
            return ended;
        }
        assert!(Instant::now() < deadline, "nothing reported within {timeout:?}");
        // Polled: a source says its ends only when polled (the launch
        // polls it too, `REAP_EVERY`); it has no event to block on.
        std::thread::sleep(Duration::from_millis(5));
    }
}

const WAIT: Duration = Duration::from_secs(5);

/// Runs every check against `fixture`; returns the checks that were not
/// applicable (each test asserts that list).
pub fn run_all(fixture: &dyn AgentFixture) -> Report {
    let mut report = Report::new("agents", fixture.expected().kind);
    properties_are_as_stated(fixture);
    started_agents_run_and_a_silent_one_is_not_reported(fixture);
    a_killed_agent_is_not_reported(fixture);
    an_agent_that_ends_is_reported(fixture, &mut report);
    wind_down_ends_everything_and_names_the_rest(fixture, &mut report);
    dropping_a_source_ends_its_agents(fixture, &mut report);
    unknown_robots_are_ignored(fixture);
    report
}

/// The source's properties say what the fixture states.
fn properties_are_as_stated(fixture: &dyn AgentFixture) {
    let want = fixture.expected();
    let got = fixture.source().properties();
    assert_eq!(got.kind, want.kind, "kind");
    let kind = want.kind;
    assert_eq!(got.all_at_once, want.all_at_once, "{kind}: all_at_once");
    assert_eq!(got.needs_placement, want.needs_placement, "{kind}: needs_placement");
    assert_eq!(got.stop_when_stuck, want.stop_when_stuck, "{kind}: stop_when_stuck");
    assert_eq!(got.wants_poses, want.wants_poses, "{kind}: wants_poses");
    assert_eq!(got.senses_beacons, want.senses_beacons, "{kind}: senses_beacons");
    assert_eq!(got.held_when_unreachable, want.held_when_unreachable, "{kind}: held_when_unreachable");
    assert_eq!(got.robot_link_grace, want.robot_link_grace, "{kind}: robot_link_grace");
    match want.start_hint {
        None => assert_eq!(got.start_hint, "", "{kind}: no start hint"),
        Some(words) => assert!(got.start_hint.contains(words), "{kind}: start_hint {:?}", got.start_hint),
    }
    assert!(got.ended_by.contains(want.ended_by), "{kind}: ended_by {:?}", got.ended_by);
}

/// A started agent runs; one that never registers and stays silent is not
/// reported by its source (the core's registration timer judges it).
fn started_agents_run_and_a_silent_one_is_not_reported(fixture: &dyn AgentFixture) {
    let want = fixture.expected();
    let mut source = fixture.source();
    let started = start(&mut *source, fixture, 1, false);
    assert!(want.starts.is(&started), "{}: started {started:?}, expected {:?}", want.kind, want.starts);
    assert!(source.is_running(1), "running after start");
    match started {
        Started::Process { pid } => assert_eq!(source.pid(1), Some(pid), "pid as started"),
        Started::Awaited | Started::Thread => assert_eq!(source.pid(1), None, "no local process, no pid"),
    }
    start(&mut *source, fixture, 2, false);
    source.heard(1);
    assert_eq!(reported(&mut *source), [], "{}: nothing ended", want.kind);
    assert!(source.is_running(1) && source.is_running(2), "a silent agent is still running");
}

fn a_killed_agent_is_not_reported(fixture: &dyn AgentFixture) {
    let mut source = fixture.source();
    start(&mut *source, fixture, 1, false);
    start(&mut *source, fixture, 2, false);
    assert!(source.kill(1), "killing a running agent");
    assert!(!source.kill(1), "a second kill finds nothing");
    assert!(!source.is_running(1) && source.pid(1).is_none());
    assert!(source.is_running(2), "the other agent is untouched");
    assert_eq!(reported(&mut *source), [], "a kill is not an end to report");
}

fn an_agent_that_ends_is_reported(fixture: &dyn AgentFixture, report: &mut Report) {
    let want = fixture.expected();
    if let EndsByItself::Cannot { why } = want.ends_by_itself {
        report.skip("an_agent_that_ends_is_reported", why);
        return;
    }
    let mut source = fixture.source();
    start(&mut *source, fixture, 4, true);
    let ended = ended_within(&mut *source, WAIT);
    match (want.ends_by_itself, ended.as_slice()) {
        (EndsByItself::Exits { code }, [Ended::Gone(4, Gone::Exited(status))]) => {
            assert_eq!(status.code(), Some(code), "reported with its exit status");
            assert!(!source.is_running(4) && source.pid(4).is_none());
        }
        (EndsByItself::ThreadEnds, [Ended::Gone(4, Gone::ThreadEnded)]) => {
            assert!(!source.is_running(4));
        }
        // A withdrawn token is a fact: the core ends the agent (`kill`).
        (EndsByItself::Disconnects, [Ended::TokenWithdrawn(4)]) => assert!(source.kill(4)),
        (ends, ended) => panic!("{}: an agent that {ends:?} was reported {ended:?}", want.kind),
    }
    assert_eq!(reported(&mut *source), [], "reported exactly once");
}

fn wind_down_ends_everything_and_names_the_rest(fixture: &dyn AgentFixture, report: &mut Report) {
    let want = fixture.expected();
    let mut source = fixture.source();
    start(&mut *source, fixture, 1, false);
    start(&mut *source, fixture, 2, false);
    match want.ends_by_itself {
        EndsByItself::Cannot { why } => report.skip("wind_down_does_not_name_an_agent_that_ended", why),
        _ => {
            start(&mut *source, fixture, 3, true);
        }
    }
    for id in 1..=3 {
        source.heard(id);
    }
    let mut ended = wind_down(&mut *source, &[1, 2, 3], Duration::from_millis(500), &mut |_| {});
    ended.sort_unstable();
    assert_eq!(ended, [1, 2], "the agents that did not end by themselves, and only those");
    for id in 1..=3 {
        assert!(!source.is_running(id), "robot {id} still running after wind_down");
        assert!(source.pid(id).is_none(), "robot {id} has a pid after wind_down");
    }
    assert_eq!(reported(&mut *source), [], "nothing left to report");
    assert_eq!(
        wind_down(&mut *source, &[1, 2, 3], Duration::from_millis(10), &mut |_| {}),
        Vec::<u32>::new(),
        "nothing left to end"
    );
}

/// Dropping a source ends whatever is still running (seen for processes:
/// their pids are gone).
fn dropping_a_source_ends_its_agents(fixture: &dyn AgentFixture, report: &mut Report) {
    let want = fixture.expected();
    let check = "dropping_a_source_ends_its_agents";
    match want.starts {
        Starts::Awaited => return report.skip(check, "nothing is started here"),
        Starts::Thread => {
            return report.skip(check, "an agent thread cannot be seen from outside its source")
        }
        Starts::Process => {}
    }
    let mut source = fixture.source();
    let pids: Vec<u32> = (1..=2)
        .map(|id| match start(&mut *source, fixture, id, false) {
            Started::Process { pid } => pid,
            other => panic!("{}: started {other:?}", want.kind),
        })
        .collect();
    let exists = |pid: u32| std::path::Path::new(&format!("/proc/{pid}")).exists();
    assert!(pids.iter().all(|&pid| exists(pid)), "the agents run: {pids:?}");
    drop(source);
    // Drop kills and reaps: the pids are gone when it returns.
    for pid in pids {
        assert!(!exists(pid), "{}: process {pid} outlived its source", want.kind);
    }
}

fn unknown_robots_are_ignored(fixture: &dyn AgentFixture) {
    let mut source = fixture.source();
    source.heard(99);
    assert!(!source.is_running(99) && source.pid(99).is_none() && !source.kill(99));
    assert_eq!(reported(&mut *source), [], "nothing was started");
    assert_eq!(wind_down(&mut *source, &[99], Duration::from_millis(10), &mut |_| {}), Vec::<u32>::new());
}
