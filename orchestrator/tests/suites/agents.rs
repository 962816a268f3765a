//! The one conformance suite of the agents seam (`launch::agents`): every
//! [`AgentSource`] passes it. An implementation supplies an
//! [`AgentFixture`] and calls [`run_all`] (see `agent_source_suite.rs`).
//!
//! Why every method is checked against what the fixture states
//! ([`Expected`]): the engine decides from the property methods
//! (`all_at_once`, `needs_placement`, `stop_when_stuck`, `wants_poses`, the
//! words of `start_hint` and `ended_by`), so a property that changes must
//! fail a test, not only a behaviour. What an implementation does not do is
//! stated too, and checked: a source whose agents cannot come back reports
//! nothing from [`AgentSource::reach`], one without robots ignores
//! [`AgentSource::robot_link`] — the suite asserts that nothing is reported,
//! so a source that starts reporting fails as surely as one that stops.
//!
//! A check that cannot apply to an implementation (an agent that ends by
//! itself, where nothing is started here) is named in the returned
//! [`Report`] with the reason, never skipped silently (see `suites/mod.rs`).

use super::Report;
use bycoms_orchestrator::launch::agents::{AgentPlan, AgentSource, Gone, Reach, Started};
use bycoms_sim::sim_agent::AgentArgs;
use std::time::{Duration, Instant};

/// The timeouts a source is made with.
#[derive(Clone, Copy, Debug)]
pub struct Timeouts {
    /// Registration timeout (from `start` to the first `heard`).
    pub register: Duration,
    /// Heartbeat timeout (from the last `heard`).
    pub heartbeat: Duration,
    /// The launch's link grace (`supervision.link_grace`): how long an
    /// unreachable agent is held before it is gone. Sources without one
    /// ignore it.
    pub link_grace: Duration,
}

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
    /// Its link goes (its liveliness token is withdrawn): with no link
    /// grace, [`Gone::Disconnected`].
    Disconnects,
    /// It cannot: the checks that need one are not applicable, for this
    /// reason.
    Cannot {
        /// Why not.
        why: &'static str,
    },
}

/// What [`AgentSource::reach`] reports for this kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reaches {
    /// Nothing, ever: its agents do not come back; a silent agent is gone
    /// at once ([`Gone::Silent`]), whatever the link grace.
    Never,
    /// A silent agent is first [`Reach::Lost`] and held for the link grace,
    /// [`Reach::Back`] when heard again within it, and gone
    /// ([`Gone::Unreachable`]) past it.
    WithinLinkGrace,
}

/// What an implementation is expected to be and do (stated by its fixture,
/// checked by the suite).
#[derive(Clone, Copy, Debug)]
pub struct Expected {
    /// [`AgentSource::kind`].
    pub kind: &'static str,
    /// [`AgentSource::all_at_once`].
    pub all_at_once: bool,
    /// [`AgentSource::needs_placement`].
    pub needs_placement: bool,
    /// [`AgentSource::stop_when_stuck`].
    pub stop_when_stuck: bool,
    /// [`AgentSource::wants_poses`].
    pub wants_poses: bool,
    /// Words [`AgentSource::start_hint`] contains; `None`: it is empty.
    pub start_hint: Option<&'static str>,
    /// Words [`AgentSource::ended_by`] contains.
    pub ended_by: &'static str,
    /// What [`AgentSource::start`] starts.
    pub starts: Starts,
    /// Whether (and how) an agent can be seen ending by itself.
    pub ends_by_itself: EndsByItself,
    /// What [`AgentSource::reach`] reports.
    pub reach: Reaches,
    /// [`AgentSource::robot_link`]: `Some(grace)` when a robot link
    /// reported lost and not restored within `grace` makes the robot gone
    /// ([`Gone::RobotLinkLost`]); `None` when the source ignores it.
    pub robot_link_grace: Option<Duration>,
}

/// How an implementation is put under test.
pub trait AgentFixture {
    /// What the implementation is expected to be and do.
    fn expected(&self) -> Expected;
    /// A fresh source with these timeouts.
    fn source(&self, timeouts: Timeouts) -> Box<dyn AgentSource>;
    /// Arguments and terrain text for robot `id`'s agent: one that stays
    /// alive and silent until ended, or (`ends_by_itself`) one that ends by
    /// itself right after starting. Asked for an ending agent only when
    /// [`Expected::ends_by_itself`] says it can; called after
    /// [`AgentFixture::source`], for the source made last.
    fn plan(&self, id: u32, ends_by_itself: bool) -> (AgentArgs, String);
}

/// Starts robot `id`'s agent (silent, or ending by itself).
fn start(source: &mut dyn AgentSource, fixture: &dyn AgentFixture, id: u32, ends: bool) -> Started {
    let (args, terrain) = fixture.plan(id, ends);
    let plan = AgentPlan { args: &args, terrain_text: &terrain };
    source.start(id, &plan).unwrap_or_else(|e| panic!("starting robot {id}: {e}"))
}

/// Polls (`force` or not) until something is reported; panics after `timeout`.
fn poll_until(source: &mut dyn AgentSource, force: bool, timeout: Duration) -> Vec<(u32, Gone)> {
    let deadline = Instant::now() + timeout;
    loop {
        let gone = source.poll(force);
        if !gone.is_empty() {
            return gone;
        }
        assert!(Instant::now() < deadline, "nothing reported within {timeout:?}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Polls for `span` and collects everything reported (to show that nothing
/// is: a span is the only way to see an absence).
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
/// How long a source that ignores robot links is watched for reporting one
/// (over twice the longest robot-link grace of any source).
const IGNORED_FOR: Duration = Duration::from_millis(400);

fn timeouts(register: Duration, heartbeat: Duration) -> Timeouts {
    Timeouts { register, heartbeat, link_grace: Duration::ZERO }
}

/// Runs every check against `fixture`; returns the checks that were not
/// applicable (each test asserts that list).
pub fn run_all(fixture: &dyn AgentFixture) -> Report {
    let mut report = Report::new("agents", fixture.expected().kind);
    properties_are_as_stated(fixture);
    started_agents_run_and_nothing_is_lost(fixture);
    an_agent_that_never_registers_is_reported_once(fixture);
    an_agent_that_falls_silent_is_reported_once(fixture);
    a_killed_agent_is_not_reported(fixture);
    an_agent_that_ends_is_reported(fixture, &mut report);
    wind_down_ends_everything_and_names_the_rest(fixture, &mut report);
    reach_reports_an_unreachable_agent_and_its_return(fixture);
    a_robot_link_that_stays_lost_is_reported_once(fixture);
    dropping_a_source_ends_its_agents(fixture, &mut report);
    unknown_robots_are_ignored(fixture);
    report
}

/// The property methods say what the fixture states.
fn properties_are_as_stated(fixture: &dyn AgentFixture) {
    let want = fixture.expected();
    let source = fixture.source(timeouts(LONG, LONG));
    assert_eq!(source.kind(), want.kind, "kind");
    let kind = want.kind;
    assert_eq!(source.all_at_once(), want.all_at_once, "{kind}: all_at_once");
    assert_eq!(source.needs_placement(), want.needs_placement, "{kind}: needs_placement");
    assert_eq!(source.stop_when_stuck(), want.stop_when_stuck, "{kind}: stop_when_stuck");
    assert_eq!(source.wants_poses(), want.wants_poses, "{kind}: wants_poses");
    match want.start_hint {
        None => assert_eq!(source.start_hint(), "", "{kind}: no start hint"),
        Some(words) => {
            assert!(source.start_hint().contains(words), "{kind}: start_hint {:?}", source.start_hint());
        }
    }
    assert!(source.ended_by().contains(want.ended_by), "{kind}: ended_by {:?}", source.ended_by());
}

fn started_agents_run_and_nothing_is_lost(fixture: &dyn AgentFixture) {
    let want = fixture.expected();
    let mut source = fixture.source(timeouts(LONG, LONG));
    let started = start(&mut *source, fixture, 1, false);
    assert!(want.starts.is(&started), "{}: started {started:?}, expected {:?}", want.kind, want.starts);
    assert!(source.is_running(1), "running after start");
    match started {
        Started::Process { pid } => assert_eq!(source.pid(1), Some(pid), "pid as started"),
        Started::Awaited | Started::Thread => assert_eq!(source.pid(1), None, "no local process, no pid"),
    }
    source.heard(1);
    assert_eq!(source.poll(false), [], "an unforced poll loses nothing either");
    assert_eq!(poll_for(&mut *source, Duration::from_millis(100)), [], "nothing lost");
    assert!(source.is_running(1));
    assert_eq!(source.reach(), [], "an agent heard from was never unreachable");
}

fn an_agent_that_never_registers_is_reported_once(fixture: &dyn AgentFixture) {
    let mut source = fixture.source(timeouts(SHORT, LONG));
    start(&mut *source, fixture, 2, false);
    let gone = poll_until(&mut *source, true, WAIT);
    assert_eq!(gone, [(2, Gone::NeverRegistered)], "the silent agent is reported as never registered");
    assert!(!source.is_running(2), "a reported agent is no longer running");
    assert_eq!(poll_for(&mut *source, Duration::from_millis(300)), [], "reported exactly once");
}

fn an_agent_that_falls_silent_is_reported_once(fixture: &dyn AgentFixture) {
    let mut source = fixture.source(timeouts(LONG, SHORT));
    start(&mut *source, fixture, 3, false);
    // Heard often enough, it is never lost.
    let until = Instant::now() + Duration::from_millis(400);
    while Instant::now() < until {
        source.heard(3);
        assert_eq!(source.poll(true), [], "an agent heard from is alive");
        std::thread::sleep(Duration::from_millis(10));
    }
    let gone = poll_until(&mut *source, true, WAIT);
    assert_eq!(gone, [(3, Gone::Silent)], "silence after being heard is reported");
    assert!(!source.is_running(3));
    assert_eq!(poll_for(&mut *source, Duration::from_millis(300)), [], "reported exactly once");
}

fn a_killed_agent_is_not_reported(fixture: &dyn AgentFixture) {
    let mut source = fixture.source(timeouts(LONG, LONG));
    start(&mut *source, fixture, 1, false);
    start(&mut *source, fixture, 2, false);
    assert!(source.kill(1), "killing a running agent");
    assert!(!source.kill(1), "a second kill finds nothing");
    assert!(!source.is_running(1) && source.pid(1).is_none());
    assert!(source.is_running(2), "the other agent is untouched");
    assert_eq!(poll_for(&mut *source, Duration::from_millis(200)), [], "a kill is not a loss to report");
}

fn an_agent_that_ends_is_reported(fixture: &dyn AgentFixture, report: &mut Report) {
    let want = fixture.expected();
    if let EndsByItself::Cannot { why } = want.ends_by_itself {
        report.skip("an_agent_that_ends_is_reported", why);
        return;
    }
    let mut source = fixture.source(timeouts(LONG, LONG));
    start(&mut *source, fixture, 4, true);
    // Unforced: a source still sweeps every few milliseconds.
    let gone = poll_until(&mut *source, false, WAIT);
    match (want.ends_by_itself, gone.as_slice()) {
        (EndsByItself::Exits { code }, [(4, Gone::Exited(status))]) => {
            assert_eq!(status.code(), Some(code), "reported with its exit status");
        }
        (EndsByItself::ThreadEnds, [(4, Gone::ThreadEnded)]) => {}
        (EndsByItself::Disconnects, [(4, Gone::Disconnected)]) => {}
        (ends, gone) => panic!("{}: an agent that {ends:?} was reported {gone:?}", want.kind),
    }
    assert!(!source.is_running(4) && source.pid(4).is_none());
    assert_eq!(poll_for(&mut *source, Duration::from_millis(200)), [], "reported exactly once");
}

fn wind_down_ends_everything_and_names_the_rest(fixture: &dyn AgentFixture, report: &mut Report) {
    let want = fixture.expected();
    let mut source = fixture.source(timeouts(LONG, LONG));
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
    let grace = Duration::from_millis(500);
    let t0 = Instant::now();
    let mut ended = source.wind_down(grace);
    ended.sort_unstable();
    assert!(t0.elapsed() < grace + Duration::from_secs(3), "wind_down keeps to its grace");
    assert_eq!(ended, [1, 2], "the agents that did not end by themselves, and only those");
    for id in 1..=3 {
        assert!(!source.is_running(id), "robot {id} still running after wind_down");
        assert!(source.pid(id).is_none(), "robot {id} has a pid after wind_down");
    }
    assert_eq!(source.poll(true), [], "nothing left to report");
    assert_eq!(source.wind_down(Duration::from_millis(10)), Vec::<u32>::new(), "nothing left to end");
}

/// `reach`: with a link grace, a silent agent of a source whose agents can
/// come back is unreachable (once), held, and back when heard; past the
/// grace it is gone. Any other source reports nothing, and its silent agent
/// is gone at once whatever the grace.
fn reach_reports_an_unreachable_agent_and_its_return(fixture: &dyn AgentFixture) {
    let want = fixture.expected();
    let kind = want.kind;
    let held = Timeouts { register: LONG, heartbeat: SHORT, link_grace: LONG };
    let mut source = fixture.source(held);
    start(&mut *source, fixture, 1, false);
    source.heard(1);
    assert_eq!(source.reach(), [], "{kind}: nothing unreachable yet");
    let deadline = Instant::now() + WAIT;
    match want.reach {
        Reaches::WithinLinkGrace => {
            let lost = loop {
                assert_eq!(source.poll(true), [], "{kind}: held within its link grace, not gone");
                let changes = source.reach();
                if !changes.is_empty() {
                    break changes;
                }
                assert!(Instant::now() < deadline, "{kind}: the silent agent never became unreachable");
                std::thread::sleep(Duration::from_millis(5));
            };
            assert_eq!(lost, [(1, Reach::Lost)], "{kind}: the silent agent is unreachable");
            assert_eq!(source.reach(), [], "{kind}: reported unreachable once");
            assert_eq!(poll_for(&mut *source, Duration::from_millis(50)), [], "{kind}: still held");
            assert!(source.is_running(1), "{kind}: an unreachable agent is still the launch's");
            source.heard(1);
            assert_eq!(source.reach(), [(1, Reach::Back)], "{kind}: heard again within the grace");
            source.heard(1);
            assert_eq!(source.reach(), [], "{kind}: back once");

            // Past a short grace it is gone, and no longer comes back.
            let mut source = fixture.source(Timeouts { link_grace: SHORT, ..held });
            start(&mut *source, fixture, 2, false);
            source.heard(2);
            let gone = poll_until(&mut *source, true, WAIT);
            let grace_ms = SHORT.as_millis() as u64;
            assert_eq!(gone, [(2, Gone::Unreachable { grace_ms })], "{kind}: unreachable past the grace");
            assert_eq!(source.reach(), [(2, Reach::Lost)], "{kind}: unreachable first");
            assert!(!source.is_running(2));
            source.heard(2);
            assert_eq!(source.reach(), [], "{kind}: a gone agent is not back");
            assert_eq!(poll_for(&mut *source, Duration::from_millis(200)), [], "{kind}: gone once");
        }
        Reaches::Never => {
            let gone = loop {
                let gone = source.poll(true);
                assert_eq!(source.reach(), [], "{kind}: reports no reachability");
                if !gone.is_empty() {
                    break gone;
                }
                assert!(Instant::now() < deadline, "{kind}: the silent agent was never reported");
                std::thread::sleep(Duration::from_millis(5));
            };
            assert_eq!(gone, [(1, Gone::Silent)], "{kind}: no link grace here: silence is a loss at once");
            source.heard(1);
            assert_eq!(source.reach(), [], "{kind}: reports no reachability");
        }
    }
}

/// `robot_link`: a source of real robots reports a robot whose link stays
/// lost for its grace gone, once, and keeps one whose link came back; every
/// other source ignores robot links.
fn a_robot_link_that_stays_lost_is_reported_once(fixture: &dyn AgentFixture) {
    let want = fixture.expected();
    let kind = want.kind;
    let mut source = fixture.source(timeouts(LONG, LONG));
    for id in 1..=3 {
        start(&mut *source, fixture, id, false);
        source.heard(id);
    }
    let t0 = Instant::now();
    for id in [1, 2, 3, 99] {
        source.robot_link(id, false);
    }
    assert_eq!(source.poll(true), [], "{kind}: not at once");
    source.robot_link(2, true); // healed within any grace
    assert!(source.kill(3), "{kind}: robot 3 ended by the engine");
    match want.robot_link_grace {
        Some(grace) => {
            // The lost report is repeated while waiting (a gateway repeats
            // it): a repeat keeps the first time, or this never ends.
            let deadline = t0 + WAIT;
            let gone = loop {
                source.robot_link(1, false);
                let gone = source.poll(true);
                if !gone.is_empty() {
                    break gone;
                }
                assert!(
                    Instant::now() < deadline,
                    "{kind}: robot 1's lost link not reported within {WAIT:?}"
                );
                std::thread::sleep(Duration::from_millis(5));
            };
            assert!(t0.elapsed() >= grace, "{kind}: reported after {:?}, before the grace", t0.elapsed());
            assert_eq!(gone, [(1, Gone::RobotLinkLost)], "{kind}: robot 1's link stayed lost");
            assert!(!source.is_running(1), "{kind}: robot 1's agent ended");
            assert!(source.is_running(2), "{kind}: robot 2's link came back within the grace: it stays");
            source.robot_link(1, false); // of a robot no longer running: ignored
            let later = poll_for(&mut *source, grace + Duration::from_millis(100));
            assert_eq!(later, [], "{kind}: reported once; the healed and the killed robots never");
        }
        None => {
            let deadline = t0 + IGNORED_FOR;
            while Instant::now() < deadline {
                source.robot_link(1, false);
                assert_eq!(source.poll(true), [], "{kind}: robot links are ignored");
                std::thread::sleep(Duration::from_millis(5));
            }
            assert!(source.is_running(1) && source.is_running(2), "{kind}: robot links are ignored");
        }
    }
    assert_eq!(source.reach(), [], "{kind}: a robot's link is not the agent's reachability");
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
    let mut source = fixture.source(timeouts(LONG, LONG));
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
    let mut source = fixture.source(timeouts(SHORT, SHORT));
    source.heard(99);
    source.robot_link(99, false);
    assert!(!source.is_running(99) && source.pid(99).is_none() && !source.kill(99));
    assert_eq!(poll_for(&mut *source, Duration::from_millis(300)), [], "nothing was started");
    assert_eq!(source.reach(), [], "nothing was started");
    assert_eq!(source.wind_down(Duration::from_millis(10)), Vec::<u32>::new());
}
