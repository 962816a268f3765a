//! Pose on the bus → ROS 2 sample: the latency `launch --ros2` adds.
//!
//! Two zenoh sessions over loopback TCP in one process: the launch's (the
//! `Ros2Bridge` observer on it, as `launch --ros2` taps it) and a ROS 2
//! subscriber's (a plain zenoh subscriber on robot 1's pose key, reading the
//! rmw_zenoh attachment's sequence number). Each pose is handed to the
//! observer as the launch hands it a pose it has just recorded; measured:
//!
//! * `observer`: the time the observer call takes (encoding `/clock`, the
//!   pose, `/tf` and, when due, the path, and putting each): what the
//!   launch loop pays per pose;
//! * `pose → sample`: from the call to the subscriber's callback receiving
//!   the `PoseStamped` sample (the observer's work plus the zenoh hop).
//!
//! Poses are paced at 1 kHz (a 3-robot lockstep launch sends about that),
//! after 200 warm-up poses. Prints p50, p99 and max; target p99 ≤ 1 ms.
//!
//! Run: `cargo bench -p bycoms-orchestrator --bench ros2_latency`
//! (`BYCOMS_BENCH_SAMPLES`, default 5000).

use bycoms_launch::observe::Observer;
use bycoms_launch::ros2::{Ros2Bridge, Ros2Config};
use bycoms_protocol::msg::Pose;
use bycoms_protocol::RobotId;
use bycoms_ros2::rmw_zenoh::Attachment;
use bycoms_runtime::stats::quantile;
use std::net::TcpListener;
use std::sync::mpsc;
use std::time::{Duration, Instant};
use zenoh::Wait;

const WARM_UP: usize = 200;

fn session(listen: Option<&str>, connect: Option<&str>) -> zenoh::Session {
    let mut c = zenoh::Config::default();
    let list = |e: Option<&str>| e.map_or("[]".to_string(), |e| format!("[\"{e}\"]"));
    c.insert_json5("mode", "\"peer\"").expect("mode");
    c.insert_json5("listen/endpoints", &list(listen)).expect("listen");
    c.insert_json5("connect/endpoints", &list(connect)).expect("connect");
    c.insert_json5("scouting/multicast/enabled", "false").expect("scouting");
    zenoh::open(c).wait().expect("zenoh session")
}

fn report(what: &str, d: Vec<Duration>) {
    // The runtime's one quantile (nearest rank); no poses, no figures.
    let us = |q: f64| quantile(&d, q).map_or(f64::NAN, |t| t.as_secs_f64() * 1e6);
    println!(
        "{what:>14}: p50 {:>7.1} µs  p99 {:>7.1} µs  max {:>8.1} µs  ({} poses)",
        us(0.5),
        us(0.99),
        us(1.0),
        d.len()
    );
}

fn main() {
    let poses: usize =
        std::env::var("BYCOMS_BENCH_SAMPLES").ok().and_then(|v| v.parse().ok()).unwrap_or(5000);
    let port = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let launch = session(Some(&endpoint), None);
    let ros = session(None, Some(&endpoint));
    let (tx, rx) = mpsc::channel();
    let _sub = ros
        .declare_subscriber("0/robot_1/pose/**")
        .callback(move |s| {
            let at = Instant::now();
            if let Some(seq) = s.attachment().and_then(|a| Attachment::decode(&a.to_bytes()).ok()) {
                let _ = tx.send((seq.sequence_number, at));
            }
        })
        .wait()
        .expect("subscriber");
    let mut bridge = Ros2Bridge::open(&Ros2Config::default(), &launch, 1).expect("bridge");
    let mut sent = Vec::with_capacity(poses + WARM_UP);
    let mut call = Vec::with_capacity(poses);
    let mut next = Instant::now();
    for i in 0..poses + WARM_UP {
        let step = i as u64;
        let pose = Pose {
            robot: RobotId(1),
            x: step as f64 * 0.01,
            y: 1.0,
            heading: 0.3,
            step,
            time_us: step * 1_000,
        };
        next += Duration::from_millis(1);
        while Instant::now() < next {
            std::hint::spin_loop();
        }
        let t0 = Instant::now();
        bridge.pose(&pose);
        if i >= WARM_UP {
            call.push(t0.elapsed());
        }
        sent.push(t0);
    }
    let mut delivered = Vec::with_capacity(poses);
    let deadline = Instant::now() + Duration::from_secs(10);
    while let Ok((seq, at)) = rx.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
        let index = usize::try_from(seq - 1).expect("sequence numbers from 1");
        if index >= WARM_UP {
            delivered.push(at - sent[index]);
        }
        if index + 1 == sent.len() {
            break;
        }
    }
    println!("ros2_latency: {poses} poses of robot 1 at 1 kHz, loopback TCP, one process");
    report("observer", call);
    println!("{:>14}: {} of {poses} delivered", "samples", delivered.len());
    report("pose → sample", delivered);
}
