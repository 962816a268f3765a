//! The format proven against a client nobody here wrote: OptiTrack's own
//! Python `NatNetClient` (PyPI `natnetsdk`, installed by `.ci/run`) reads
//! the emulated lab's NatNet server and must see the same bodies, names
//! and positions. It is `#[ignore = "needs …"]`: `.ci/run` installs the
//! package and runs it with `--include-ignored`; without it, it fails.

use bycoms_natnet_server::{BodyConfig, Faults, NatNetServer, ServerConfig};
use std::io::Read;
use std::net::Ipv4Addr;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn natnetsdk_available() -> bool {
    Command::new("python3")
        .args(["-c", "import natnetsdk.NatNetClient"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

#[test]
#[ignore = "needs python3 with natnetsdk==4.1.1"]
fn the_sdk_python_client_sees_our_bodies_names_and_positions() {
    assert!(natnetsdk_available(), "python3 cannot import natnetsdk (pip install natnetsdk==4.1.1)");
    let bodies = vec![
        BodyConfig { name: "robot1".into(), id: 1, position: [0.25, 0.0, -0.5], yaw_deg: 0.0 },
        BodyConfig { name: "robot2".into(), id: 2, position: [1.5, 0.0, 0.75], yaw_deg: 30.0 },
        BodyConfig { name: "goal".into(), id: 10, position: [3.0, 0.125, -1.0], yaw_deg: 0.0 },
    ];
    let config = ServerConfig {
        rate_hz: 120.0,
        app_name: "bycoms lab".into(),
        multicast: None,
        bodies: bodies.clone(),
        faults: Faults::default(),
    };
    let server = NatNetServer::start_any_port(config, Ipv4Addr::LOCALHOST.into()).unwrap();
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/natnet_sdk_read.py");
    let mut child = Command::new("python3")
        .args([script, &server.command_addr().port().to_string(), "10"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("the SDK client did not finish within 30 s");
        }
        // Polled: std's `Child` has no wait with a timeout.
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut out = String::new();
    child.stdout.take().unwrap().read_to_string(&mut out).unwrap();
    assert!(status.success(), "SDK client failed: {out}");
    let lines: Vec<Vec<&str>> = out.lines().map(|l| l.split_whitespace().collect()).collect();
    let field = |key: &str| lines.iter().find(|l| l.first() == Some(&key)).map(|l| l[1..].join(" "));
    assert_eq!(field("app").as_deref(), Some("bycoms lab"), "{out}");
    assert_eq!(field("version").as_deref(), Some("4.1.0.0"), "{out}");
    let frames: u32 = field("frames").and_then(|f| f.parse().ok()).unwrap_or(0);
    assert!(frames >= 10, "the client parsed {frames} frames:\n{out}");
    for b in &bodies {
        let name = lines.iter().find(|l| l[0] == "name" && l[1] == b.id.to_string());
        assert_eq!(name.map(|l| l[2..].join(" ")), Some(b.name.clone()), "name of id {}:\n{out}", b.id);
        let body = lines.iter().find(|l| l[0] == "body" && l[1] == b.id.to_string()).expect("body seen");
        let pos: Vec<f32> = body[2..5].iter().map(|v| v.parse().unwrap()).collect();
        assert_eq!(pos, b.position, "position of {}", b.name);
        assert_eq!(body[5], "1", "tracking valid for {}", b.name);
    }
}
