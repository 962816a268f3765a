//! The poses seam's conformance suite (`suites/poses.rs`) against every
//! [`PoseSource`]: add a fixture and one `#[test]` per implementation.
//!
//! [`PoseSource`]: bycoms_launch::poses::PoseSource

use crate::suites;

use bycoms_launch::poses::bus::BusPoses;
use bycoms_launch::poses::merged::MergedPoses;
use bycoms_launch::poses::{PoseSink, PoseSource};
use bycoms_launch::recording::Recording;
use bycoms_launch::transport::{AnyPublisher, SharedBus};
use bycoms_protocol::bus::memory::MemoryBus;
use bycoms_protocol::bus::Limits;
use bycoms_protocol::msg::Pose;
use bycoms_protocol::{encode, RobotId, Swarm, MAX_MESSAGE_LEN};
use bycoms_runtime::Traffic;
use std::collections::BTreeMap;
use std::rc::Rc;
use std::time::Duration;
use suites::poses::{run_all, Expected, Garbage, PoseFixture};

/// The agents' simulated mocap: poses published on the (in-memory) bus.
struct BusFixture {
    bus: SharedBus,
    swarm: Swarm,
    publishers: BTreeMap<u32, AnyPublisher>,
}

impl BusFixture {
    fn new() -> Self {
        let bus: SharedBus = Rc::new(MemoryBus::new(Limits::default()).expect("memory bus"));
        Self { bus, swarm: Swarm::new("suite").expect("swarm"), publishers: BTreeMap::new() }
    }

    fn publish(&mut self, robot: u32, bytes: &[u8]) {
        let (bus, swarm) = (&self.bus, self.swarm);
        let publisher = self
            .publishers
            .entry(robot)
            .or_insert_with(|| bus.publisher(swarm.pose(RobotId(robot)).name()).expect("publisher"));
        publisher.publish(bytes).expect("publish");
    }
}

impl PoseFixture for BusFixture {
    fn expected(&self) -> Expected {
        Expected { kind: "bus", on_the_bus: true, rejects_jumps: false, garbage: Garbage::Counted }
    }

    fn emit_garbage(&mut self, robot: u32) {
        self.publish(robot, &[0xff, 0x00, 0x13]);
    }

    fn source(&mut self) -> (Box<dyn PoseSource>, Swarm) {
        (Box::new(BusPoses::new(Rc::clone(&self.bus), self.swarm, 3).expect("pose fan-in")), self.swarm)
    }

    fn emit(&mut self, robot: u32, pose: &Pose) {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        let bytes = encode(pose, &mut buf).expect("encode").to_vec();
        self.publish(robot, &bytes);
    }

    fn tolerance(&self) -> f64 {
        0.0
    }
}

#[test]
fn bus_poses_pass_the_suite() {
    let report = run_all(&mut BusFixture::new());
    assert_eq!(report.not_applicable(), Vec::<&str>::new(), "{report:?}");
}

#[test]
fn bus_poses_record_and_count_garbage_and_go_on() {
    let mut fixture = BusFixture::new();
    let (mut source, swarm) = fixture.source();
    assert!(source.on_the_bus(), "the bus source records raw bytes itself");
    source.open_robot(1).expect("open");
    fixture.publish(1, &[0xff, 0x00, 0x13]);
    let good = Pose { robot: RobotId(1), x: 1.5, y: 2.5, heading: 0.0, step: 7, time_us: 700_000 };
    fixture.emit(1, &good);
    let (mut recording, mut traffic, mut got) = (Recording::off(), Traffic::default(), Vec::new());
    let mut sink = PoseSink::new(&mut recording, &mut traffic, &swarm, &mut got, false);
    source.drain(&mut sink).expect("garbage is not fatal");
    assert_eq!(sink.recorded(), 2, "the garbage is recorded byte for byte too");
    assert_eq!(got, [(1, good)], "the pose after the garbage still arrives");
    assert_eq!(traffic.total(), 1, "counted as bad traffic: {traffic:?}");
}

#[test]
fn bus_poses_refuse_a_respelled_pose_as_bad_traffic() {
    // The same pose as `good`, its robot id spelled `81 00` instead of `01`:
    // one message has one encoding, so it is garbage, not a second copy.
    let mut fixture = BusFixture::new();
    let (mut source, swarm) = fixture.source();
    source.open_robot(1).expect("open");
    let good = Pose { robot: RobotId(1), x: 1.5, y: 2.5, heading: 0.0, step: 7, time_us: 700_000 };
    let mut buf = [0u8; MAX_MESSAGE_LEN];
    let canonical = encode(&good, &mut buf).expect("encode").to_vec();
    assert_eq!(&canonical[..2], [3, 1], "version 3, robot 1");
    let respelled = [&[3, 0x81, 0x00], &canonical[2..]].concat();
    fixture.publish(1, &respelled);
    let (mut recording, mut traffic, mut got) = (Recording::off(), Traffic::default(), Vec::new());
    let mut sink = PoseSink::new(&mut recording, &mut traffic, &swarm, &mut got, false);
    source.drain(&mut sink).expect("garbage is not fatal");
    assert_eq!(got, [], "the respelled pose is not delivered");
    assert_eq!((traffic.garbage, traffic.total()), (1, 1), "counted as undecodable: {traffic:?}");
}

/// OptiTrack NatNet: a scripted NatNet server on loopback answers the
/// client's connect and model-definition requests, then sends one frame per
/// emitted pose (frame number = the pose's step; the body's Motive pose is
/// the arena pose mapped back: X = x, Z = −y, yaw about Y = heading).
struct NatNetFixture {
    socket: std::net::UdpSocket,
    client: std::sync::Arc<std::sync::Mutex<Option<std::net::SocketAddr>>>,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

mod natnet_fixture {
    use bycoms_natnet_server::{model_definitions, BodyConfig, Faults, ServerConfig};
    use bycoms_protocol::natnet::{encode_packet, parse_packet, Packet, ServerInfo, Version};

    pub fn server_info() -> Packet {
        Packet::ServerInfo(ServerInfo {
            app_name: "suite".into(),
            app_version: [1, 0, 0, 0],
            natnet_version: [4, 1, 0, 0],
            clock_frequency: 1_000_000,
            data_port: 0,
            multicast: false,
            multicast_group: [0; 4],
        })
    }

    pub fn defs() -> Packet {
        let bodies = (1..=3)
            .map(|k| BodyConfig { name: format!("robot{k}"), id: 100 + k, position: [0.0; 3], yaw_deg: 0.0 })
            .collect();
        let config = ServerConfig {
            rate_hz: 120.0,
            app_name: "suite".into(),
            multicast: None,
            bodies,
            faults: Faults::default(),
        };
        Packet::ModelDef(model_definitions(&config))
    }

    pub fn reply(request: &[u8]) -> Option<Vec<u8>> {
        match parse_packet(request).ok()? {
            Packet::Connect(_) => encode_packet(&server_info(), Version::V4_1).ok(),
            Packet::RequestModelDef => encode_packet(&defs(), Version::V4_1).ok(),
            _ => None,
        }
    }
}

impl NatNetFixture {
    fn new() -> Self {
        let socket = std::net::UdpSocket::bind("127.0.0.1:0").expect("bind");
        socket.set_read_timeout(Some(Duration::from_millis(20))).expect("timeout");
        let client = std::sync::Arc::new(std::sync::Mutex::new(None));
        let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let (sock, who, halt) = (socket.try_clone().expect("clone"), client.clone(), stop.clone());
        let thread = std::thread::spawn(move || {
            let mut buf = [0u8; 2048];
            while !halt.load(std::sync::atomic::Ordering::Relaxed) {
                let Ok((n, from)) = sock.recv_from(&mut buf) else { continue };
                if let Some(bytes) = natnet_fixture::reply(&buf[..n]) {
                    *who.lock().expect("lock") = Some(from);
                    sock.send_to(&bytes, from).expect("reply");
                }
            }
        });
        Self { socket, client, stop, thread: Some(thread) }
    }
}

impl Drop for NatNetFixture {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl PoseFixture for NatNetFixture {
    /// A datagram that is not NatNet is dropped and counted by the client
    /// (`NatNetClient::bad_packets`, warned about), not handed to the
    /// sink's `bad`: the launch's traffic counters do not see it.
    fn expected(&self) -> Expected {
        Expected { kind: "natnet", on_the_bus: false, rejects_jumps: true, garbage: Garbage::DroppedBySource }
    }

    fn emit_garbage(&mut self, _robot: u32) {
        let to = self.client.lock().expect("lock").expect("the client connected");
        self.socket.send_to(&[0xff, 0x00, 0x13], to).expect("send");
    }

    fn source(&mut self) -> (Box<dyn PoseSource>, Swarm) {
        use bycoms_launch::poses::mocap::NatNetPoses;
        use bycoms_mocap::{
            ArenaTransform, ClientConfig, NatNetPoseSource, NatNetSourceConfig, TrackerConfig,
        };
        let config = NatNetSourceConfig {
            client: ClientConfig {
                server: self.socket.local_addr().expect("addr"),
                local: std::net::Ipv4Addr::LOCALHOST.into(),
                multicast: None,
                reply_timeout_ms: 1000,
            },
            arena: ArenaTransform::default(),
            bodies: (1..=3).map(|k| (format!("robot{k}"), RobotId(k))).collect(),
            // Fast enough for every plausible move of the suite (steps 0.1 s
            // apart), far too slow for its kilometre jumps (identity swaps).
            tracker: TrackerConfig { max_speed: 1000.0, jump_slack: 1.0, lost_after_us: 10_000_000 },
        };
        let source = NatNetPoseSource::connect(&config).expect("connect");
        let poses = NatNetPoses::new(source);
        (Box::new(poses), Swarm::new("suite").expect("swarm"))
    }

    fn emit(&mut self, robot: u32, pose: &Pose) {
        use bycoms_natnet_server::BodyPose;
        use bycoms_protocol::natnet::{encode_packet, FrameOfData, Packet, RigidBody, Version};
        let body = BodyPose::yawed([pose.x as f32, 0.0, -pose.y as f32], pose.heading as f32);
        let mut frame = FrameOfData { frame_number: pose.step as i32, ..FrameOfData::default() };
        frame.rigid_bodies.push(RigidBody {
            id: 100 + robot as i32,
            position: body.position,
            orientation: body.orientation,
            mean_error: 0.0001,
            params: 1,
        });
        frame.suffix.timestamp = pose.time_us as f64 * 1e-6;
        let bytes = encode_packet(&Packet::FrameOfData(frame), Version::V4_1).expect("encode");
        let to = self.client.lock().expect("lock").expect("the client connected");
        self.socket.send_to(&bytes, to).expect("send");
    }

    fn tolerance(&self) -> f64 {
        1e-5 * 30.0 // f32 on the wire
    }
}

#[test]
fn natnet_poses_pass_the_suite() {
    let report = run_all(&mut NatNetFixture::new());
    assert_eq!(report.not_applicable(), Vec::<&str>::new(), "{report:?}");
}

#[test]
fn natnet_poses_record_the_model_definitions_and_every_frame() {
    let mut fixture = NatNetFixture::new();
    let (mut source, swarm) = fixture.source();
    source.open_robot(1).expect("open");
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("natnet.mcap");
    let mut recording = Recording::create(&path).expect("recording");
    let (mut traffic, mut got) = (Traffic::default(), Vec::new());
    for k in 1..=4 {
        fixture.emit(
            1,
            &Pose { robot: RobotId(1), x: k as f64, y: 2.0, heading: 0.5, step: k, time_us: k * 100_000 },
        );
    }
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    while got.len() < 4 && std::time::Instant::now() < deadline {
        let mut sink = PoseSink::new(&mut recording, &mut traffic, &swarm, &mut got, true);
        source.drain(&mut sink).expect("drain");
        // Polled: a pose source is drained without waiting; it has no event
        // to block on.
        std::thread::sleep(Duration::from_millis(5));
    }
    assert_eq!(got.len(), 4, "{got:?}");
    recording.finish().expect("finish");
    let counts = bycoms_record::read_counts(&path).expect("read back");
    assert_eq!(counts.get("bycoms/suite/mocap/natnet_modeldef"), Some(&1), "{counts:?}");
    assert_eq!(counts.get("bycoms/suite/mocap/natnet"), Some(&4), "{counts:?}");
    assert_eq!(counts.get("bycoms/suite/robot/1/pose"), Some(&4), "the trusted poses: {counts:?}");
}

/// Replay: poses fed through the source's channel as a reader would.
struct ReplayFixture {
    feed: Option<std::sync::mpsc::Sender<Pose>>,
}

impl PoseFixture for ReplayFixture {
    fn expected(&self) -> Expected {
        Expected { kind: "replay", on_the_bus: false, rejects_jumps: false, garbage: Garbage::CannotArrive }
    }

    fn emit_garbage(&mut self, _robot: u32) {
        unreachable!("only decoded poses can be fed to a replay")
    }

    fn source(&mut self) -> (Box<dyn PoseSource>, Swarm) {
        let (tx, source) = bycoms_orchestrator::replay::ReplayPoseSource::channel();
        self.feed = Some(tx);
        (Box::new(source), Swarm::new("suite").expect("swarm"))
    }

    fn emit(&mut self, _robot: u32, pose: &Pose) {
        self.feed.as_ref().expect("source made").send(*pose).expect("feed");
    }

    fn tolerance(&self) -> f64 {
        0.0
    }
}

#[test]
fn replayed_poses_pass_the_suite() {
    let report = run_all(&mut ReplayFixture { feed: None });
    assert_eq!(report.not_applicable(), ["what_a_source_cannot_use_is_never_fatal"], "{report:?}");
}

/// A ROS 2 motion-capture driver: each emitted pose is put as a
/// `geometry_msgs/msg/PoseStamped` (Z up, metres = arena units, the pose's
/// time as its stamp) on its robot's topic's rmw_zenoh key, with an
/// rmw_zenoh attachment, on the same zenoh session the source subscribes
/// on (zenoh delivers a session's own puts to its subscribers: no network).
struct Ros2Fixture {
    session: zenoh::Session,
    publishers: BTreeMap<u32, bycoms_ros2::rmw_zenoh::Publisher>,
}

impl Ros2Fixture {
    fn new() -> Self {
        use bycoms_protocol::bus::zenoh::{Mode, ZenohBus};
        let config = bycoms_runtime::zenoh_config(Mode::Peer, Vec::new(), Vec::new(), None);
        let session = ZenohBus::open(config).expect("zenoh session").session().clone();
        Self { session, publishers: BTreeMap::new() }
    }

    fn topic(robot: u32) -> String {
        format!("/mocap/robot{robot}/pose")
    }

    fn put(&mut self, robot: u32, cdr: Vec<u8>) {
        use bycoms_ros2::msgs::{PoseStamped, RosMessage};
        use bycoms_ros2::rmw_zenoh::{Endpoint, EntityKind, Node, Publisher, Qos};
        use zenoh::Wait;
        let session = &self.session;
        let publisher = self.publishers.entry(robot).or_insert_with(|| {
            let node = Node {
                domain_id: 0,
                zid: "d0d0".into(),
                id: 0,
                enclave: "/".into(),
                namespace: "/".into(),
                name: "driver".into(),
            };
            let endpoint = Endpoint {
                id: u64::from(robot),
                kind: EntityKind::Publisher,
                topic: Self::topic(robot),
                ros_type: PoseStamped::DESCRIPTION.name.into(),
                type_hash: PoseStamped::DESCRIPTION.rihs01(),
                qos: Qos::best_effort(1),
            };
            Publisher::new(&node, &endpoint).expect("publisher")
        });
        let attachment = publisher.next_attachment(1_700_000_000_000_000_000).encode().to_vec();
        session.put(publisher.key_expr.as_str(), cdr).attachment(attachment).wait().expect("put");
    }
}

impl PoseFixture for Ros2Fixture {
    fn expected(&self) -> Expected {
        Expected { kind: "ros2", on_the_bus: false, rejects_jumps: true, garbage: Garbage::Counted }
    }

    fn emit_garbage(&mut self, robot: u32) {
        self.put(robot, vec![0x00, 0x01, 0x00, 0x00, 0x13]);
    }

    fn source(&mut self) -> (Box<dyn PoseSource>, Swarm) {
        use bycoms_launch::poses::ros2::Ros2Poses;
        use bycoms_launch::ros2::Ros2Config;
        use bycoms_mocap::{ArenaTransform, Ros2MocapConfig, TrackerConfig, UpAxis};
        let config = Ros2MocapConfig {
            topics: (1..=3).map(|k| (Self::topic(k), RobotId(k))).collect(),
            arena: ArenaTransform { up: UpAxis::Z, origin: [0.0; 3], scale: 1.0 },
            // As NatNet's fixture: every plausible move passes, a kilometre jump does not.
            tracker: TrackerConfig { max_speed: 1000.0, jump_slack: 1.0, lost_after_us: 10_000_000 },
            graph_timeout: 5.0,
        };
        let source = Ros2Poses::open(&config, &Ros2Config::default(), &self.session).expect("subscribe");
        (Box::new(source), Swarm::new("suite").expect("swarm"))
    }

    fn emit(&mut self, robot: u32, pose: &Pose) {
        use bycoms_ros2::msgs::{Header, Point, Pose as RosPose, PoseStamped, Quaternion, RosMessage, Time};
        let stamp = Time::from_nanos(1_700_000_000_000_000_000 + pose.time_us as i64 * 1000);
        let msg = PoseStamped {
            header: Header { stamp, frame_id: "world".into() },
            pose: RosPose {
                position: Point { x: pose.x, y: pose.y, z: 0.2 },
                orientation: Quaternion::from_yaw(pose.heading),
            },
        };
        self.put(robot, msg.to_cdr());
    }

    fn tolerance(&self) -> f64 {
        1e-9 // the heading, through a quaternion and back
    }
}

#[test]
fn ros2_poses_pass_the_suite() {
    let report = run_all(&mut Ros2Fixture::new());
    assert_eq!(report.not_applicable(), Vec::<&str>::new(), "{report:?}");
}

/// A mixed swarm's poses (`MergedPoses`): robots 1 and 2 real, seen by
/// motion capture (a replay's channel stands for it), robot 3 simulated,
/// its poses on the (in-memory) bus. The suite's robots 1 and 2 come from
/// the motion capture; robot 3, never opened by the suite, is not handed.
struct MergedFixture {
    replay: ReplayFixture,
    bus: BusFixture,
}

impl MergedFixture {
    fn new() -> Self {
        Self { replay: ReplayFixture { feed: None }, bus: BusFixture::new() }
    }

    fn merged(&mut self) -> MergedPoses {
        let (mocap, _) = self.replay.source();
        let bus = BusPoses::new(Rc::clone(&self.bus.bus), self.bus.swarm, 3).expect("pose fan-in");
        MergedPoses::new(mocap, bus, vec![3])
    }
}

impl PoseFixture for MergedFixture {
    fn expected(&self) -> Expected {
        Expected { kind: "mixed", ..self.replay.expected() }
    }

    fn emit_garbage(&mut self, _robot: u32) {
        unreachable!("only decoded poses reach the real robots' motion capture here")
    }

    fn source(&mut self) -> (Box<dyn PoseSource>, Swarm) {
        (Box::new(self.merged()), self.bus.swarm)
    }

    fn emit(&mut self, robot: u32, pose: &Pose) {
        match robot {
            3 => self.bus.emit(robot, pose),
            _ => self.replay.emit(robot, pose),
        }
    }

    fn tolerance(&self) -> f64 {
        0.0
    }
}

#[test]
fn merged_poses_pass_the_suite() {
    let report = run_all(&mut MergedFixture::new());
    assert_eq!(report.not_applicable(), ["what_a_source_cannot_use_is_never_fatal"], "{report:?}");
}

/// Both halves at once: the simulated robot's poses come from the bus and
/// are recorded byte for byte, once; the real ones' from motion capture,
/// recorded decoded, once; all handed robots in id order.
#[test]
fn merged_poses_hand_both_kinds_in_robot_order_each_recorded_once() {
    let mut fixture = MergedFixture::new();
    let mut source = fixture.merged();
    assert!(!source.on_the_bus(), "the motion capture's poses are recorded by the sink");
    for id in 1..=3 {
        source.open_robot(id).expect("open");
    }
    let at = |robot: u32, step: u64| Pose {
        robot: RobotId(robot),
        x: f64::from(robot),
        y: step as f64,
        heading: 0.0,
        step,
        time_us: step * 100_000,
    };
    fixture.emit(3, &at(3, 1));
    fixture.emit(2, &at(2, 1));
    fixture.emit(1, &at(1, 1));
    fixture.emit(3, &at(3, 2));
    let (mut recording, mut traffic, mut got) = (Recording::off(), Traffic::default(), vec![(9, at(9, 9))]);
    let mut sink = PoseSink::new(&mut recording, &mut traffic, &fixture.bus.swarm, &mut got, true);
    source.drain(&mut sink).expect("drained");
    let recorded = sink.recorded();
    let numbered = sink.numbers().len();
    assert_eq!((recorded, numbered), (4, 4), "each pose recorded once, raw or decoded");
    let order: Vec<(u32, u64)> = got.iter().skip(1).map(|(r, p)| (*r, p.step)).collect();
    assert_eq!(order, [(1, 1), (2, 1), (3, 1), (3, 2)], "robots in id order, each in its order");
    assert_eq!(got[0].0, 9, "what the engine held before the drain stays first");
    assert_eq!(traffic.total(), 0);
}
