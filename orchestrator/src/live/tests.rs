//! The live view without a launch: its state, its front's request
//! classification, and a real server on port 0 read by a Foxglove-protocol
//! client (tungstenite) and by plain HTTP.

use super::front::{classify, Request};
use super::state::{LiveState, RobotState, TRAIL_STEP};
use super::{state_topic, world_topic, LiveView};
use bycoms_launch::core::SlotState;
use bycoms_launch::observe::Observer;
use bycoms_launch::{LaunchConfig, World};
use bycoms_protocol::msg::{GateEvent, GateKind, Pose};
use bycoms_protocol::RobotId;
use bycoms_record::scene::json::{BeaconAt, GateDecision, RobotPose, RobotSlot};
use bycoms_record::scene::{Scene, SceneWorld, SharedScene};
use foxglove::messages::SceneUpdate;
use foxglove::Decode;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};
use tungstenite::client::IntoClientRequest;
use tungstenite::Message;

fn pose(robot: u32, x: f64, y: f64, step: u64) -> Pose {
    Pose { robot: RobotId(robot), x, y, heading: 0.5, step, time_us: step * 100_000 }
}

fn event(robot: u32, kind: GateKind, x: f64, y: f64) -> GateEvent {
    GateEvent { robot: RobotId(robot), kind, x, y, step: 7 }
}

/// A pose as the scene hands it on.
fn seen(robot: u32, x: f64, y: f64, step: u64) -> RobotPose {
    RobotPose::from(&pose(robot, x, y, step))
}

/// A gate event as the scene hands it on.
fn decided(robot: u32, kind: GateKind, x: f64, y: f64) -> GateDecision {
    GateDecision::from(&event(robot, kind, x, y))
}

fn world() -> World {
    World::tiny()
}

/// An observer fed as a launch feeds a live view: what the run's one scene
/// made of each message.
struct Fed {
    tap: Box<dyn Observer>,
    scene: SharedScene,
}

impl Fed {
    fn new(tap: Box<dyn Observer>, world: &World, cfg: &LaunchConfig) -> Self {
        let terrain = world.terrain.clone();
        let scene = SharedScene::new(Scene::new(
            "t",
            SceneWorld { terrain, eps: cfg.eps, goal_radius: 0.5, real: Vec::new() },
        ));
        let mut fed = Self { tap, scene };
        fed.tap.world("t", world, cfg, Some(&fed.scene));
        let outs = fed.scene.lock().world(1);
        fed.tap.scene(&outs);
        fed
    }

    fn pose(&mut self, p: &Pose) {
        let outs = self.scene.lock().pose(p, 2);
        self.tap.scene(&outs);
    }

    fn gate(&mut self, e: &GateEvent) {
        let outs = self.scene.lock().gate(e, 3);
        self.tap.scene(&outs);
    }

    fn beacon(&mut self, robot: u32, x: f64, y: f64) {
        let outs = self.scene.lock().beacon(robot, bycoms_sim::Vec2::new(x, y), 3);
        self.tap.scene(&outs);
    }

    fn state(&mut self, robot: u32, state: SlotState) {
        let outs = self.scene.lock().state(robot, state, 3);
        self.tap.scene(&outs);
    }
}

/// A state change as the scene hands it on.
fn slot(robot: u32, state: SlotState) -> RobotSlot {
    RobotSlot { robot, state }
}

#[test]
fn the_state_follows_poses_and_the_gate() {
    let mut s = LiveState::default();
    s.pose(&seen(2, 1.0, 1.0, 0));
    s.pose(&seen(1, 0.5, 0.5, 0));
    assert_eq!(s.robots.iter().map(|r| r.id).collect::<Vec<_>>(), [1, 2], "id order");
    // A small move is not a trail point; a move of TRAIL_STEP is.
    s.pose(&seen(1, 0.5 + TRAIL_STEP / 2.0, 0.5, 1));
    s.pose(&seen(1, 0.5 + TRAIL_STEP, 0.5, 2));
    assert_eq!(s.robots[0].trail, [[0.5, 0.5], [0.5 + TRAIL_STEP, 0.5]]);
    assert_eq!(s.robots[0].x, 0.5 + TRAIL_STEP);
    assert!(s.state(&slot(1, SlotState::Moving)), "a seen robot's state changed");
    s.gate(&decided(1, GateKind::Deployed, 0.5, 0.5));
    assert_eq!((s.robots[0].state, s.moving), (RobotState::Moving, Some(1)));
    s.state(&slot(1, SlotState::Stuck));
    s.gate(&decided(1, GateKind::Stopped { arrived: false }, 3.0, 4.0));
    assert_eq!((s.robots[0].state, s.moving), (RobotState::Stuck, None));
    assert_eq!((s.robots[0].x, s.robots[0].y), (3.0, 4.0), "where the gate stopped it");
    assert!(s.beacons.is_empty(), "the core tells its beacons");
    assert!(s.beacon(&BeaconAt { robot: 1, x: 3.0, y: 4.0 }), "a new beacon");
    assert_eq!((s.beacons.len(), s.beacons[0].x, s.beacons[0].y), (1, 3.0, 4.0));
    assert!(!s.beacon(&BeaconAt { robot: 1, x: 3.25, y: 4.0 }), "crept on");
    assert_eq!((s.beacons.len(), s.beacons[0].x), (1, 3.25), "in its place, where it crept to");
    s.state(&slot(2, SlotState::Moving));
    s.gate(&decided(2, GateKind::Deployed, 1.0, 1.0));
    s.state(&slot(2, SlotState::Died));
    s.gate(&decided(2, GateKind::Died, 1.5, 1.5));
    s.beacon(&BeaconAt { robot: 2, x: 1.5, y: 1.5 });
    s.state(&slot(3, SlotState::Moving));
    s.gate(&decided(3, GateKind::Deployed, 0.5, 0.5));
    s.state(&slot(3, SlotState::Arrived));
    s.gate(&decided(3, GateKind::Stopped { arrived: true }, 2.5, 2.5));
    let states: Vec<_> = s.robots.iter().map(|r| r.state).collect();
    assert_eq!(states, [RobotState::Stuck, RobotState::Lost, RobotState::Arrived]);
    assert_eq!((s.beacons.len(), s.gate_events), (2, 6), "stuck and lost robots are beacons");
    s.ended(true, "arrived");
    let j = serde_json::to_value(&s).unwrap();
    assert_eq!(j["ended"], json!({ "success": true, "verdict": "arrived" }));
    assert_eq!(j["robots"][1]["state"], "lost");
}

/// A robot's state is the core's word, not the gate's: a robot revoked
/// before its deployment (no gate decision about it) is lost on the page,
/// and one said lost before it was seen is listed lost when it is; a gate
/// decision alone changes no state.
#[test]
fn the_state_of_a_robot_is_the_cores() {
    let mut s = LiveState::default();
    s.pose(&seen(1, 0.5, 0.5, 0));
    assert!(!s.state(&slot(1, SlotState::Registered)), "deploying already");
    assert!(s.state(&slot(1, SlotState::Lost)), "revoked before its deployment");
    assert_eq!((s.robots[0].state, s.moving, s.gate_events), (RobotState::Lost, None, 0));
    assert!(!s.state(&slot(2, SlotState::Lost)), "not listed yet");
    s.pose(&seen(2, 1.0, 1.0, 0));
    assert_eq!(s.robots[1].state, RobotState::Lost);
    s.pose(&seen(3, 1.0, 1.0, 0));
    s.gate(&decided(3, GateKind::Deployed, 1.0, 1.0));
    assert_eq!((s.robots[2].state, s.moving), (RobotState::Deploying, None), "no state said");
    s.take(&[bycoms_record::scene::Out {
        topic: "bycoms/t/robot/3/state".into(),
        message: bycoms_record::scene::Message::State(slot(3, SlotState::Unfinished)),
    }]);
    assert_eq!(serde_json::to_value(&s).unwrap()["robots"][2]["state"], "timeout");
}

#[test]
fn the_front_tells_pages_from_upgrades() {
    let get = b"GET / HTTP/1.1\r\nHost: x\r\n\r\n";
    assert_eq!(classify(get).unwrap(), Some(Request::Page { head_only: false }));
    assert_eq!(classify(b"GET / HTTP/1.1\r\nHost: x\r\n").unwrap(), None, "incomplete head");
    let ws = b"GET / HTTP/1.1\r\nHost: x\r\nConnection: Upgrade\r\nUpgrade: WebSocket\r\n\
               Sec-WebSocket-Protocol: x, foxglove.sdk.v1.1\r\n\r\n";
    assert_eq!(classify(ws).unwrap(), Some(Request::Upgrade));
    let old =
        b"GET / HTTP/1.1\r\nUpgrade: websocket\r\nSec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n";
    assert_eq!(classify(old).unwrap(), Some(Request::NoSubprotocol));
    let none = b"GET / HTTP/1.1\r\nUpgrade: websocket\r\n\r\n";
    assert_eq!(classify(none).unwrap(), Some(Request::NoSubprotocol));
    assert_eq!(
        classify(b"HEAD /index.html?x=1 HTTP/1.1\r\n\r\n").unwrap(),
        Some(Request::Page { head_only: true })
    );
    assert_eq!(classify(b"GET /etc/passwd HTTP/1.1\r\n\r\n").unwrap(), Some(Request::NotFound));
    assert_eq!(classify(b"POST / HTTP/1.1\r\n\r\n").unwrap(), Some(Request::BadMethod));
    assert!(classify(b"\x16\x03\x01 not http\r\n\r\n").is_err());
}

fn http(addr: SocketAddr, request: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    out
}

type Ws = tungstenite::WebSocket<TcpStream>;

fn foxglove_client(addr: SocketAddr) -> Ws {
    let mut req = format!("ws://{addr}/").into_client_request().unwrap();
    req.headers_mut().insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1".parse().unwrap());
    let stream = TcpStream::connect(addr).unwrap();
    stream.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let (ws, response) = tungstenite::client(req, stream).unwrap();
    let protocol = response.headers().get("sec-websocket-protocol").map(|v| v.to_str().unwrap().to_owned());
    assert_eq!(protocol.as_deref(), Some("foxglove.sdk.v1"));
    ws
}

/// Reads messages until `want` accepts one (5 s per read, 10 s in all).
fn next<T>(ws: &mut Ws, mut want: impl FnMut(&Message) -> Option<T>) -> T {
    let deadline = Instant::now() + Duration::from_secs(10);
    while Instant::now() < deadline {
        let msg = ws.read().expect("a message within 5 s");
        if let Some(v) = want(&msg) {
            return v;
        }
    }
    panic!("no wanted message within 10 s");
}

/// A message-data frame's subscription id and payload.
fn payload(msg: &Message) -> Option<(u32, Vec<u8>)> {
    let Message::Binary(b) = msg else { return None };
    if b.len() < 13 || b[0] != 1 {
        return None;
    }
    let sub = u32::from_le_bytes(b[1..5].try_into().ok()?);
    Some((sub, b[13..].to_vec()))
}

#[test]
fn one_port_serves_the_page_and_the_foxglove_stream() {
    let live = LiveView::start("127.0.0.1:0").unwrap();
    let addr = live.local_addr();
    assert_ne!(addr.port(), 0, "port 0 becomes a real port");
    let cfg = LaunchConfig { eps: 2.0, ..LaunchConfig::default() };
    let mut tap = Fed::new(Box::new(live.clone()), &world(), &cfg);
    tap.pose(&pose(1, 0.5, 0.5, 0));
    tap.state(1, SlotState::Moving);
    tap.gate(&event(1, GateKind::Deployed, 0.5, 0.5));

    let page = http(addr, "GET / HTTP/1.1\r\nHost: t\r\n\r\n");
    assert!(page.starts_with("HTTP/1.1 200 OK"), "{page:.200}");
    assert!(page.contains("foxglove.sdk.v1") && page.ends_with("</html>\n"), "the whole page");
    assert!(http(addr, "GET /nope HTTP/1.1\r\n\r\n").starts_with("HTTP/1.1 404"));

    // A viewer that connects now gets the channels, then the world and the
    // state so far as soon as it subscribes.
    let mut ws = foxglove_client(addr);
    let channels: BTreeMap<String, u64> = next(&mut ws, |m| {
        let Message::Text(t) = m else { return None };
        let j: Value = serde_json::from_str(t).ok()?;
        (j["op"] == "advertise").then(|| {
            j["channels"]
                .as_array()
                .unwrap()
                .iter()
                .map(|c| (c["topic"].as_str().unwrap().to_owned(), c["id"].as_u64().unwrap()))
                .collect()
        })
    });
    let (world_t, state_t, pose_t, scene_t) = (
        world_topic("t"),
        state_topic("t"),
        "bycoms/t/robot/1/pose/json".to_owned(),
        "bycoms/t/scene".to_owned(),
    );
    for topic in [&world_t, &state_t, &pose_t, &scene_t, &"bycoms/t/gate/json".to_owned()] {
        assert!(channels.contains_key(topic), "{topic} advertised: {channels:?}");
    }
    let subscriptions: Vec<Value> = [&world_t, &state_t, &pose_t, &scene_t]
        .iter()
        .enumerate()
        .map(|(i, t)| json!({ "id": i + 1, "channelId": channels[*t] }))
        .collect();
    ws.send(Message::text(json!({ "op": "subscribe", "subscriptions": subscriptions }).to_string())).unwrap();
    // The 3D scene so far comes as SceneUpdates (the world, then the
    // robots), decoded here as Foxglove decodes them.
    let mut got: BTreeMap<u32, Vec<u8>> = BTreeMap::new();
    let mut entities: Vec<String> = Vec::new();
    next(&mut ws, |m| {
        let (sub, bytes) = payload(m)?;
        if sub == 4 {
            let scene = <SceneUpdate as Decode>::decode(bytes.as_slice()).expect("a SceneUpdate");
            entities.extend(scene.entities.into_iter().map(|e| e.id));
        } else {
            got.insert(sub, bytes);
        }
        (got.len() == 2 && entities.iter().any(|e| e == "robot/1")).then_some(())
    });
    for id in ["arena", "terrain", "start", "goal", "robot/1"] {
        assert!(entities.iter().any(|e| e == id), "{id} in the snapshot: {entities:?}");
    }
    let json_of = |b: &[u8]| serde_json::from_slice::<Value>(b).expect("JSON payload");
    let (w, state) = (json_of(&got[&1]), json_of(&got[&2]));
    assert_eq!(w["rows"], json!(["..G", ".#.", "S.."]));
    assert_eq!((w["eps"].as_f64(), w["width"].as_u64()), (Some(2.0), Some(3)));
    assert_eq!(state["moving"], 1, "the state so far: {state}");
    // Live: a pose and a stop as they happen.
    tap.pose(&pose(1, 1.5, 0.5, 1));
    let p = next(&mut ws, |m| payload(m).filter(|(s, _)| *s == 3).map(|(_, b)| json_of(&b)));
    assert_eq!((p["robot"].as_u64(), p["x"].as_f64()), (Some(1), Some(1.5)));
    tap.state(1, SlotState::Stuck);
    tap.gate(&event(1, GateKind::Stopped { arrived: false }, 1.5, 0.5));
    tap.beacon(1, 1.5, 0.5);
    let with_beacon = |(_, b): (u32, Vec<u8>)| Some(json_of(&b)).filter(|s| s["beacons"] != json!([]));
    let state = next(&mut ws, |m| payload(m).filter(|(s, _)| *s == 2).and_then(with_beacon));
    assert_eq!(state["beacons"], json!([{ "robot": 1, "x": 1.5, "y": 0.5 }]));
    assert_eq!(state["robots"][0]["state"], "stuck");
    drop(tap);
    live.shutdown();
    assert!(TcpStream::connect(addr).is_err(), "the port is closed after shutdown");
}

#[test]
fn a_busy_address_is_a_clear_error() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap().to_string();
    let err = LiveView::start(&addr).err().expect("bind fails");
    assert!(err.to_string().contains(&addr), "{err}");
}

/// A WebSocket upgrade request for `/` offering `protocols`.
fn upgrade(protocols: Option<&str>) -> String {
    let offer = protocols.map(|p| format!("Sec-WebSocket-Protocol: {p}\r\n")).unwrap_or_default();
    format!(
        "GET / HTTP/1.1\r\nHost: t\r\nConnection: Upgrade\r\nUpgrade: websocket\r\n\
         Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n{offer}\r\n"
    )
}

/// The response head to `request` (up to its blank line).
fn response_head(addr: SocketAddr, request: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut out = Vec::new();
    let mut byte = [0u8; 1];
    while !out.ends_with(b"\r\n\r\n") {
        match s.read(&mut byte) {
            Ok(1) => out.push(byte[0]),
            _ => break,
        }
    }
    let mut rest = String::new();
    if !out.starts_with(b"HTTP/1.1 101") {
        let _ = s.read_to_string(&mut rest);
    }
    String::from_utf8_lossy(&out).into_owned() + &rest
}

#[test]
fn a_client_of_the_old_subprotocol_name_gets_a_refusal_that_says_what_is_served() {
    let live = LiveView::start("127.0.0.1:0").unwrap();
    let addr = live.local_addr();
    for offered in [Some("foxglove.websocket.v1"), None] {
        let refused = response_head(addr, &upgrade(offered));
        assert!(refused.starts_with("HTTP/1.1 400 Bad Request"), "{offered:?}: {refused}");
        assert!(
            refused.contains("foxglove.sdk.v1 or foxglove.sdk.v1.1")
                && refused.contains("foxglove.websocket.v1"),
            "names what is served and what is not: {refused}"
        );
    }
    let accepted = response_head(addr, &upgrade(Some("foxglove.websocket.v1, foxglove.sdk.v1")));
    assert!(accepted.starts_with("HTTP/1.1 101"), "{accepted}");
    assert!(accepted.to_ascii_lowercase().contains("sec-websocket-protocol: foxglove.sdk.v1"), "{accepted}");
    live.shutdown();
}

/// The page's world names the robots with a real body: a mixed swarm's
/// real members (robot 2 here), none for simulated agents.
#[test]
fn the_world_view_names_the_robots_with_a_real_body() {
    use super::state::WorldView;
    let arena = bycoms_launch::SimArena {
        terrain_text: String::new(),
        cell: 0.02,
        robot_speed: 0.22,
        members: vec![1, 3],
    };
    let mixed = World { simulated: Some(arena), ..world() };
    let mut cfg = LaunchConfig { robots: 3, ..LaunchConfig::default() };
    assert!(WorldView::new(&mixed, &cfg).real.is_empty(), "spawned agents simulate every robot");
    cfg.agents.source = bycoms_launch::config::AgentSourceKind::Real;
    assert_eq!(WorldView::new(&mixed, &cfg).real, [2]);
    assert_eq!(WorldView::new(&world(), &cfg).real, [1, 2, 3], "a lab's robots are all real");
}
