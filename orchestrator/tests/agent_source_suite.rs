//! The agents seam's conformance suite (`suites/agents.rs`) against every
//! [`AgentSource`]: add a fixture and one `#[test]` per implementation.
//!
//! Each fixture states what its implementation is and does
//! ([`Expected`]: its properties, whether its agents can end by themselves
//! as far as it sees), and each test
//! asserts which of the suite's checks were not applicable to it (none are
//! skipped silently).
//!
//! [`AgentSource`]: bycoms_launch::agents::AgentSource

use crate::suites;

use bycoms_lab::robots::RobotsFile;
use bycoms_launch::agents::gateways::{Gateways, LINK_GRACE};
use bycoms_launch::agents::mixed::Mixed;
use bycoms_launch::agents::remote::Remote;
use bycoms_launch::agents::ros2_robots::{Graph, Ros2Robots};
use bycoms_launch::agents::spawned::{AgentCommand, Spawned};
use bycoms_launch::agents::threads::Threads;
use bycoms_launch::agents::{AgentError, AgentPlan, AgentSource, Joining};
use bycoms_protocol::bus::memory::MemoryBus;
use bycoms_protocol::bus::zenoh::{AliveToken, AliveWatch, Mode, Presence, ZenohBus, ZenohConfig};
use bycoms_protocol::bus::{BusExt, Limits};
use bycoms_protocol::msg::{FromAgent, ToAgent};
use bycoms_protocol::naming::Member;
use bycoms_protocol::{RobotId, Swarm};
use bycoms_runtime::{BusArgs, Transport};
use bycoms_sim_agent::{Clock, RunSettings};
use std::cell::{Cell, RefCell};
use std::time::{Duration, Instant};
use suites::agents::{run_all, AgentFixture, EndsByItself, Expected, Starts};

/// How the suite's agents join: swarm `suite`, over iceoryx2.
fn joining() -> Joining {
    Joining {
        swarm: "suite".into(),
        parent_pid: Some(std::process::id() as i32),
        bus: BusArgs { transport: Transport::Ipc, connect: Vec::new(), zenoh_config: None },
        failsafe: Default::default(),
        parked_heartbeat_ms: 100,
    }
}

/// The suite's run settings (ε 3, lockstep, four robots) with `terrain`.
fn settings(terrain: &str) -> RunSettings {
    RunSettings {
        terrain: terrain.into(),
        eps: 3.0,
        noise: false,
        seed: 0,
        clock: Clock::Lockstep,
        speed: 1.0,
        swarm_size: 4,
        heartbeat_ms: 100,
        cell: 1.0,
        robot_speed: 1.0,
    }
}

/// Spawned agents: a shell that reads its "terrain" from stdin and exits
/// (code 3) at once if it says `exit`, else sleeps (alive and silent) until
/// killed. The agent flags follow as the script's positional parameters,
/// ignored.
struct SpawnedFixture;

impl AgentFixture for SpawnedFixture {
    fn expected(&self) -> Expected {
        Expected {
            kind: "spawned",
            all_at_once: false,
            needs_placement: false,
            stop_when_stuck: false,
            wants_poses: false,
            senses_beacons: true,
            start_hint: None,
            ended_by: "killed",
            starts: Starts::Process,
            ends_by_itself: EndsByItself::Exits { code: 3 },
            held_when_unreachable: false,
            robot_link_grace: None,
        }
    }

    fn source(&self) -> Box<dyn AgentSource> {
        let script = r#"read what; [ "$what" = exit ] && exit 3; exec sleep 30"#;
        let command = AgentCommand {
            program: "sh".into(),
            prefix: vec!["-c".into(), script.into(), "sh".into()],
            own: false,
        };
        Box::new(Spawned::new(command))
    }

    fn plan(&self, _id: u32, ends_by_itself: bool) -> (Joining, RunSettings) {
        (joining(), settings(if ends_by_itself { "exit\n" } else { "stay\n" }))
    }
}

#[test]
fn spawned_agents_pass_the_suite() {
    let report = run_all(&SpawnedFixture);
    assert_eq!(report.not_applicable(), Vec::<&str>::new(), "{report:?}");
}

/// Remote agents without liveliness (no zenoh here): nothing is started,
/// so an agent is "silent" until the test says it was heard. The source
/// learns of an agent's end only from its liveliness token (none here) or
/// its silence, so none can be seen ending by itself.
struct RemoteFixture;

impl AgentFixture for RemoteFixture {
    fn expected(&self) -> Expected {
        Expected {
            kind: "remote",
            all_at_once: true,
            needs_placement: false,
            stop_when_stuck: false,
            wants_poses: false,
            senses_beacons: true,
            start_hint: Some("sim-agent --transport zenoh --connect"),
            ended_by: "dropped from the launch",
            starts: Starts::Awaited,
            ends_by_itself: EndsByItself::Cannot {
                why: "remote agents are not started here: without their liveliness tokens their end \
                      shows only as silence (the core's timers judge it)",
            },
            held_when_unreachable: true,
            robot_link_grace: None,
        }
    }

    fn source(&self) -> Box<dyn AgentSource> {
        Box::new(Remote::new(None))
    }

    fn plan(&self, _id: u32, ends_by_itself: bool) -> (Joining, RunSettings) {
        assert!(!ends_by_itself, "the suite asked a remote agent to end by itself");
        (joining(), settings(""))
    }
}

#[test]
fn remote_agents_pass_the_suite() {
    let report = run_all(&RemoteFixture);
    assert_eq!(
        report.not_applicable(),
        [
            "an_agent_that_ends_is_reported",
            "wind_down_does_not_name_an_agent_that_ended",
            "dropping_a_source_ends_its_agents"
        ],
        "{report:?}"
    );
}

/// Remote agents with liveliness, as a launch over zenoh has them: the
/// source watches the swarm's tokens on a router session (the
/// orchestrator's), and each agent is a token declared by a peer session
/// connected to it over loopback tcp (the agent's process). An agent that
/// ends by itself is one whose token is withdrawn; the fixture returns
/// from `plan` once the router has seen the token come (and, for an ending
/// agent, go), watching it on a probe of its own. Each source gets a swarm
/// of its own, so no token of an earlier check is seen by a later one.
struct RemoteLivelinessFixture {
    router: ZenohBus,
    peer: ZenohBus,
    /// How many sources were made (their swarms are numbered).
    sources: Cell<u32>,
    /// The swarm of the source made last, and the fixture's own watch on it.
    current: RefCell<Option<(Swarm, AliveWatch)>>,
    /// The tokens of the agents that stay.
    tokens: RefCell<Vec<AliveToken>>,
}

impl RemoteLivelinessFixture {
    fn new() -> Self {
        // zenoh's default lease (10 s): no token goes unless withdrawn,
        // however busy the machine.
        let config = |endpoint: &str| ZenohConfig {
            mode: Mode::Router,
            listen: vec![endpoint.to_owned()],
            ..Default::default()
        };
        let (router, endpoint) = ZenohBus::loopback_router(config).expect("a router on a free loopback port");
        let peer = ZenohConfig { mode: Mode::Peer, connect: vec![endpoint], ..Default::default() };
        let peer = ZenohBus::open(peer).expect("peer session");
        Self {
            router,
            peer,
            sources: Cell::new(0),
            current: RefCell::new(None),
            tokens: RefCell::new(Vec::new()),
        }
    }
}

/// Waits (on the fixture's probe) until robot `id`'s token is `presence`.
fn await_token(watch: &AliveWatch, id: u32, presence: Presence) {
    let (seen, other) = watch.wait_for(Member::Agent(RobotId(id)), presence, Duration::from_secs(10));
    assert!(seen.is_some(), "robot {id}'s token never {presence:?} within 10 s; saw {other:?}");
}

impl AgentFixture for RemoteLivelinessFixture {
    fn expected(&self) -> Expected {
        Expected { ends_by_itself: EndsByItself::Disconnects, ..RemoteFixture.expected() }
    }

    fn source(&self) -> Box<dyn AgentSource> {
        self.tokens.borrow_mut().clear();
        let n = self.sources.get() + 1;
        self.sources.set(n);
        let swarm = Swarm::new(&format!("suite-{}-{n}", std::process::id())).expect("swarm");
        let probe = self.router.watch_alive(&swarm).expect("probe");
        let watch = self.router.watch_alive(&swarm).expect("watch");
        *self.current.borrow_mut() = Some((swarm, probe));
        Box::new(Remote::new(Some(watch)))
    }

    fn plan(&self, id: u32, ends_by_itself: bool) -> (Joining, RunSettings) {
        let current = self.current.borrow();
        let (swarm, probe) = current.as_ref().expect("a source was made");
        let token = self.peer.declare_alive(swarm, Member::Agent(RobotId(id))).expect("token");
        await_token(probe, id, Presence::Alive);
        if ends_by_itself {
            drop(token);
            await_token(probe, id, Presence::Lost);
        } else {
            self.tokens.borrow_mut().push(token);
        }
        (Joining { swarm: swarm.as_str().into(), ..joining() }, settings(""))
    }
}

#[test]
fn remote_agents_with_liveliness_pass_the_suite() {
    let report = run_all(&RemoteLivelinessFixture::new());
    assert_eq!(report.not_applicable(), ["dropping_a_source_ends_its_agents"], "{report:?}");
}

/// Gateways of real robots: a shell stands in for the `gateway` executable;
/// it exits (code 3) at once when its flags carry the marker heartbeat
/// period ([`ENDS`]), else sleeps (alive and silent) until killed. The
/// robots file names four robots with their keys, in a temporary directory.
struct GatewaysFixture {
    robots: RobotsFile,
    _dir: tempfile::TempDir,
}

/// The heartbeat period that makes the stand-in gateway end at once.
const ENDS: u64 = 7;

impl GatewaysFixture {
    fn new() -> Self {
        let dir = tempfile::tempdir().expect("temp dir");
        let mut text = String::new();
        for id in 1..=4u32 {
            let key = format!("{id}").repeat(64);
            std::fs::write(dir.path().join(format!("robot-{id}.key")), key).expect("key file");
            text += &format!(
                "[[robot]]\nid = {id}\naddress = \"127.0.0.1:{}\"\ngateway = \"127.0.0.1:{}\"\nkey_file = \"robot-{id}.key\"\n",
                47100 + id,
                47000 + id
            );
        }
        let path = dir.path().join("robots.toml");
        std::fs::write(&path, text).expect("robots file");
        let robots = RobotsFile::read(&path).expect("robots file reads");
        Self { robots, _dir: dir }
    }
}

impl AgentFixture for GatewaysFixture {
    fn expected(&self) -> Expected {
        Expected {
            kind: "gateway",
            all_at_once: true,
            needs_placement: true,
            stop_when_stuck: true,
            wants_poses: true,
            senses_beacons: false,
            start_hint: None,
            ended_by: "killed",
            starts: Starts::Process,
            ends_by_itself: EndsByItself::Exits { code: 3 },
            held_when_unreachable: false,
            robot_link_grace: Some(LINK_GRACE),
        }
    }

    fn source(&self) -> Box<dyn AgentSource> {
        let script = format!(r#"case " $* " in *" --heartbeat-ms {ENDS} "*) exit 3;; esac; exec sleep 30"#);
        let command =
            AgentCommand { program: "sh".into(), prefix: vec!["-c".into(), script, "sh".into()], own: false };
        Box::new(Gateways::new(command, self.robots.clone()))
    }

    fn plan(&self, _id: u32, ends_by_itself: bool) -> (Joining, RunSettings) {
        let mut run = settings("");
        if ends_by_itself {
            run.heartbeat_ms = ENDS;
        }
        (joining(), run)
    }
}

#[test]
fn gateways_pass_the_suite() {
    let report = run_all(&GatewaysFixture::new());
    assert_eq!(report.not_applicable(), Vec::<&str>::new(), "{report:?}");
}

/// ROS 2 robots' agents: the same stand-in as the gateways' for the
/// `ros2-robot` executable; the robots file names four ROS 2 robots.
struct Ros2RobotsFixture {
    robots: RobotsFile,
    _dir: tempfile::TempDir,
}

impl Ros2RobotsFixture {
    fn new() -> Self {
        let dir = tempfile::tempdir().expect("temp dir");
        let text: String = (1..=4u32).map(|id| format!("[[robot]]\nid = {id}\nkind = \"ros2\"\n")).collect();
        let path = dir.path().join("robots.toml");
        std::fs::write(&path, text).expect("robots file");
        let robots = RobotsFile::read(&path).expect("robots file reads");
        Self { robots, _dir: dir }
    }
}

impl AgentFixture for Ros2RobotsFixture {
    fn expected(&self) -> Expected {
        Expected {
            kind: "ros2_robot",
            senses_beacons: true,
            robot_link_grace: None,
            ..GatewaysFixture::new().expected()
        }
    }

    fn source(&self) -> Box<dyn AgentSource> {
        let script = format!(r#"case " $* " in *" --heartbeat-ms {ENDS} "*) exit 3;; esac; exec sleep 30"#);
        let command =
            AgentCommand { program: "sh".into(), prefix: vec!["-c".into(), script, "sh".into()], own: false };
        let graph = Graph { router: "tcp/127.0.0.1:7447".into(), domain_id: 0, namespace: "/".into() };
        Box::new(Ros2Robots::new(command, &self.robots, graph))
    }

    fn plan(&self, id: u32, ends_by_itself: bool) -> (Joining, RunSettings) {
        GatewaysFixture::new().plan(id, ends_by_itself)
    }
}

#[test]
fn ros2_robots_pass_the_suite() {
    let report = run_all(&Ros2RobotsFixture::new());
    assert_eq!(report.not_applicable(), Vec::<&str>::new(), "{report:?}");
}

/// A mixed swarm's agents: robots 2 and 4 simulated (`sim-agent`s), 1 and
/// 3 ROS 2 robots, one stand-in for both executables (the gateways'); what
/// the source says of its agents is the real robots', with the simulated
/// ones named.
struct MixedFixture {
    robots: RobotsFile,
    _dir: tempfile::TempDir,
}

impl MixedFixture {
    fn new() -> Self {
        let dir = tempfile::tempdir().expect("temp dir");
        let kind = |id: u32| if id.is_multiple_of(2) { "sim" } else { "ros2" };
        let text: String =
            (1..=4u32).map(|id| format!("[[robot]]\nid = {id}\nkind = \"{}\"\n", kind(id))).collect();
        let path = dir.path().join("robots.toml");
        std::fs::write(&path, text).expect("robots file");
        let robots = RobotsFile::read(&path).expect("robots file reads");
        Self { robots, _dir: dir }
    }
}

impl AgentFixture for MixedFixture {
    fn expected(&self) -> Expected {
        Expected { kind: "mixed", ..Ros2RobotsFixture::new().expected() }
    }

    fn source(&self) -> Box<dyn AgentSource> {
        let script = format!(r#"case " $* " in *" --heartbeat-ms {ENDS} "*) exit 3;; esac; exec sleep 30"#);
        let command =
            AgentCommand { program: "sh".into(), prefix: vec!["-c".into(), script, "sh".into()], own: false };
        let graph = Graph { router: "tcp/127.0.0.1:7447".into(), domain_id: 0, namespace: "/".into() };
        let real = Ros2Robots::new(command.clone(), &self.robots, graph);
        Box::new(Mixed::new(command, self.robots.sim.clone(), Box::new(real)))
    }

    fn plan(&self, id: u32, ends_by_itself: bool) -> (Joining, RunSettings) {
        GatewaysFixture::new().plan(id, ends_by_itself)
    }
}

#[test]
fn mixed_agents_pass_the_suite() {
    let report = run_all(&MixedFixture::new());
    assert_eq!(report.not_applicable(), Vec::<&str>::new(), "{report:?}");
}

/// The simulated members are named in the properties (the core places
/// and forwards poses to the others only).
#[test]
fn mixed_agents_name_their_simulated_members() {
    let fixture = MixedFixture::new();
    assert_eq!(fixture.source().properties().simulated, [2, 4]);
}

#[test]
fn ros2_robots_are_started_with_their_robots_file_entry_and_the_graph() {
    let fixture = Ros2RobotsFixture::new();
    let graph = Graph { router: "tcp/127.0.0.1:7447".into(), domain_id: 7, namespace: "/lab".into() };
    let command = AgentCommand { program: "true".into(), prefix: Vec::new(), own: false };
    let source = Ros2Robots::new(command, &fixture.robots, graph);
    let (joining, settings) = fixture.plan(2, false);
    let args = source.args(2, &AgentPlan { joining: &joining, settings: &settings }).expect("robot 2");
    assert_eq!((args.robot, args.domain_id, args.namespace.as_str()), (2, 7, "/lab"));
    assert_eq!(args.cmd_vel_topic(), "/lab/robot_2/cmd_vel");
    assert_eq!(args.eps, settings.eps, "ε of the run");
    assert_eq!(args.validate(), Ok(()));
    let refused = source.args(9, &AgentPlan { joining: &joining, settings: &settings });
    assert!(matches!(refused, Err(AgentError::NoSuchRobot { robot: 9, .. })), "{refused:?}");
}

#[test]
fn gateways_refuse_a_robot_the_robots_file_does_not_name() {
    let fixture = GatewaysFixture::new();
    let mut source = fixture.source();
    let (joining, settings) = fixture.plan(9, false);
    let refused = source.start(9, &AgentPlan { joining: &joining, settings: &settings });
    assert!(matches!(refused, Err(AgentError::NoSuchRobot { robot: 9, .. })), "{refused:?}");
    assert!(!source.is_running(9), "nothing started");
}

/// Agents as threads over an in-memory bus (a fresh one per source): each
/// runs the real agent loop, registers and heartbeats on the bus — which
/// the source never reads (the engine does, and tells it with `heard`), so
/// to the source an agent is silent until the test says it was heard. An
/// agent that ends by itself is one told `Shutdown` by a stand-in for the
/// orchestrator as soon as it registered (the agent's loop then returns).
struct ThreadsFixture {
    /// The bus of the source made last.
    bus: RefCell<Option<MemoryBus>>,
    /// The stand-ins, each ending once it sent its `Shutdown` (or after
    /// [`STAND_IN_FOR`]).
    stand_ins: RefCell<Vec<std::thread::JoinHandle<()>>>,
}

/// Longest a stand-in waits for its agent's registration.
const STAND_IN_FOR: Duration = Duration::from_secs(10);

impl ThreadsFixture {
    fn new() -> Self {
        Self { bus: RefCell::new(None), stand_ins: RefCell::new(Vec::new()) }
    }

    /// Sends robot `id` `Shutdown` on `bus` once it registered.
    fn shut_down_when_registered(&self, bus: &MemoryBus, id: u32) {
        let swarm = Swarm::new("suite").expect("swarm");
        // Subscribed before the agent starts, so its registration is seen.
        let reports = bus.typed_subscriber(&swarm.from_agent(RobotId(id))).expect("reports");
        let commands = bus.typed_publisher(&swarm.to_agent(RobotId(id))).expect("commands");
        let stand_in = std::thread::spawn(move || {
            let deadline = Instant::now() + STAND_IN_FOR;
            while Instant::now() < deadline {
                if let Ok(Some(FromAgent::Register(r))) = reports.recv_timeout(Duration::from_millis(20)) {
                    if r.robot == RobotId(id) {
                        commands.publish(&ToAgent::Shutdown).expect("shutdown");
                        return;
                    }
                }
            }
        });
        self.stand_ins.borrow_mut().push(stand_in);
    }
}

impl Drop for ThreadsFixture {
    fn drop(&mut self) {
        for stand_in in self.stand_ins.take() {
            let _ = stand_in.join();
        }
    }
}

impl AgentFixture for ThreadsFixture {
    fn expected(&self) -> Expected {
        Expected {
            kind: "threads",
            all_at_once: false,
            needs_placement: false,
            stop_when_stuck: false,
            wants_poses: false,
            senses_beacons: true,
            start_hint: None,
            ended_by: "threads told to stop",
            starts: Starts::Thread,
            ends_by_itself: EndsByItself::ThreadEnds,
            held_when_unreachable: false,
            robot_link_grace: None,
        }
    }

    fn source(&self) -> Box<dyn AgentSource> {
        let bus = MemoryBus::new(Limits::default()).expect("memory bus");
        *self.bus.borrow_mut() = Some(bus.clone());
        Box::new(Threads::new(bus))
    }

    fn plan(&self, id: u32, ends_by_itself: bool) -> (Joining, RunSettings) {
        if ends_by_itself {
            let bus = self.bus.borrow().clone().expect("a source was made");
            self.shut_down_when_registered(&bus, id);
        }
        let terrain = bycoms_sim::terrain::to_text(&bycoms_sim::terrain::Terrain::paper());
        let mut joining = Joining { parent_pid: None, ..joining() };
        joining.bus.transport = Transport::Memory;
        (joining, settings(&terrain))
    }
}

#[test]
fn agent_threads_pass_the_suite() {
    let report = run_all(&ThreadsFixture::new());
    assert_eq!(report.not_applicable(), ["dropping_a_source_ends_its_agents"], "{report:?}");
}
