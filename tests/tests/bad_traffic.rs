//! Bad traffic is counted and logged, never fatal: while a launch runs, this
//! test publishes garbage bytes, a message of another protocol version, a
//! report from an unknown robot, a registration of robot 2 on robot 1's
//! report topic (forged: a message's robot must be its topic's) and a
//! duplicate registration to the orchestrator, and garbage and a foreign
//! command to robot 1's agent. The
//! launch must still finish with the same result as without the noise, and
//! report what it saw.

use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::bus::{Bus, Publish};
use bycoms_protocol::msg::{Deploy, FromAgent, GoalBearing, Heartbeat, Register, RobotKind, ToAgent};
use bycoms_protocol::{encode_vec, RobotId, Swarm, PROTOCOL_VERSION};
use bycoms_runtime::ipc_config;
use bycoms_tests::{swarm_name, wait_for_pose, Proc};
use std::time::Duration;

#[test]
fn garbage_wrong_versions_unknown_robots_and_duplicates_are_counted_not_fatal() {
    let name = swarm_name("junk");
    let swarm = Swarm::new(&name).expect("swarm name");
    // Real time at 10×: robot 1 registers at once and the run lasts seconds.
    let launch = Proc::orchestrator(&[
        "launch", "--clock", "realtime", "--speed", "10", "--dwell", "3", "--swarm", &name, "--json",
    ]);
    // Robot 1 moving: its agent has registered and subscribed.
    wait_for_pose(&name, 3, 1, Duration::from_secs(30), |p| p.x > 16.0).expect("robot 1 moves");

    // The same service sizes as the launch (3 robots), or the topics would not open.
    let bus = IpcBus::new(ipc_config(3)).expect("bus");
    let report = bus.publisher(swarm.from_agent(RobotId(1)).name()).expect("report publisher");
    let command = bus.publisher(swarm.to_agent(RobotId(1)).name()).expect("command publisher");
    let register = FromAgent::Register(Register {
        robot: RobotId(1),
        kind: RobotKind::Simulated,
        protocol_version: PROTOCOL_VERSION,
        // Not robot 1's agent (whose instance is random): a second agent.
        instance: 0,
        settings: 0,
        failsafe_grace_ms: 0,
    });
    let mut other_version = encode_vec(&register).expect("encode");
    other_version[0] = 9; // the envelope's version varint
    let stranger = FromAgent::Heartbeat(Heartbeat { robot: RobotId(99), seq: 1 });
    // Had it been taken, robot 2's own agent would be refused as a duplicate.
    let as_robot_2 =
        FromAgent::Register(Register { robot: RobotId(2), instance: 5, ..register_of(&register) });
    let foreign = ToAgent::GoalBearing(GoalBearing { robot: RobotId(2), bearing: 0.0, step: 0 });
    let again = ToAgent::Deploy(Deploy { robot: RobotId(1), x: 1.0, y: 1.0, heading: 0.0 });
    for _ in 0..3 {
        report.publish(&[0xff, 0xff, 0xff, 0xff]).expect("garbage");
        report.publish(&other_version).expect("other version");
        report.publish(&encode_vec(&stranger).expect("encode")).expect("unknown robot");
        report.publish(&encode_vec(&as_robot_2).expect("encode")).expect("another robot's registration");
        report.publish(&encode_vec(&register).expect("encode")).expect("duplicate");
        command.publish(&[PROTOCOL_VERSION as u8, 0xee, 0x07]).expect("garbage command");
        command.publish(&encode_vec(&foreign).expect("encode")).expect("foreign command");
        command.publish(&encode_vec(&again).expect("encode")).expect("second deploy");
    }
    // Each kind's third message logged, by the orchestrator and by robot 1's
    // agent: all were taken. Only then do the publishers go (a subscriber
    // drops what a publisher that has gone left unread). 21 messages fit the
    // subscribers' buffers (64 per publisher), so they may come at once.
    let mut awaited: Vec<(&str, &str)> = ["Garbage", "WrongVersion", "UnknownRobot", "Duplicate"]
        .map(|kind| ("who=\"launch\"", kind))
        .into_iter()
        .chain(["Garbage", "UnknownRobot", "Duplicate"].map(|kind| ("who=\"sim-agent[robot 1]\"", kind)))
        .collect();
    launch
        .stderr_line(Duration::from_secs(30), |l| {
            if l.contains("bad message") && l.contains(" n=3") {
                awaited.retain(|(who, kind)| !(l.contains(who) && l.contains(&format!("kind={kind}"))));
            }
            awaited.is_empty().then_some(())
        })
        .unwrap_or_else(|| {
            panic!("the third bad message of each kind was not logged within 30 s: {awaited:?}")
        });
    drop((report, command, bus));

    let out = launch.wait(Duration::from_secs(60));
    assert_eq!(out.status.code(), Some(0), "the run still succeeds:\n{}", out.stderr);
    let j = out.json();
    let seen = &j["bad_traffic"];
    for kind in ["garbage", "wrong_version", "duplicate"] {
        assert_eq!(seen[kind], 3, "orchestrator {kind}: {seen}");
    }
    assert_eq!(seen["unknown_robot"], 6, "robot 99, and robot 2 on robot 1's topic: {seen}");
    // The agent logged its own counts when it exited.
    let agent_line = out
        .stderr
        .lines()
        .find(|l| l.contains("sim-agent{robot=1}") && l.contains("exiting"))
        .unwrap_or_else(|| panic!("robot 1's agent reported nothing:\n{}", out.stderr));
    for count in ["3 undecodable", "3 about an unknown robot", "3 duplicate registration"] {
        assert!(agent_line.contains(count), "{count} in {agent_line}");
    }
    assert_eq!(j["robots"][0]["end"], "stuck", "robot 1 went on as if nothing happened");
    assert_eq!(j["robots"][1]["end"], "stuck", "robot 2's own agent ran it: {}", j["robots"][1]);
    assert_eq!(j["robots"][2]["end"], "arrived");
}

/// A forged pose cannot stall, win or change a real launch (the harness
/// pins every rule in virtual time, `orchestrator/launch/tests/launch_sim.rs`;
/// this is the same through the bus and the driver): a pose of robot 1 with
/// step `u64::MAX` and one with a NaN coordinate, published on robot 1's
/// pose topic while it moves, are refused and counted; one at the goal
/// either jumps too fast (refused) or is older than what robot 1 has
/// published meanwhile (ignored): either way robot 1 does not win by it.
/// Issue 53: none of them is shown. The recording holds them as they came
/// on the bus, but not among the poses the core applied (`core/moved`),
/// which are what the scene, the live view, ROS 2 and the bag show.
#[test]
fn forged_poses_are_refused_counted_and_change_nothing() {
    use bycoms_protocol::msg::Pose;
    let name = swarm_name("forged");
    let swarm = Swarm::new(&name).expect("swarm name");
    let dir = tempfile::tempdir().expect("temp dir");
    let recording = dir.path().join("forged.mcap");
    let rec = recording.to_str().expect("utf-8 path");
    let launch = Proc::orchestrator(&[
        "launch", "--clock", "realtime", "--speed", "10", "--dwell", "3", "--swarm", &name, "--json",
        "--record", rec,
    ]);
    let moving = wait_for_pose(&name, 3, 1, Duration::from_secs(30), |p| p.x > 16.0).expect("robot 1 moves");
    let bus = IpcBus::new(ipc_config(3)).expect("bus");
    let pose_topic = bus.publisher(swarm.pose(RobotId(1)).name()).expect("pose publisher");
    let future = Pose { step: u64::MAX, ..moving };
    let world = bycoms_study::scenario::load(&bycoms_study::scenario::TerrainSource::Scenario(
        bycoms_study::scenario::DEFAULT.into(),
    ))
    .expect("the default scenario");
    let goal = world.terrain.goal();
    let at_goal =
        Pose { x: goal.x, y: goal.y, step: moving.step + 1, time_us: moving.time_us + 100_000, ..moving };
    let not_a_number = Pose { x: f64::NAN, step: moving.step + 2, ..moving };
    for forged in [future, at_goal, not_a_number] {
        pose_topic.publish(&encode_vec(&forged).expect("encode")).expect("forged pose");
    }
    // The publisher stays until the launch ends: a subscriber drops what a
    // publisher that has gone left unread.
    let out = launch.wait(Duration::from_secs(60));
    drop((pose_topic, bus));
    assert_eq!(out.status.code(), Some(0), "the run still succeeds:\n{}", out.stderr);
    let j = out.json();
    let refused = j["bad_traffic"]["refused"].as_u64().expect("a count");
    assert!((2..=3).contains(&refused), "{}", j["bad_traffic"]);
    assert_eq!(j["robots"][0]["end"], "stuck", "robot 1 did not win by a forged pose");
    assert_eq!(j["robots"][2]["end"], "arrived");
    let (on_the_bus, shown) = recorded_poses(&recording);
    let forged = |p: &Pose| p.robot == RobotId(1) && (p.step == u64::MAX || p.x.is_nan() || p.x == goal.x);
    assert!(on_the_bus.iter().filter(|p| forged(p)).count() >= 3, "recorded as they came on the bus");
    assert!(shown.iter().any(|p| p.robot == RobotId(1)), "robot 1 is shown moving");
    assert!(!shown.iter().any(forged), "a forged pose is shown: {:?}", shown.iter().find(|p| forged(p)));
    let bag = std::io::Cursor::new(Vec::new());
    let (exported, _) = bycoms_launch::ros2::bag::export(&recording, bag, "bag.mcap").expect("exported");
    assert_eq!(exported.poses, shown.len() as u64, "the bag holds the poses shown, no other");
}

/// Every pose a recording holds on the bus's pose topics, and those the
/// launch core applied (`core/moved`), in order.
pub(crate) fn recorded_poses(
    path: &std::path::Path,
) -> (Vec<bycoms_protocol::msg::Pose>, Vec<bycoms_protocol::msg::Pose>) {
    use bycoms_record::decode::{decode_message, Content};
    use bycoms_record::read::{Item, Reader};
    let (mut on_the_bus, mut shown) = (Vec::new(), Vec::new());
    let mut applied = false;
    Reader::open(path)
        .expect("a recording")
        .stream(|item| {
            let Item::Message { channel, data, .. } = item else {
                return Ok::<_, bycoms_record::RecordError>(());
            };
            match decode_message(channel, data) {
                Content::Run(json) => {
                    let meta: bycoms_study::draw::run::RunMeta =
                        serde_json::from_slice(json).expect("run meta");
                    applied = meta.applied_poses;
                }
                Content::Pose(pose) => on_the_bus.push(pose),
                Content::Moved(pose) => shown.push(pose),
                _ => {}
            }
            Ok(())
        })
        .expect("read to its end");
    assert!(applied, "the run metadata says the applied poses are recorded");
    (on_the_bus, shown)
}

fn register_of(msg: &FromAgent) -> Register {
    match msg {
        FromAgent::Register(r) => *r,
        other => panic!("not a Register: {other:?}"),
    }
}
