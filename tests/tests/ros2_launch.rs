//! `orchestrator launch --ros2` seen by a ROS 2-over-zenoh client that is
//! not ours (`tests/python/ros2_listen.py`: eclipse-zenoh, rosbags, xxhash).
//!
//! The client plays the lab's router (rmw_zenohd's place); the launch
//! connects to it, as it would to a lab's. The client finds every topic
//! through its liveliness token, as `ros2 topic list` does, and checks every
//! sample with its own means (key, CDR, attachment, GID); the test then
//! compares what it saw with the launch's own summary: every robot's last
//! pose and path, the map, the beacons; every topic's sequence numbers from
//! 1 without a gap (the client subscribes before the launch, with
//! subscription tokens as a ROS 2 node's, so the launch waits for the
//! route to it and loses nothing at its start); nothing it could not decode.
//!
//! Needs python3 with the PyPI packages: `#[ignore = "needs …"]`, run by
//! `.ci/run` (which installs them) with `--include-ignored`.

use bycoms_tests::{swarm_name, Proc, PythonClient};
use std::net::TcpListener;
use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

#[test]
#[ignore = "needs python3 with eclipse-zenoh==1.10.2, rosbags==0.11.9 and xxhash==4.1.0"]
fn a_ros2_client_finds_every_topic_and_decodes_every_sample_of_a_launch() {
    // The lab router's port: free when asked (the listener binds it at once).
    let port = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port();
    let router = format!("tcp/127.0.0.1:{port}");
    let mut listener = PythonClient::start("ros2_listen.py", &[&router, "0", "3"]);
    assert_eq!(listener.line("ready line"), "ready");
    let swarm = swarm_name("ros2");
    let orch = Proc::orchestrator(&[
        "launch",
        "--robots",
        "3",
        "--swarm",
        &swarm,
        "--json",
        "--ros2",
        "--transport",
        "zenoh",
        "--listen",
        "tcp/127.0.0.1:0",
        "--connect",
        &router,
    ]);
    let done = orch.wait(Duration::from_secs(180));
    assert!(done.status.success(), "the launch failed:\n{}", done.stderr);
    let summary = done.json();
    assert_eq!(summary["outcome"], "arrived", "{summary}");
    let report = listener.report();

    let nodes = report["nodes"].as_array().expect("nodes");
    assert!(nodes.iter().any(|n| n.as_str().is_some_and(|n| n.ends_with("/NN/%/%/bycoms"))), "{report}");
    let topics = report["topics"].as_object().expect("topics");
    let mut names: Vec<&str> = topics.keys().map(String::as_str).collect();
    names.sort_unstable();
    let expected = [
        "/beacons",
        "/clock",
        "/gate",
        "/map",
        "/robot_1/path",
        "/robot_1/pose",
        "/robot_1/state",
        "/robot_2/path",
        "/robot_2/pose",
        "/robot_2/state",
        "/robot_3/path",
        "/robot_3/pose",
        "/robot_3/state",
        "/tf",
    ];
    assert_eq!(names, expected, "every topic with samples (no /diagnostics: no real robot): {report}");
    for (topic, t) in topics {
        let (count, last) = (t["count"].as_u64().expect("count"), t["last_seq"].as_u64().expect("last"));
        // The launch waited for the route to this subscriber: every sample
        // from the first (sequence number 1) on, none lost (≥ 99.9 % of those sent).
        assert_eq!(t["first_seq"], 1, "{topic}: from the first sample: {t}");
        assert_eq!(t["contiguous"], true, "{topic}: sequence numbers without a gap: {t}");
        assert!(count * 1000 >= last * 999, "{topic}: {count} of {last} sent: {t}");
    }
    assert_eq!(topics["/map"]["count"], 1, "the map, once: {report}");
    assert_eq!(topics["/gate"]["count"], 6, "deployed and stopped, each of 3 robots: {report}");
    let map = &topics["/map"]["last"];
    assert!(map[0].as_u64().is_some_and(|w| w > 0) && map[2].as_u64().is_some_and(|b| b > 0), "{map}");
    for key in ["undecoded", "bad_attachment", "bad_gid"] {
        assert_eq!(report[key], 0, "{key}: {report}");
    }
    assert_eq!(report["unexpected"], serde_json::json!([]), "{report}");
    robots_as_the_launch_ended(&summary, topics);
}

/// Each robot's last pose, path and state, and the beacons, against the
/// launch's summary.
fn robots_as_the_launch_ended(
    summary: &serde_json::Value,
    topics: &serde_json::Map<String, serde_json::Value>,
) {
    // Every robot's last pose is the one the launch ended with.
    for robot in summary["robots"].as_array().expect("robots") {
        let id = robot["id"].as_u64().expect("id");
        let last = &topics[&format!("/robot_{id}/pose")]["last"];
        assert_eq!((&last[0], &last[1], &last[2]), (&robot["x"], &robot["y"], &"world".into()), "robot {id}");
        let trail = &topics[&format!("/robot_{id}/path")]["last"];
        assert!(trail.as_u64().is_some_and(|n| n > 1), "robot {id}'s whole path: {trail}");
        // bycoms_msgs/RobotState: 2 a beacon, 3 arrived; waiting, moving, then that.
        let state = &topics[&format!("/robot_{id}/state")];
        let end = if robot["end"] == "stuck" { 2 } else { 3 };
        assert_eq!((&state["last"], &state["count"]), (&end.into(), &3.into()), "robot {id}: {state}");
    }
    // The beacons: every robot that stopped short of the goal.
    let stuck: Vec<u64> = summary["robots"]
        .as_array()
        .expect("robots")
        .iter()
        .filter(|r| r["end"] == "stuck")
        .map(|r| r["id"].as_u64().expect("id"))
        .collect();
    assert!(!stuck.is_empty(), "the default run has beacons: {summary}");
    assert_eq!(topics["/beacons"]["last"], serde_json::json!(stuck), "{topics:?}");
}

/// `orchestrator record export --ros2`: a launch's recording as a ROS 2 bag,
/// read by rosbags' rosbag2 reader (every message deserialized with the
/// bag's own schemas, each type's hash recomputed from them) and by
/// `mcap-ros2-support`'s decoder (`tests/python/ros2_bag.py`); the poses in
/// the bag are those the launch core applied (the recording's `core/moved`),
/// one for one.
#[test]
#[ignore = "needs python3 with rosbags==0.11.9, mcap==1.6.0 and mcap-ros2-support==0.6.0"]
fn an_exported_bag_is_read_by_rosbags_and_mcap_ros2_with_every_applied_pose_of_the_recording() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (recording, bag) = (dir.path().join("run.mcap"), dir.path().join("bag.mcap"));
    let swarm = swarm_name("ros2bag");
    let rec = recording.to_str().expect("utf-8");
    let launch = Proc::orchestrator(&["launch", "--robots", "3", "--swarm", &swarm, "--record", rec]);
    let done = launch.wait(Duration::from_secs(180));
    assert!(done.status.success(), "the launch failed:\n{}", done.stderr);
    let out = bag.to_str().expect("utf-8");
    let export =
        Proc::orchestrator(&["record", "export", "--ros2", rec, "--out", out]).wait(Duration::from_secs(60));
    assert!(export.status.success(), "the export failed:\n{}", export.stderr);
    // The outputs rule: an existing bag is replaced only with --force.
    let again =
        Proc::orchestrator(&["record", "export", "--ros2", rec, "--out", out]).wait(Duration::from_secs(60));
    assert_eq!(again.status.code(), Some(2), "{}", again.stderr);
    assert!(again.stderr.contains("bag.mcap") && again.stderr.contains("--force"), "{}", again.stderr);

    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("python/ros2_bag.py");
    let read = Command::new("python3").arg(script).args([rec, out]).output().expect("python3 runs");
    assert!(read.status.success(), "the readers failed: {}", String::from_utf8_lossy(&read.stderr));
    let report: serde_json::Value = serde_json::from_slice(&read.stdout).expect("the script prints JSON");
    let (rosbags, mcap) = (&report["rosbags"], &report["mcap_ros2"]);
    assert_eq!(rosbags["undecoded"], 0, "{report}");
    assert_eq!(rosbags["counts"], mcap["counts"], "both readers read every message: {report}");
    assert_eq!(mcap["profile"], "ros2");
    assert_eq!(mcap["hash_mismatch"], serde_json::json!([]), "{report}");
    assert_eq!(mcap["no_qos"], serde_json::json!([]), "{report}");
    assert_eq!(mcap["metadata"], serde_json::json!([["rosbag2", ["ROS_DISTRO", "serialized_metadata"]]]));
    let counts = rosbags["counts"].as_object().expect("counts");
    let poses: u64 = (1..=3).map(|k| counts[&format!("/robot_{k}/pose")].as_u64().expect("poses")).sum();
    assert_eq!(poses, report["recording_poses"].as_u64().expect("recording poses"), "{report}");
    assert_eq!(counts["/tf"], poses, "one transform per pose");
    assert_eq!(counts["/map"], 1);
    assert!(counts["/beacons"].as_u64().is_some_and(|n| n > 0), "{report}");
}

/// Issue 32 item 4: the stop service. An independent client (eclipse-zenoh
/// and rosbags, `tests/python/ros2_stop_call.py`) finds `/emergency` by its
/// `SS` token, calls it as rmw_zenoh's client does, and gets
/// `success = true` in CDR with its own sequence number and GID in the
/// reply's attachment; the launch stops every running robot at once and
/// its summary names the service as who stopped it.
#[test]
#[ignore = "needs python3 with eclipse-zenoh==1.10.2, rosbags==0.11.9 and xxhash==4.1.0"]
fn calling_the_ros2_stop_service_stops_every_robot() {
    let port = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port();
    let router = format!("tcp/127.0.0.1:{port}");
    let mut caller = PythonClient::start("ros2_stop_call.py", &[&router, "0"]);
    assert_eq!(caller.line("ready line"), "ready");
    let swarm = swarm_name("ros2stop");
    let orch = Proc::orchestrator(&[
        "launch",
        "--clock",
        "realtime",
        "--speed",
        "1",
        "--swarm",
        &swarm,
        "--json",
        "--ros2",
        "--transport",
        "zenoh",
        "--listen",
        "tcp/127.0.0.1:0",
        "--connect",
        &router,
    ]);
    assert_eq!(caller.line("found line"), "found /emergency");
    // Once robot 1 moves, so that a robot is running when the call comes.
    bycoms_tests::wait_for(Duration::from_secs(30), || {
        let out = Proc::orchestrator(&["status", "--json", "--swarm", &swarm]).wait(Duration::from_secs(20));
        let line: serde_json::Value = serde_json::from_str(out.stdout.lines().next()?).ok()?;
        (line["status"]["robots"][0]["state"] == "moving").then_some(())
    })
    .expect("robot 1 moves within 30 s");
    let report = caller.report_after("call");
    assert_eq!(report["replies"], 1, "{report}");
    assert_eq!(report["success"], true, "{report}");
    assert!(report["message"].as_str().is_some_and(|m| m.contains(&swarm)), "{report}");
    assert_eq!((&report["same_sequence"], &report["same_gid"]), (&true.into(), &true.into()), "{report}");
    assert_eq!(report["key"], report["expected_key"], "{report}");
    let done = orch.wait(Duration::from_secs(30));
    assert_eq!(done.status.code(), Some(130), "{}", done.stderr);
    let stop = &done.json()["stop"];
    assert_eq!(stop["now"], true, "{stop}");
    assert!(
        stop["who"].as_str().is_some_and(|w| w.starts_with("ros2 service /emergency (client ")),
        "{stop}"
    );
    assert!(stop["told"].as_array().is_some_and(|t| t.first() == Some(&1.into())), "{stop}");
    assert_eq!(stop["told"].as_array().map(Vec::len), stop["answered"].as_array().map(Vec::len), "{stop}");
}
