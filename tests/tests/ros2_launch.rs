//! `orchestrator launch --ros2` seen by a ROS 2-over-zenoh client that is
//! not ours (`tests/python/ros2_listen.py`: eclipse-zenoh, rosbags, xxhash).
//!
//! The client plays the lab's router (rmw_zenohd's place); the launch
//! connects to it, as it would to a lab's. The client finds every topic
//! through its liveliness token, as `ros2 topic list` does, and checks every
//! sample with its own means (key, CDR, attachment, GID); the test then
//! compares what it saw with the launch's own summary: every robot's last
//! pose, sequence numbers without a gap from the first received on (what
//! is put before the route to the router exists is lost, as any volatile
//! ROS 2 publisher's samples are), nothing it could not decode.
//!
//! Needs python3 with the PyPI packages: `#[ignore = "needs …"]`, run by
//! `.ci/run` (which installs them) with `--include-ignored`.

use bycoms_tests::{swarm_name, Proc};
use std::io::Write;
use std::net::TcpListener;
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

/// The Python listener, killed and reaped on drop.
struct Listener {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: mpsc::Receiver<String>,
}

impl Listener {
    fn start(endpoint: &str) -> Listener {
        let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("python/ros2_listen.py");
        let mut child = Command::new("python3")
            .arg(&script)
            .args([endpoint, "0"])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("python3 starts");
        let lines = bycoms_tests::stdout_lines(&mut child);
        let stdin = child.stdin.take();
        Listener { child, stdin, lines }
    }

    fn line(&self, what: &str) -> String {
        self.lines
            .recv_timeout(Duration::from_secs(60))
            .unwrap_or_else(|_| panic!("the listener printed no {what} within 60 s"))
    }

    /// Tells it the launch has ended; its report.
    fn report(&mut self) -> serde_json::Value {
        let mut stdin = self.stdin.take().expect("stdin");
        stdin.write_all(b"done\n").expect("write to the listener");
        drop(stdin);
        serde_json::from_str(&self.line("report")).expect("the report is JSON")
    }
}

impl Drop for Listener {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
#[ignore = "needs python3 with eclipse-zenoh==1.10.2, rosbags==0.11.9 and xxhash==4.1.0"]
fn a_ros2_client_finds_every_topic_and_decodes_every_sample_of_a_launch() {
    // The lab router's port: free when asked (the listener binds it at once).
    let port = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port();
    let router = format!("tcp/127.0.0.1:{port}");
    let mut listener = Listener::start(&router);
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
    assert_eq!(names, ["/clock", "/robot_1/pose", "/robot_2/pose", "/robot_3/pose", "/tf"], "{report}");
    for (topic, t) in topics {
        assert!(t["count"].as_u64().is_some_and(|n| n > 0), "{topic}: {t}");
        // Samples put before the route to the router exists are lost, as a
        // volatile ROS 2 publisher's are (deploy/ros2/README.md); from the
        // first received on, none is.
        assert_eq!(t["contiguous"], true, "{topic}: sequence numbers without a gap: {t}");
    }
    for key in ["undecoded", "bad_attachment", "bad_gid"] {
        assert_eq!(report[key], 0, "{key}: {report}");
    }
    assert_eq!(report["unexpected"], serde_json::json!([]), "{report}");
    // Every robot's last pose is the one the launch ended with.
    for robot in summary["robots"].as_array().expect("robots") {
        let id = robot["id"].as_u64().expect("id");
        let last = &topics[&format!("/robot_{id}/pose")]["last"];
        assert_eq!((&last[0], &last[1], &last[2]), (&robot["x"], &robot["y"], &"world".into()), "robot {id}");
    }
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
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("python/ros2_stop_call.py");
    let mut child = Command::new("python3")
        .arg(&script)
        .args([router.as_str(), "0"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("python3 starts");
    let lines = bycoms_tests::stdout_lines(&mut child);
    let mut caller = Listener { stdin: child.stdin.take(), child, lines };
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
    let mut stdin = caller.stdin.take().expect("stdin");
    stdin.write_all(b"call\n").expect("write to the caller");
    drop(stdin);
    let report: serde_json::Value = serde_json::from_str(&caller.line("report")).expect("JSON");
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
}
