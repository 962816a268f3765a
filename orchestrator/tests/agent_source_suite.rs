//! The agents seam's conformance suite (`suites/agents.rs`) against every
//! [`AgentSource`]: add a fixture and one `#[test]` per implementation.
//!
//! [`AgentSource`]: bycoms_orchestrator::launch::agents::AgentSource

use crate::suites;

use bycoms_orchestrator::launch::agents::gateways::Gateways;
use bycoms_orchestrator::launch::agents::remote::Remote;
use bycoms_orchestrator::launch::agents::spawned::{AgentCommand, Spawned};
use bycoms_orchestrator::launch::agents::AgentSource;
use bycoms_sim::agent_process::{AgentArgs, Clock, Transport};
use bycoms_sim::lab::robots::RobotsFile;
use std::path::PathBuf;
use std::time::Duration;
use suites::agents::{run_all, AgentFixture};

/// Agent arguments of robot `id` (what a launch would pass).
fn args(id: u32) -> AgentArgs {
    AgentArgs {
        swarm: "suite".into(),
        robot: id,
        terrain: PathBuf::from("-"),
        eps: 3.0,
        noise: false,
        seed: 0,
        clock: Clock::Lockstep,
        speed: 1.0,
        swarm_size: Some(4),
        peers: None,
        parent_pid: Some(std::process::id() as i32),
        heartbeat_ms: 100,
        transport: Transport::Ipc,
        connect: Vec::new(),
        zenoh_config: None,
        failsafe: Default::default(),
    }
}

/// Spawned agents: a shell that reads its "terrain" from stdin and exits at
/// once if it says `exit`, else sleeps (alive and silent) until killed. The
/// agent flags follow as the script's positional parameters, ignored.
struct SpawnedFixture;

impl AgentFixture for SpawnedFixture {
    fn source(&self, register_timeout: Duration, heartbeat_timeout: Duration) -> Box<dyn AgentSource> {
        let script = r#"read what; [ "$what" = exit ] && exit 3; exec sleep 30"#;
        let command =
            AgentCommand { program: "sh".into(), prefix: vec!["-c".into(), script.into(), "sh".into()] };
        Box::new(Spawned::new(command, register_timeout, heartbeat_timeout))
    }

    fn plan(&self, id: u32, ends_at_once: bool) -> Option<(AgentArgs, String)> {
        Some((args(id), if ends_at_once { "exit\n" } else { "stay\n" }.into()))
    }
}

#[test]
fn spawned_agents_pass_the_suite() {
    run_all(&SpawnedFixture);
}

/// Remote agents: nothing is started here, so an agent is "silent" until
/// the test says it was heard, and none can be seen ending by itself.
struct RemoteFixture;

impl AgentFixture for RemoteFixture {
    fn source(&self, register_timeout: Duration, heartbeat_timeout: Duration) -> Box<dyn AgentSource> {
        Box::new(Remote::new(register_timeout, heartbeat_timeout, None))
    }

    fn plan(&self, id: u32, ends_at_once: bool) -> Option<(AgentArgs, String)> {
        (!ends_at_once).then(|| (args(id), String::new()))
    }
}

#[test]
fn remote_agents_pass_the_suite() {
    let source = RemoteFixture.source(Duration::from_secs(1), Duration::from_secs(1));
    assert!(source.all_at_once(), "remote agents are awaited all at once");
    run_all(&RemoteFixture);
}

/// Gateways of real robots: a shell stands in for the `agent` executable;
/// it exits at once when its flags carry the marker heartbeat period
/// ([`ENDS`]), else sleeps (alive and silent) until killed. The robots file
/// names four robots with their keys, in a temporary directory.
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
    fn source(&self, register_timeout: Duration, heartbeat_timeout: Duration) -> Box<dyn AgentSource> {
        let script = format!(r#"case " $* " in *" --heartbeat-ms {ENDS} "*) exit 3;; esac; exec sleep 30"#);
        let command = AgentCommand { program: "sh".into(), prefix: vec!["-c".into(), script, "sh".into()] };
        Box::new(Gateways::new(command, self.robots.clone(), register_timeout, heartbeat_timeout))
    }

    fn plan(&self, id: u32, ends_at_once: bool) -> Option<(AgentArgs, String)> {
        let mut a = args(id);
        if ends_at_once {
            a.heartbeat_ms = ENDS;
        }
        Some((a, String::new()))
    }
}

#[test]
fn gateways_pass_the_suite() {
    let fixture = GatewaysFixture::new();
    let source = fixture.source(Duration::from_secs(1), Duration::from_secs(1));
    assert!(source.all_at_once(), "robots exist on their own: every gateway starts at once");
    run_all(&fixture);
}

#[test]
fn gateways_report_a_robot_link_that_stays_lost_and_keep_one_that_heals() {
    use bycoms_orchestrator::launch::agents::gateways::LINK_GRACE;
    use bycoms_orchestrator::launch::agents::{AgentPlan, Gone};
    let fixture = GatewaysFixture::new();
    let mut source = fixture.source(Duration::from_secs(5), Duration::from_secs(5));
    for id in [1, 2] {
        let (a, terrain) = fixture.plan(id, false).expect("a plan");
        source.start(id, &AgentPlan { args: &a, terrain_text: &terrain }).expect("starts");
        source.heard(id);
    }
    source.robot_link(1, false);
    source.robot_link(2, false);
    assert!(source.poll(true).is_empty(), "not before the grace");
    source.robot_link(2, true);
    std::thread::sleep(LINK_GRACE + Duration::from_millis(20));
    // A repeated report while lost keeps the first time.
    source.robot_link(1, false);
    assert_eq!(source.poll(true), [(1, Gone::RobotLinkLost)], "robot 1's link stayed lost");
    assert!(!source.is_running(1) && source.is_running(2), "robot 1's gateway ended, robot 2's kept");
    assert!(source.poll(true).is_empty(), "reported once");
    assert!(source.wind_down(Duration::from_millis(10)).contains(&2));
}
