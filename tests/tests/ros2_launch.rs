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
        "/tf_static",
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
    assert_eq!(topics["/tf_static"]["count"], 1, "the static frames, once: {report}");
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

/// How a transient-local subscription of rmw_zenoh subscribes
/// (`rmw_subscription_data.cpp`, commit 04df82fd985f, `SubscriptionData::init`):
/// zenoh-ext's advanced subscriber with subscriber detection, a query
/// timeout of `u64::MAX` ms, history with late-publisher detection and
/// `max_samples` = the depth, and, the topic being reliable, recovery by
/// heartbeat.
fn rmw_zenoh_transient_local_subscriber(
    session: &zenoh::Session,
    key: String,
    depth: usize,
) -> zenoh_ext::AdvancedSubscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>> {
    use zenoh::Wait;
    use zenoh_ext::{AdvancedSubscriberBuilderExt, HistoryConfig, RecoveryConfig};
    session
        .declare_subscriber(key)
        .advanced()
        .subscriber_detection()
        .query_timeout(Duration::from_millis(u64::MAX))
        .history(HistoryConfig::default().detect_late_publishers().max_samples(depth))
        .recovery(RecoveryConfig::default().heartbeat())
        .wait()
        .expect("an advanced subscriber")
}

/// One received sample: its attachment's sequence number and its CDR.
fn sequenced(sample: &zenoh::sample::Sample) -> (i64, Vec<u8>) {
    let attachment = sample.attachment().expect("rmw_zenoh's attachment").to_bytes();
    let attachment = bycoms_ros2::rmw_zenoh::Attachment::decode(&attachment).expect("a 33-byte attachment");
    (attachment.sequence_number, sample.payload().to_bytes().to_vec())
}

/// A late joiner's subscribers of the map, `/tf_static` and the beacons.
type Latched = [zenoh_ext::AdvancedSubscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>; 3];

/// What `subscribers` receive until each got a sample, for at most `wait`
/// (each sample as [`sequenced`]).
fn first_of_each(subscribers: &Latched, wait: Duration) -> [Vec<(i64, Vec<u8>)>; 3] {
    let mut got: [Vec<(i64, Vec<u8>)>; 3] = Default::default();
    let deadline = std::time::Instant::now() + wait;
    while got.iter().any(Vec::is_empty) && std::time::Instant::now() < deadline {
        for (sub, got) in subscribers.iter().zip(&mut got) {
            if let Ok(Some(s)) = sub.recv_timeout(Duration::from_millis(50)) {
                got.push(sequenced(&s));
            }
        }
    }
    assert!(
        got.iter().all(|g| !g.is_empty()),
        "each latched topic within {wait:?}: {:?}",
        got.each_ref().map(Vec::len)
    );
    got
}

/// The map and the static frames a late joiner got: each once, the one
/// sent before the run (sequence number 1), decoded.
fn map_and_static_frames_once(map: &[(i64, Vec<u8>)], tf_static: &[(i64, Vec<u8>)]) {
    use bycoms_ros2::display::OccupancyGrid;
    use bycoms_ros2::msgs::TfMessage;
    assert_eq!(map.len(), 1, "the map once");
    assert_eq!(map[0].0, 1, "the one sent before the run");
    let grid = OccupancyGrid::from_cdr(&map[0].1).expect("an OccupancyGrid");
    let (w, h) = (grid.width, grid.height);
    assert!(w > 0 && grid.data.len() == (w * h) as usize, "{w}×{h}");
    assert!(grid.data.contains(&100) && grid.header.frame_id == "world", "blocked cells in world");
    assert_eq!(tf_static.len(), 1, "the static frames once");
    let tf = TfMessage::from_cdr(&tf_static[0].1).expect("a TFMessage");
    let frames: Vec<_> =
        tf.transforms.iter().map(|t| (t.header.frame_id.as_str(), t.child_frame_id.as_str())).collect();
    assert_eq!((tf_static[0].0, frames), (1, vec![("world", "arena")]));
}

/// A ROS 2 node that joins late (RViz opened during the run) gets the
/// latched topics: zenoh-ext's own `AdvancedSubscriber` (the `unstable`
/// dev-dependency; the product has none), configured as rmw_zenoh
/// configures a transient-local subscription, joins a `launch --ros2`
/// after its first beacon was published (the map and `/tf_static` went out
/// before the run), and receives the map, `/tf_static` and the beacons'
/// markers from the launch's caches, each once (sequence numbers never
/// repeated), decoded; the map and the static frames are the ones sent
/// before the run (sequence number 1).
#[test]
fn a_late_rmw_zenoh_subscriber_gets_the_map_static_frames_and_beacons_once() {
    use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
    use bycoms_ros2::display::{MarkerArray, OccupancyGrid};
    use bycoms_ros2::msgs::{RosMessage, TfMessage};
    use bycoms_ros2::rmw_zenoh::topic_key_expr;
    use zenoh::Wait;
    const WAIT: Duration = Duration::from_secs(60);
    fn key(topic: &str, d: &'static bycoms_ros2::types::TypeDescription) -> String {
        topic_key_expr(0, topic, d.name, &d.rihs01())
    }
    let (map_key, tf_key) =
        (key("/map", OccupancyGrid::DESCRIPTION), key("/tf_static", TfMessage::DESCRIPTION));
    let beacons_key = key("/beacons", MarkerArray::DESCRIPTION);

    let config =
        |ep: &str| ZenohConfig { mode: Mode::Router, listen: vec![ep.to_owned()], ..ZenohConfig::default() };
    let (router, endpoint) = ZenohBus::loopback_router(config).expect("the lab's router");
    // What the lab sees of the run before the late joiner comes: the beacons as they are sent.
    let watcher = router.session().declare_subscriber(beacons_key.clone()).wait().expect("a watcher");
    let swarm = swarm_name("ros2late");
    let orch = Proc::orchestrator(&[
        "launch",
        "--robots",
        "3",
        "--swarm",
        &swarm,
        "--json",
        "--clock",
        "realtime",
        "--speed",
        "5",
        "--ros2",
        "--ros2-router",
        &endpoint,
    ]);
    let first = watcher.recv_timeout(WAIT).ok().flatten().expect("the first beacon within 60 s");
    let seen_before = sequenced(&first).0;

    let late = ZenohBus::open(bycoms_runtime::zenoh_config(Mode::Client, vec![], vec![endpoint], None))
        .expect("the late joiner's session");
    let subscribers = [&map_key, &tf_key, &beacons_key]
        .map(|k| rmw_zenoh_transient_local_subscriber(late.session(), k.clone(), 1));
    // Every latched topic's cached sample arrives while the launch runs.
    let mut got = first_of_each(&subscribers, WAIT);
    let done = orch.wait(Duration::from_secs(180));
    assert!(done.status.success(), "the launch failed:\n{}", done.stderr);
    for (sub, got) in subscribers.iter().zip(&mut got) {
        while let Ok(Some(s)) = sub.try_recv() {
            got.push(sequenced(&s));
        }
    }
    let [map, tf_static, beacons] = got;

    map_and_static_frames_once(&map, &tf_static);
    // The beacons: from the cache (the newest when it joined, at least the
    // one seen before), then live; none twice.
    let seqs: Vec<i64> = beacons.iter().map(|b| b.0).collect();
    assert!(
        seqs[0] >= seen_before && seqs.windows(2).all(|w| w[0] < w[1]),
        "{seqs:?} (seen before: {seen_before})"
    );
    let summary = done.json();
    let stuck = summary["robots"].as_array().expect("robots").iter().filter(|r| r["end"] == "stuck").count();
    let last = beacons.last().expect("a beacons sample");
    let mut r = bycoms_ros2::cdr::CdrReader::new(&last.1).expect("CDR");
    assert_eq!(
        r.u32().expect("the markers' count") as usize,
        2 * stuck,
        "a sphere and a circle per beacon: {summary}"
    );
}

/// `geometry_msgs/msg/PoseStamped` as ros2-client's serde CDR reads it
/// (positional: the fields in the message's order), written here from the
/// message definitions, not from our encoder.
#[derive(serde::Deserialize, Debug)]
struct OraclePoseStamped {
    header: (i32, u32, String),
    position: (f64, f64, f64),
    orientation: (f64, f64, f64, f64),
}

/// What a 3-robot `launch --ros2` with the default namespace offers, with
/// the DDS type names rmw_zenoh writes in its tokens (written out here from
/// the message packages, not from our encoder): its topics, and its
/// `/emergency` service.
fn launch_graph() -> std::collections::BTreeMap<String, &'static str> {
    let mut graph: std::collections::BTreeMap<String, &'static str> = [
        ("/clock", "rosgraph_msgs::msg::dds_::Clock_"),
        ("/tf", "tf2_msgs::msg::dds_::TFMessage_"),
        ("/tf_static", "tf2_msgs::msg::dds_::TFMessage_"),
        ("/map", "nav_msgs::msg::dds_::OccupancyGrid_"),
        ("/beacons", "visualization_msgs::msg::dds_::MarkerArray_"),
        ("/diagnostics", "diagnostic_msgs::msg::dds_::DiagnosticArray_"),
        ("/gate", "bycoms_msgs::msg::dds_::GateEvent_"),
        ("/emergency", "std_srvs::srv::dds_::Trigger_"),
    ]
    .map(|(t, ty)| (t.to_owned(), ty))
    .into();
    for k in 1..=3 {
        graph.insert(format!("/robot_{k}/pose"), "geometry_msgs::msg::dds_::PoseStamped_");
        graph.insert(format!("/robot_{k}/path"), "nav_msgs::msg::dds_::Path_");
        graph.insert(format!("/robot_{k}/state"), "bycoms_msgs::msg::dds_::RobotState_");
    }
    graph
}

/// The publishers and service servers of node `/bycoms` that `next` (a
/// ros2-client graph event stream's next event, if any) declared so far:
/// name → DDS type.
fn bycoms_entities(
    mut next: impl FnMut() -> Option<ros2_client::GraphEvent>,
    seen: &mut std::collections::BTreeMap<String, String>,
) {
    use ros2_client::{EntityKind, GraphEvent};
    while let Some(event) = next() {
        let GraphEvent::EntityDeclared(e) = event else { continue };
        let served = matches!(e.kind, EntityKind::Publisher | EntityKind::ServiceServer);
        if let (true, "/bycoms", Some(name), Some(ty)) = (served, e.node_name.as_str(), e.name, e.type_name) {
            seen.insert(name, ty);
        }
    }
}

/// ros2-client 0.12.1's zenoh backend (an independent Rust implementation
/// of rmw_zenoh; its interop report passes against rmw_zenoh_cpp) as a
/// second oracle: subscribed before the launch, on a client session of the
/// lab's router, it finds the launch's node and one publisher of each of
/// its topics, each with its type, and the `/emergency` service with its
/// type, in its graph (from our liveliness tokens), and decodes
/// robot 1's poses with its own CDR (serde), the last one the launch's.
/// Not checked with it: the `/emergency` service (its client puts requests
/// on a placeholder type hash, `RIHS01_000…`, for types outside its table,
/// std_srvs/Trigger among them, so no rmw_zenoh server, ours included,
/// matches: deploy/ros2/README.md).
#[test]
fn ros2_client_finds_the_launchs_node_and_topics_and_decodes_its_poses() {
    use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
    use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};
    let config =
        |ep: &str| ZenohConfig { mode: Mode::Router, listen: vec![ep.to_owned()], ..ZenohConfig::default() };
    let (_router, endpoint) = ZenohBus::loopback_router(config).expect("the lab's router");
    let mut zenoh_config = zenoh::Config::default();
    for (key, value) in [
        ("mode", "\"client\"".to_owned()),
        ("connect/endpoints", format!("[\"{endpoint}\"]")),
        ("scouting/multicast/enabled", "false".to_owned()),
    ] {
        zenoh_config.insert_json5(key, &value).unwrap_or_else(|e| panic!("{key}: {e}"));
    }
    let options = ros2_client::zenoh::ContextOptions::new().domain_id(0).zenoh_config(zenoh_config);
    let context = ros2_client::zenoh::Context::with_options(options).expect("ros2-client's context");
    let name = NodeName::new("/", "oracle").expect("a node name");
    let node = context.new_node(name, NodeOptions::new().enable_rosout(false)).expect("a node");
    let pose_name = Name::new("/robot_1", "pose").expect("a topic name");
    let topic = node.create_topic(
        &pose_name,
        MessageTypeName::new("geometry_msgs", "PoseStamped"),
        &QosProfile::subscription_default(),
    );
    let poses = node.create_subscription::<OraclePoseStamped>(&topic, None).expect("a subscription");

    let events = context.graph_event_stream();
    let swarm = swarm_name("ros2oracle");
    let args = ["launch", "--robots", "3", "--swarm", &swarm, "--json", "--ros2", "--ros2-router", &endpoint];
    let launch = std::thread::spawn({
        let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
        move || {
            Proc::orchestrator(&args.iter().map(String::as_str).collect::<Vec<_>>())
                .wait(Duration::from_secs(180))
        }
    });
    // Its graph: the node, then every topic and the service with their
    // types (their tokens come with the launch's start).
    let (expected, mut seen) = (launch_graph(), std::collections::BTreeMap::new());
    let listed = bycoms_tests::wait_for_every(Duration::from_millis(20), Duration::from_secs(60), || {
        bycoms_entities(|| events.try_recv().ok(), &mut seen);
        let all = expected.iter().all(|(t, ty)| seen.get(t).is_some_and(|s| s == ty));
        let published =
            expected.keys().filter(|t| *t != "/emergency").all(|t| context.publisher_count(t) == 1);
        (context.node_names().contains(&"/bycoms".to_owned()) && all && published).then_some(())
    });
    let mut got = Vec::new();
    let drained = bycoms_tests::wait_for_every(Duration::from_millis(20), Duration::from_secs(180), || {
        while let Ok(Some((pose, _info))) = poses.try_take() {
            got.push(pose);
        }
        launch.is_finished().then_some(())
    });
    let done = launch.join().expect("the launch's thread");
    while let Ok(Some((pose, _info))) = poses.try_take() {
        got.push(pose);
    }
    assert!(listed.is_some(), "the node and every topic: nodes {:?}, seen {seen:?}", context.node_names());
    assert!(drained.is_some() && done.status.success(), "the launch:\n{}", done.stderr);
    let summary = done.json();
    let robot = &summary["robots"][0];
    let last = got.last().expect("robot 1's poses");
    assert_eq!(last.header.2, "world", "{last:?}");
    let (x, y, z, w) = last.orientation;
    assert!((x * x + y * y + z * z + w * w - 1.0).abs() < 1e-9 && x == 0.0 && y == 0.0, "a yaw: {last:?}");
    assert_eq!(
        (robot["x"].as_f64(), robot["y"].as_f64()),
        (Some(last.position.0), Some(last.position.1)),
        "{last:?}"
    );
}
