//! The run as ROS 2 messages, computed once: which topics there are (name,
//! type, QoS) and, for each thing the run does, which CDR message goes on
//! which topic at which run time. Where they go is a [`Sink`]'s business:
//! the live graph over rmw_zenoh (`super::Ros2Bridge`) or a rosbag2 MCAP
//! file ([`super::bag`]); both are fed by this one publisher, so the bag and
//! the live graph cannot differ.
//!
//! Topics (`<ns>` is the configured namespace): `/clock`, `/tf`,
//! `<ns>/map` (the terrain), `/tf_static` (the static frames:
//! [`super::static_frames`]) and `<ns>/beacons` (each beacon and its ε
//! circle), these three latched (transient local, depth 1: each message is
//! the whole state, so the last one is what a late joiner needs; their
//! publishers answer late joiners, `bycoms_runtime::ros2`), `/diagnostics` (real
//! robots: battery, link, failsafe, from the gateway's reports), `<ns>/gate`
//! (`bycoms_msgs/msg/GateEvent`, each gate decision), and per robot
//! `<ns>/robot_<k>/pose`, `<ns>/robot_<k>/path` and `<ns>/robot_<k>/state`
//! (`bycoms_msgs/msg/RobotState`: waiting at the start, then each time its
//! state changes, [`ros_state`]). A bag (never the live graph: the robots' own
//! agents publish there) has one more topic per ROS 2 robot: its `cmd_vel`,
//! with the commands its agent reported ([`RunMessages::with_cmd_vel`]).
//!
//! States are the run's view's ([`RunView`], the one fold of the launch
//! core's outputs every renderer reads): each robot's state as the core
//! said it (`Output::State`, [`RunMessages::state`]), so a robot revoked or
//! lost before its deployment is `LOST` as on the recording's scene and the
//! live view; a bag made from a recording older than `core/state` takes
//! the states its gate decisions imply
//! ([`RunMessages::without_states_told`]). A `RobotState` goes out when
//! its `state` field changes (the core's states before a deployment are
//! all `WAITING`).
//!
//! Beacons are the run view's too: where the core's beacon table
//! has each (`Output::Beacon`, [`RunMessages::beacon`]), creeping with it;
//! a bag made from a recording older than `core/beacon` places them where
//! the gate judged them ([`RunMessages::without_beacons_told`]). The
//! latched `<ns>/beacons` is sent again when a beacon appears, or once one
//! crept [`PATH_SPACING`] or more from where it was last sent.
//!
//! Paths cost: a `nav_msgs/msg/Path` holds the whole trail, so it is sent
//! at a bounded rate, at most once per [`PATH_PERIOD_US`] of run time per
//! robot (and once more when the robot stops), and the trail keeps a pose
//! only [`PATH_SPACING`] or more from the last one kept (its length grows
//! with the distance driven, not with the run's duration).

use std::collections::BTreeMap;

use bycoms_launch_core::view::{BeaconAt, RunView, Shown, SlotState, StateChange};
use bycoms_protocol::msg::{Commanded, FromAgent, GateEvent, GateKind, Pose};
use bycoms_record::schema::Ros2RobotTopic;
use bycoms_ros2::bycoms_msgs::{gate_kind, robot_state, GateEvent as RosGateEvent, RobotState};
use bycoms_ros2::display::{
    level, marker_action, marker_type, ColorRgba, DiagnosticArray, DiagnosticStatus, Marker, MarkerArray,
    OccupancyGrid,
};
use bycoms_ros2::msgs::{
    Clock, Header, Path, Point, Pose as RosPose, PoseStamped, Quaternion, RosMessage, TfMessage, Time,
    TransformStamped, Twist, TwistStamped, Vector3,
};
use bycoms_ros2::rmw_zenoh::Qos;
use bycoms_ros2::types::TypeDescription;
use bycoms_ros2::velocity::VelocityMessage;
use bycoms_sim::terrain::Terrain;
use bycoms_sim::Vec2;

use super::{ros_messages, run_time, static_frames, Ros2Config, WORLD_FRAME};

/// One topic of the run in the ROS 2 graph.
#[derive(Debug, Clone)]
pub struct Topic {
    /// Its fully qualified name (`/robot_1/pose`).
    pub name: String,
    /// Its type.
    pub description: &'static TypeDescription,
    /// The QoS it is offered with.
    pub qos: Qos,
}

/// Where the run's ROS 2 messages go.
pub trait Sink {
    /// One message on topic `topic` (its index in [`RunMessages::topics`])
    /// at `time_ns`, the run's time in nanoseconds.
    fn send(&mut self, topic: usize, time_ns: u64, cdr: &[u8]);
}

/// A path is sent at most once per this much run time per robot.
pub const PATH_PERIOD_US: u64 = 1_000_000;
/// A path keeps a pose this far (frame units) or more from the last one kept.
pub const PATH_SPACING: f64 = 0.1;
/// Real robots' diagnostics from telemetry: at most once per this much run time per robot.
pub const DIAGNOSTICS_PERIOD_US: u64 = 1_000_000;

const CLOCK: usize = 0;
const TF: usize = 1;
const MAP: usize = 2;
const BEACONS: usize = 3;
const DIAGNOSTICS: usize = 4;
const GATE: usize = 5;
const TF_STATIC: usize = 6;
/// Topics before the robots' own, [`PER_ROBOT`] each (pose, path, state).
const SHARED: usize = 7;
const PER_ROBOT: usize = 3;

/// A robot's trail and when its path was last sent.
#[derive(Default)]
struct Trail {
    last: Option<Pose>,
    path: Path,
    sent_us: Option<u64>,
    diagnostics_us: Option<u64>,
    /// The `RobotState.state` last sent.
    state_sent: Option<u8>,
}

/// A ROS 2 robot's `cmd_vel` in a bag.
struct CmdVel {
    topic: usize,
    message: VelocityMessage,
    frame_id: String,
}

/// The run as ROS 2 messages (see the module docs).
pub struct RunMessages {
    topics: Vec<Topic>,
    /// By robot: where its reported commands go (a bag's only).
    cmd_vel: BTreeMap<u32, CmdVel>,
    trails: Vec<Trail>,
    /// The run as the views show it: each robot's state, where each
    /// beacon stands.
    view: RunView,
    /// Where each beacon stood when `<ns>/beacons` was last sent.
    beacons_sent: BTreeMap<u32, Vec2>,
    eps: f64,
    now_us: u64,
    clock_us: Option<u64>,
    statics: Vec<TransformStamped>,
    /// The robots with a real body (`RobotState.real`).
    real: Vec<u32>,
}

impl RunMessages {
    /// The topics of a run of `robots` robots, nothing sent yet.
    pub fn new(cfg: &Ros2Config, robots: u32) -> Self {
        let ns = cfg.namespace.trim_end_matches('/');
        let topic = |name: String, description, qos| Topic { name, description, qos };
        let mut topics = vec![
            topic("/clock".into(), Clock::DESCRIPTION, Qos::reliable(10)),
            topic("/tf".into(), TfMessage::DESCRIPTION, Qos::reliable(10)),
            topic(format!("{ns}/map"), OccupancyGrid::DESCRIPTION, Qos::transient_local(1)),
            topic(format!("{ns}/beacons"), MarkerArray::DESCRIPTION, Qos::transient_local(1)),
            topic("/diagnostics".into(), DiagnosticArray::DESCRIPTION, Qos::reliable(10)),
            topic(format!("{ns}/gate"), RosGateEvent::DESCRIPTION, Qos::reliable(10)),
            // tf2's StaticTransformBroadcaster's QoS.
            topic("/tf_static".into(), TfMessage::DESCRIPTION, Qos::transient_local(1)),
        ];
        for k in 1..=robots {
            topics.push(topic(cfg.pose_topic(k), PoseStamped::DESCRIPTION, Qos::reliable(10)));
            topics.push(topic(format!("{ns}/robot_{k}/path"), Path::DESCRIPTION, Qos::reliable(10)));
            topics.push(topic(format!("{ns}/robot_{k}/state"), RobotState::DESCRIPTION, Qos::reliable(10)));
        }
        let trails = (0..robots).map(|_| Trail::default()).collect();
        let statics = static_frames(None);
        Self {
            topics,
            cmd_vel: BTreeMap::new(),
            trails,
            view: RunView::new(),
            beacons_sent: BTreeMap::new(),
            eps: 0.0,
            now_us: 0,
            clock_us: None,
            statics,
            real: Vec::new(),
        }
    }

    /// Of a recording older than `core/beacon`, which tells no beacon: a
    /// robot the gate judged stuck or lost is a beacon where it was judged
    /// ([`RunView::without_beacons`]).
    pub fn without_beacons_told(mut self) -> Self {
        self.view = RunView::without_beacons();
        self
    }

    /// Of a recording older than `core/state`, which tells no state: each
    /// gate decision sets the state it implies ([`RunView::without_states`]).
    pub fn without_states_told(mut self) -> Self {
        self.view = std::mem::take(&mut self.view).without_states();
        self
    }

    /// The robots with a real body (`lab::real_robots`, the run metadata's
    /// `real`): their `RobotState` says `real` (default: none).
    pub fn set_real(&mut self, real: Vec<u32>) {
        self.real = real;
    }

    /// The static frames `/tf_static` will carry (default:
    /// [`static_frames`] of no motion capture).
    pub fn set_static_frames(&mut self, frames: Vec<TransformStamped>) {
        self.statics = frames;
    }

    /// With one more topic per ROS 2 robot of `robots` (the run metadata's
    /// `ros2_robots`): its `cmd_vel`, of its message type, offered as its
    /// agent offers it (reliable, keep last 10), carrying each command its
    /// agent reported ([`Commanded`]). For a bag only: on the live graph
    /// the agents publish these themselves. A robot whose message is not
    /// `twist` or `twist-stamped` is left out, with a warning.
    pub fn with_cmd_vel(mut self, robots: &[Ros2RobotTopic]) -> Self {
        for r in robots {
            let message = match r.message.parse::<VelocityMessage>() {
                Ok(message) => message,
                Err(e) => {
                    tracing::warn!(robot = r.robot, "robot {}'s cmd_vel is left out: {e}", r.robot);
                    continue;
                }
            };
            let topic = self.topics.len();
            self.topics.push(Topic {
                name: r.cmd_vel.clone(),
                description: message.description(),
                qos: Qos::reliable(10),
            });
            self.cmd_vel.insert(r.robot, CmdVel { topic, message, frame_id: r.frame_id.clone() });
        }
        self
    }

    /// A reported command on its robot's `cmd_vel` (a bag with
    /// [`RunMessages::with_cmd_vel`]), at the run's time of the latest pose
    /// (the one it was computed from); a `TwistStamped` is stamped with it.
    fn commanded(&self, c: &Commanded, sink: &mut dyn Sink) {
        let Some(to) = self.cmd_vel.get(&c.robot.0) else { return };
        let (t, twist) = (self.now_us, Twist::planar(c.linear, c.angular));
        match to.message {
            VelocityMessage::Twist => self.send(sink, to.topic, t, &twist),
            VelocityMessage::TwistStamped => {
                let header = Header { stamp: run_time(t), frame_id: to.frame_id.clone() };
                self.send(sink, to.topic, t, &TwistStamped { header, twist });
            }
        }
    }

    /// Every topic, in the order [`Sink::send`] numbers them.
    pub fn topics(&self) -> &[Topic] {
        &self.topics
    }

    fn send<M: RosMessage>(&self, sink: &mut dyn Sink, topic: usize, time_us: u64, msg: &M) {
        sink.send(topic, time_us.saturating_mul(1_000), &msg.to_cdr());
    }

    /// The run's world: the terrain as the (latched) map and the static
    /// frames on `/tf_static` at time 0, and ε, the beacons' circles' radius.
    pub fn world(&mut self, terrain: &Terrain, eps: f64, sink: &mut dyn Sink) {
        self.eps = eps;
        self.send(sink, MAP, 0, &occupancy_grid(terrain));
        self.send(sink, TF_STATIC, 0, &TfMessage { transforms: self.statics.clone() });
        for index in 0..self.trails.len() {
            self.send_state(index, robot_state::WAITING, sink);
        }
    }

    /// Robot `robot`'s state changed to `state` (the launch core said so):
    /// its `RobotState`, if that changes what it says.
    pub fn state(&mut self, robot: u32, state: SlotState, sink: &mut dyn Sink) {
        self.view.take(&Shown::State(StateChange { robot, state }));
        self.send_state_of(robot, sink);
    }

    /// Robot `robot`'s `RobotState` with the view's state, unless it says
    /// what was last sent.
    fn send_state_of(&mut self, robot: u32, sink: &mut dyn Sink) {
        let Some(index) = (robot as usize).checked_sub(1).filter(|i| *i < self.trails.len()) else {
            return;
        };
        let state = ros_state(self.view.state(robot));
        if self.trails[index].state_sent != Some(state) {
            self.send_state(index, state, sink);
        }
    }

    fn send_state(&mut self, index: usize, state: u8, sink: &mut dyn Sink) {
        let t = self.now_us;
        self.trails[index].state_sent = Some(state);
        let last = self.trails[index].last;
        let robot = index as u32 + 1;
        let msg = RobotState {
            header: Header { stamp: run_time(t), frame_id: WORLD_FRAME.into() },
            robot,
            state,
            x: last.map_or(0.0, |p| p.x),
            y: last.map_or(0.0, |p| p.y),
            heading: last.map_or(0.0, |p| p.heading),
            step: last.map_or(0, |p| p.step),
            real: self.real.contains(&robot),
        };
        self.send(sink, SHARED + PER_ROBOT * index + 2, t, &msg);
    }

    /// A robot's pose: `/clock` when the run's time advanced, its pose, its
    /// transform on `/tf`, and its path when due.
    pub fn pose(&mut self, pose: &Pose, sink: &mut dyn Sink) {
        let Some(index) = (pose.robot.0 as usize).checked_sub(1).filter(|i| *i < self.trails.len()) else {
            return;
        };
        let t = pose.time_us;
        self.now_us = self.now_us.max(t);
        if self.clock_us.is_none_or(|c| t > c) {
            self.clock_us = Some(t);
            self.send(sink, CLOCK, t, &Clock { clock: run_time(t) });
        }
        let (stamped, transform) = ros_messages(pose);
        self.send(sink, SHARED + PER_ROBOT * index, t, &stamped);
        self.send(sink, TF, t, &TfMessage { transforms: vec![transform] });
        let trail = &mut self.trails[index];
        trail.last = Some(*pose);
        let far = |last: &PoseStamped| {
            let (a, b) = (last.pose.position, stamped.pose.position);
            (a.x - b.x).hypot(a.y - b.y) >= PATH_SPACING
        };
        if trail.path.poses.last().is_none_or(far) {
            trail.path.poses.push(stamped);
        }
        if trail.sent_us.is_none_or(|s| t >= s + PATH_PERIOD_US) {
            self.send_path(index, t, sink);
        }
        self.view.take(&Shown::Moved(*pose));
    }

    /// Robot `robot`'s beacon stands at `at` (the launch core's beacon
    /// table changed): the beacons are sent again if it is new or crept
    /// [`PATH_SPACING`] or more from where it was last sent.
    pub fn beacon(&mut self, robot: u32, at: Vec2, sink: &mut dyn Sink) {
        if self.view.take(&Shown::Beacon(BeaconAt { robot, at })) {
            self.send_beacons(sink);
        }
    }

    /// The view's beacons on the latched topic, unless none is new and
    /// none moved [`PATH_SPACING`] since they were last sent.
    fn send_beacons(&mut self, sink: &mut dyn Sink) {
        let now: BTreeMap<u32, Vec2> = self.view.beacons().collect();
        let moved = |(id, at): (&u32, &Vec2)| {
            self.beacons_sent.get(id).is_none_or(|was| was.distance(*at) >= PATH_SPACING)
        };
        if !now.iter().any(moved) {
            return;
        }
        let t = self.now_us;
        self.send(sink, BEACONS, t, &beacon_markers(&now, self.eps, run_time(t)));
        self.beacons_sent = now;
    }

    fn send_path(&mut self, index: usize, t: u64, sink: &mut dyn Sink) {
        let trail = &mut self.trails[index];
        trail.sent_us = Some(t);
        trail.path.header = Header { stamp: run_time(t), frame_id: WORLD_FRAME.into() };
        let path = std::mem::take(&mut trail.path);
        self.send(sink, SHARED + PER_ROBOT * index + 1, t, &path);
        self.trails[index].path = path;
    }

    /// A gate decision, and a stopped robot's path once more, whole. (Its
    /// state and beacon come as the core tells them, [`RunMessages::state`]
    /// and [`RunMessages::beacon`]; of an older recording, from here.)
    pub fn gate(&mut self, event: &GateEvent, sink: &mut dyn Sink) {
        let t = self.now_us;
        let kind = match event.kind {
            GateKind::Deployed => gate_kind::DEPLOYED,
            GateKind::Stopped { .. } => gate_kind::STOPPED,
            GateKind::Died => gate_kind::DIED,
            GateKind::Timeout => gate_kind::TIMEOUT,
        };
        let ros = RosGateEvent {
            stamp: run_time(t),
            robot: event.robot.0,
            kind,
            arrived: matches!(event.kind, GateKind::Stopped { arrived: true }),
            x: event.x,
            y: event.y,
            step: event.step,
        };
        self.send(sink, GATE, t, &ros);
        let beacons_changed = self.view.take(&Shown::Gate(*event));
        self.send_state_of(event.robot.0, sink);
        let index = (event.robot.0 as usize).checked_sub(1).filter(|i| *i < self.trails.len());
        if let (Some(i), GateKind::Stopped { .. } | GateKind::Died | GateKind::Timeout) = (index, event.kind)
        {
            if !self.trails[i].path.poses.is_empty() {
                self.send_path(i, t, sink);
            }
        }
        if beacons_changed {
            self.send_beacons(sink);
        }
    }

    /// An agent's report: a real robot's telemetry (at most once per
    /// [`DIAGNOSTICS_PERIOD_US`]), link and failsafe reports become
    /// `/diagnostics`; a ROS 2 robot's command goes on its `cmd_vel` (a
    /// bag's); other reports carry no health.
    pub fn report(&mut self, report: &FromAgent, sink: &mut dyn Sink) {
        if let FromAgent::Commanded(c) = report {
            return self.commanded(c, sink);
        }
        let robot = report.robot().0;
        let Some(index) = (robot as usize).checked_sub(1).filter(|i| *i < self.trails.len()) else {
            return;
        };
        let t = self.now_us;
        if let FromAgent::Telemetry(_) = report {
            let due = &mut self.trails[index].diagnostics_us;
            if due.is_some_and(|s| t < s + DIAGNOSTICS_PERIOD_US) {
                return;
            }
            *due = Some(t);
        }
        let Some(status) = diagnostic(report) else {
            return;
        };
        let header = Header { stamp: run_time(t), frame_id: String::new() };
        self.send(sink, DIAGNOSTICS, t, &DiagnosticArray { header, status: vec![status] });
    }
}

/// A robot's state as `RobotState.state` says it: not deployed yet
/// (never said, or any state before `Moving`, or skipped as absent) is
/// `WAITING`; lost before its deployment or while moving is `LOST`.
pub fn ros_state(state: Option<SlotState>) -> u8 {
    match state {
        None
        | Some(SlotState::Waiting | SlotState::Spawned | SlotState::Registered | SlotState::Deploying)
        | Some(SlotState::Absent) => robot_state::WAITING,
        Some(SlotState::Moving) => robot_state::MOVING,
        Some(SlotState::Stuck) => robot_state::BEACON,
        Some(SlotState::Arrived) => robot_state::ARRIVED,
        Some(SlotState::Died | SlotState::Lost) => robot_state::LOST,
        Some(SlotState::Unfinished) => robot_state::TIMED_OUT,
    }
}

/// The terrain as an occupancy grid: one cell per terrain cell (resolution
/// 1 frame unit), row by row from (0, 0), blocked 100 and free 0.
pub fn occupancy_grid(terrain: &Terrain) -> OccupancyGrid {
    let width = u32::try_from(terrain.width()).unwrap_or(u32::MAX);
    let height = u32::try_from(terrain.height()).unwrap_or(u32::MAX);
    OccupancyGrid {
        header: Header { stamp: Time::default(), frame_id: WORLD_FRAME.into() },
        map_load_time: Time::default(),
        resolution: 1.0,
        width,
        height,
        origin: RosPose::default(),
        data: terrain.blocked_cells().iter().map(|&b| if b { 100 } else { 0 }).collect(),
    }
}

/// Points of an ε circle's outline.
const CIRCLE_POINTS: usize = 48;

/// Each beacon as a sphere (namespace `beacons`) and its ε circle as a line
/// strip (namespace `eps`), both with the robot's number as id.
pub fn beacon_markers(beacons: &BTreeMap<u32, Vec2>, eps: f64, stamp: Time) -> MarkerArray {
    let header = Header { stamp, frame_id: WORLD_FRAME.into() };
    let mut markers = Vec::with_capacity(beacons.len() * 2);
    for (&robot, &at) in beacons {
        let at = Point { x: at.x, y: at.y, z: 0.0 };
        let id = i32::try_from(robot).unwrap_or(i32::MAX);
        let marker = |ns: &str, kind, scale: f64, color| Marker {
            header: header.clone(),
            ns: ns.into(),
            id,
            kind,
            action: marker_action::ADD,
            pose: RosPose { position: at, orientation: Quaternion::default() },
            scale: Vector3(Point { x: scale, y: scale, z: scale }),
            color,
            ..Marker::default()
        };
        markers.push(marker(
            "beacons",
            marker_type::SPHERE,
            0.5,
            ColorRgba { r: 1.0, g: 0.6, b: 0.0, a: 1.0 },
        ));
        let mut circle =
            marker("eps", marker_type::LINE_STRIP, 0.05, ColorRgba { r: 1.0, g: 0.6, b: 0.0, a: 0.8 });
        circle.points = (0..=CIRCLE_POINTS)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / CIRCLE_POINTS as f64;
                Point { x: eps * a.cos(), y: eps * a.sin(), z: 0.0 }
            })
            .collect();
        markers.push(circle);
    }
    MarkerArray { markers }
}

/// A real robot's health as a diagnostic status, named `bycoms/robot_<k>`.
fn diagnostic(report: &FromAgent) -> Option<DiagnosticStatus> {
    let robot = report.robot().0;
    let status = |lvl, message: String, values: Vec<(&str, String)>| DiagnosticStatus {
        level: lvl,
        name: format!("bycoms/robot_{robot}"),
        message,
        hardware_id: format!("robot_{robot}"),
        values: values.into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
    };
    Some(match report {
        FromAgent::Telemetry(t) => {
            let low = t.health & 1 != 0;
            let lvl = if low { level::WARN } else { level::OK };
            let message = if low { "battery low" } else { "ok" };
            status(
                lvl,
                message.into(),
                vec![
                    ("battery_mv", t.battery_mv.to_string()),
                    ("health", format!("{:#04x}", t.health)),
                    ("state", format!("{:?}", t.state)),
                    ("robot_drops", t.robot_drops.to_string()),
                ],
            )
        }
        FromAgent::Link(l) => status(
            if l.up { level::OK } else { level::ERROR },
            if l.up { "link up".into() } else { format!("link lost ({} ms silent)", l.silent_ms) },
            vec![
                ("link_up", l.up.to_string()),
                ("silent_ms", l.silent_ms.to_string()),
                ("refused", l.refused.to_string()),
            ],
        ),
        FromAgent::Failsafe(f) => status(
            level::ERROR,
            format!("failsafe stopped the robot ({} ms without the orchestrator)", f.silent_ms),
            vec![("failsafe", "true".into()), ("silent_ms", f.silent_ms.to_string())],
        ),
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::RobotId;

    /// Every message sent: (topic name, run time ns, CDR).
    #[derive(Default)]
    struct Sent(Vec<(usize, u64, Vec<u8>)>);

    impl Sink for Sent {
        fn send(&mut self, topic: usize, time_ns: u64, cdr: &[u8]) {
            self.0.push((topic, time_ns, cdr.to_vec()));
        }
    }

    impl Sent {
        fn on(&self, run: &RunMessages, name: &str) -> Vec<u64> {
            self.0.iter().filter(|(t, ..)| run.topics()[*t].name == name).map(|(_, ns, _)| *ns).collect()
        }
    }

    fn pose(robot: u32, x: f64, time_us: u64) -> Pose {
        Pose { robot: RobotId(robot), x, y: 1.0, heading: 0.0, step: time_us / 100_000, time_us }
    }

    #[test]
    fn the_topics_are_the_shared_ones_then_each_robots_pose_path_and_state() {
        let run = RunMessages::new(&Ros2Config { namespace: "/lab".into(), ..Ros2Config::default() }, 2);
        let names: Vec<_> = run.topics().iter().map(|t| t.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "/clock",
                "/tf",
                "/lab/map",
                "/lab/beacons",
                "/diagnostics",
                "/lab/gate",
                "/tf_static",
                "/lab/robot_1/pose",
                "/lab/robot_1/path",
                "/lab/robot_1/state",
                "/lab/robot_2/pose",
                "/lab/robot_2/path",
                "/lab/robot_2/state"
            ]
        );
        for latched in [MAP, TF_STATIC, BEACONS] {
            assert_eq!(
                run.topics()[latched].qos,
                Qos::transient_local(1),
                "{} is latched",
                run.topics()[latched].name
            );
        }
    }

    #[test]
    fn clock_once_per_time_and_paths_at_most_once_a_second_of_run_time() {
        let mut run = RunMessages::new(&Ros2Config::default(), 2);
        let mut sent = Sent::default();
        run.world(&Terrain::new(4, 3), 2.0, &mut sent);
        // 3 s of run time at 10 Hz, both robots each step.
        for step in 0..30u64 {
            for robot in [1, 2] {
                run.pose(&pose(robot, step as f64 * 0.06, step * 100_000), &mut sent);
            }
        }
        assert_eq!(sent.on(&run, "/map"), [0]);
        assert_eq!(sent.on(&run, "/tf_static"), [0], "the static frames once, before the run");
        assert_eq!(sent.on(&run, "/clock").len(), 30, "one /clock per run time, not per robot");
        assert_eq!(sent.on(&run, "/tf").len(), 60);
        assert_eq!(sent.on(&run, "/robot_1/pose").len(), 30);
        assert_eq!(sent.on(&run, "/robot_1/path"), [0, 1_000_000_000, 2_000_000_000]);
        // Poses 0.06 apart: the trail keeps every other one (PATH_SPACING 0.1).
        assert_eq!(run.trails[0].path.poses.len(), 15);
        let grid = sent.0.iter().find(|(t, ..)| *t == MAP).expect("map");
        assert_eq!(grid.2, occupancy_grid(&Terrain::new(4, 3)).to_cdr());
    }

    #[test]
    fn a_stuck_or_dead_robot_is_a_beacon_and_an_arrived_one_is_not() {
        let mut run = RunMessages::new(&Ros2Config::default(), 3);
        let mut sent = Sent::default();
        run.world(&Terrain::new(4, 3), 2.0, &mut sent);
        run.pose(&pose(1, 1.0, 500_000), &mut sent);
        let stop = |robot, kind| GateEvent { robot: RobotId(robot), kind, x: 1.0, y: 1.0, step: 5 };
        // As the core puts them out: the state, the decision, the beacon.
        let decide = |run: &mut RunMessages, robot, kind, sent: &mut Sent| {
            run.state(robot, SlotState::of_gate(kind), sent);
            run.gate(&stop(robot, kind), sent);
        };
        decide(&mut run, 1, GateKind::Stopped { arrived: false }, &mut sent);
        run.beacon(1, Vec2::new(1.0, 1.0), &mut sent);
        decide(&mut run, 2, GateKind::Died, &mut sent);
        run.beacon(2, Vec2::new(1.0, 1.0), &mut sent);
        decide(&mut run, 3, GateKind::Stopped { arrived: true }, &mut sent);
        assert_eq!(sent.on(&run, "/beacons"), [500_000_000, 500_000_000]);
        assert_eq!(sent.on(&run, "/robot_1/path").len(), 2, "its first, and its whole path when it stopped");
        assert_eq!(sent.on(&run, "/gate").len(), 3, "every gate decision");
        assert_eq!(sent.on(&run, "/robot_1/state"), [0, 500_000_000], "waiting, then a beacon");
        let state =
            sent.0.iter().rev().find(|(t, ..)| run.topics()[*t].name == "/robot_1/state").expect("state");
        let beacon = RobotState {
            header: Header { stamp: run_time(500_000), frame_id: WORLD_FRAME.into() },
            robot: 1,
            state: robot_state::BEACON,
            x: 1.0,
            y: 1.0,
            heading: 0.0,
            step: 5,
            real: false,
        };
        assert_eq!(state.2, beacon.to_cdr());
        let markers = beacon_markers(&run.beacons_sent, 2.0, run_time(500_000));
        assert_eq!(markers.markers.len(), 4, "robots 1 and 2: a sphere and an ε circle each");
        let circle = &markers.markers[1];
        assert_eq!((circle.ns.as_str(), circle.points.len()), ("eps", CIRCLE_POINTS + 1));
        assert!(circle.points.iter().all(|p| (p.x.hypot(p.y) - 2.0).abs() < 1e-9), "radius ε");
        // A beacon that creeps on, as the core tells it, is sent again at
        // its new place once it crept PATH_SPACING or more.
        run.pose(&pose(1, 1.05, 600_000), &mut sent);
        run.beacon(1, Vec2::new(1.05, 1.0), &mut sent);
        assert_eq!(sent.on(&run, "/beacons").len(), 2, "a creep shorter than PATH_SPACING");
        run.pose(&pose(1, 1.5, 700_000), &mut sent);
        assert_eq!(sent.on(&run, "/beacons").len(), 2, "a pose alone moves no beacon");
        run.beacon(1, Vec2::new(1.5, 1.0), &mut sent);
        assert_eq!(sent.on(&run, "/beacons").len(), 3);
        assert_eq!(run.beacons_sent[&1].x, 1.5);
    }

    /// The last `RobotState.state` sent on `name`, and how many were.
    fn states(sent: &Sent, run: &RunMessages, name: &str) -> (Option<u8>, usize) {
        let on: Vec<_> = sent.0.iter().filter(|(t, ..)| run.topics()[*t].name == name).collect();
        (on.last().map(|(.., cdr)| super::super::messages::robot_state_in(cdr)), on.len())
    }

    /// A robot's state is the core's word: one revoked before its
    /// deployment is `LOST` with no gate decision, the core's states
    /// before a deployment send nothing new (all `WAITING`), and a gate
    /// decision alone changes no told state; of a recording older than
    /// `core/state`, the gate's decisions imply the states.
    #[test]
    fn states_are_the_cores_as_it_said_them() {
        let mut run = RunMessages::new(&Ros2Config::default(), 2);
        let mut sent = Sent::default();
        run.world(&Terrain::new(4, 3), 2.0, &mut sent);
        for state in [SlotState::Spawned, SlotState::Registered, SlotState::Deploying] {
            run.state(1, state, &mut sent);
        }
        assert_eq!(states(&sent, &run, "/robot_1/state"), (Some(robot_state::WAITING), 1));
        run.state(2, SlotState::Lost, &mut sent);
        assert_eq!(states(&sent, &run, "/robot_2/state"), (Some(robot_state::LOST), 2));
        let timeout = GateEvent { robot: RobotId(1), kind: GateKind::Timeout, x: 1.0, y: 1.0, step: 5 };
        run.gate(&timeout, &mut sent);
        assert_eq!(states(&sent, &run, "/robot_1/state"), (Some(robot_state::WAITING), 1), "not the gate's");
        run.state(1, SlotState::Unfinished, &mut sent);
        assert_eq!(states(&sent, &run, "/robot_1/state"), (Some(robot_state::TIMED_OUT), 2));
        let mut old = RunMessages::new(&Ros2Config::default(), 1).without_states_told();
        let mut sent = Sent::default();
        old.world(&Terrain::new(4, 3), 2.0, &mut sent);
        old.gate(&GateEvent { kind: GateKind::Deployed, ..timeout }, &mut sent);
        old.gate(&timeout, &mut sent);
        assert_eq!(states(&sent, &old, "/robot_1/state"), (Some(robot_state::TIMED_OUT), 3));
    }

    /// A bag of a recording older than `core/beacon`: the gate's decisions
    /// place the beacons, where it judged them.
    #[test]
    fn without_told_beacons_the_gate_places_them() {
        let mut run = RunMessages::new(&Ros2Config::default(), 2).without_beacons_told();
        let mut sent = Sent::default();
        run.world(&Terrain::new(4, 3), 2.0, &mut sent);
        let stop = |robot, kind| GateEvent { robot: RobotId(robot), kind, x: 2.0, y: 1.0, step: 5 };
        run.gate(&stop(1, GateKind::Stopped { arrived: false }), &mut sent);
        run.gate(&stop(2, GateKind::Stopped { arrived: true }), &mut sent);
        assert_eq!(sent.on(&run, "/beacons").len(), 1);
        assert_eq!(run.beacons_sent.get(&1), Some(&Vec2::new(2.0, 1.0)));
    }

    #[test]
    fn a_bags_ros2_robots_get_their_reported_commands_on_their_cmd_vel_with_their_type() {
        use bycoms_protocol::msg::{Commanded, Sensed};
        let topic = |robot, cmd_vel: &str, message: &str| Ros2RobotTopic {
            robot,
            cmd_vel: cmd_vel.into(),
            message: message.into(),
            r#type: String::new(),
            frame_id: "base_link".into(),
        };
        let robots = [
            topic(1, "/tb3_1/cmd_vel", "twist"),
            topic(2, "/robot_2/cmd_vel", "twist-stamped"),
            topic(3, "/robot_3/cmd_vel", "wrench"),
        ];
        let mut run = RunMessages::new(&Ros2Config::default(), 3).with_cmd_vel(&robots);
        let names: Vec<_> =
            run.topics().iter().skip(SHARED + 3 * PER_ROBOT).map(|t| t.name.as_str()).collect();
        assert_eq!(
            names,
            ["/tb3_1/cmd_vel", "/robot_2/cmd_vel"],
            "after every other topic; robot 3's message is unknown"
        );
        assert_eq!(run.topics()[SHARED + 3 * PER_ROBOT + 1].description.name, TwistStamped::DESCRIPTION.name);
        let mut sent = Sent::default();
        run.pose(&pose(1, 0.0, 300_000), &mut sent);
        let sensed = Some(Sensed { intensity: 2.0, gradient: Some(0.5) });
        let cmd = |robot, linear| Commanded { robot: RobotId(robot), step: 3, linear, angular: -0.7, sensed };
        for c in [cmd(1, 0.22), cmd(2, 0.1), cmd(3, 0.1), cmd(1, 0.0)] {
            run.report(&FromAgent::Commanded(c), &mut sent);
        }
        assert_eq!(sent.on(&run, "/tb3_1/cmd_vel"), [300_000_000, 300_000_000], "at the latest pose's time");
        let on = |name: &str| -> Vec<Vec<u8>> {
            sent.0
                .iter()
                .filter(|(t, ..)| run.topics()[*t].name == name)
                .map(|(.., cdr)| cdr.clone())
                .collect()
        };
        assert_eq!(
            on("/tb3_1/cmd_vel"),
            [Twist::planar(0.22, -0.7).to_cdr(), Twist::planar(0.0, -0.7).to_cdr()]
        );
        let header = Header { stamp: run_time(300_000), frame_id: "base_link".into() };
        let stamped = TwistStamped { header, twist: Twist::planar(0.1, -0.7) };
        assert_eq!(on("/robot_2/cmd_vel"), [stamped.to_cdr()]);
        // The live graph's publisher has no cmd_vel topics: reports go nowhere.
        let mut live = RunMessages::new(&Ros2Config::default(), 3);
        let mut none = Sent::default();
        live.report(&FromAgent::Commanded(cmd(1, 0.22)), &mut none);
        assert!(none.0.is_empty());
    }

    #[test]
    fn diagnostics_from_telemetry_at_most_once_a_second_and_every_link_report() {
        use bycoms_protocol::msg::{LinkStatus, Telemetry};
        let mut run = RunMessages::new(&Ros2Config::default(), 1);
        let mut sent = Sent::default();
        let telemetry = |battery_mv| {
            FromAgent::Telemetry(Telemetry {
                robot: RobotId(1),
                period: 0,
                state: bycoms_protocol::msg::DriveState::Driving,
                mode: 1,
                mics: [0.0; 6],
                v_ave: 0.0,
                gradient: None,
                left: 0.0,
                right: 0.0,
                battery_mv,
                health: 1,
                robot_drops: 0,
            })
        };
        for step in 0..20u64 {
            run.pose(&pose(1, 0.0, step * 100_000), &mut sent);
            run.report(&telemetry(3700), &mut sent);
        }
        run.report(
            &FromAgent::Link(LinkStatus { robot: RobotId(1), up: false, silent_ms: 600, refused: 2 }),
            &mut sent,
        );
        assert_eq!(sent.on(&run, "/diagnostics"), [0, 1_000_000_000, 1_900_000_000]);
        let status = diagnostic(&telemetry(3700)).expect("telemetry is health");
        assert_eq!((status.level, status.message.as_str()), (level::WARN, "battery low"));
        assert!(status.values.contains(&("battery_mv".into(), "3700".into())));
    }
}
