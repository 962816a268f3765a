//! Agent → orchestrator: registration, liveness and lockstep replies.
//!
//! Why no pose here: the orchestrator learns where a robot is from motion
//! capture ([`crate::msg::Pose`]), exactly as a lab would; an agent only
//! says that it exists, that it is alive, which mode it is in, and that it
//! has finished a lockstep tick. A real robot's gateway adds what only a
//! real robot has: its telemetry and the state of its WiFi link. Each agent
//! reports on its own robot's `from_agent` topic, and every message still
//! carries the sender's [`RobotId`], which must be the topic's: over zenoh
//! the access control lets robot k's certificate publish only under robot
//! k, so a message that names another robot than its key is forged.

use crate::RobotId;
use serde::{Deserialize, Serialize};

/// What kind of robot an agent speaks for: a simulated one (`sim-agent`)
/// or a real one (its `gateway`). (Not where the launch's agents
/// come from: that is the orchestrator's `AgentSourceKind`.)
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RobotKind {
    /// A simulated body (`sim-agent`).
    Simulated,
    /// A real robot behind its `gateway` (WiFi, the robot link).
    Real,
}

/// First message of an agent: who it is and which protocol it speaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Register {
    /// The agent's robot.
    pub robot: RobotId,
    /// Simulated or real.
    pub kind: RobotKind,
    /// The agent's [`crate::PROTOCOL_VERSION`], so a mismatch is reported
    /// by name even when the envelope check already passed.
    pub protocol_version: u16,
    /// A random number drawn once per agent process: who is speaking for
    /// the robot. The orchestrator takes the first instance that registers
    /// a robot; the same instance again is a repeat, another one a refused
    /// duplicate (answered with [`crate::msg::ToAgent::Refused`]).
    pub instance: u64,
    /// The fingerprint of the run settings the agent was started with
    /// (terrain, ε, seed, noise, clock, speed, limits); 0 when it was
    /// started without any and takes the orchestrator's. An agent whose
    /// fingerprint is not the launch's is refused
    /// ([`crate::msg::Refusal::Settings`]): it would run another study.
    pub settings: u64,
    /// How long the agent's failsafe lets its robot drive without hearing
    /// the orchestrator, ms; 0 when it has none (over iceoryx2 the agent's
    /// lifeline ties it to the orchestrator's process). A launch that would
    /// wait for an unreachable agent longer than this refuses it
    /// ([`crate::msg::Refusal::Grace`]): the robot would stop for good while
    /// the launch still counted on it.
    pub failsafe_grace_ms: u32,
}

/// How often an agent sends its [`Heartbeat`] unless told otherwise, ms of
/// wall time: the one default of every agent (`sim-agent`, `gateway`,
/// `ros2-robot`) and of the launch's `supervision.heartbeat_interval`.
pub const HEARTBEAT_MS: u64 = 100;

/// Periodic liveness signal; `seq` increases by one per heartbeat.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Heartbeat {
    /// The agent's robot.
    pub robot: RobotId,
    /// Heartbeat sequence number.
    pub seq: u64,
}

/// The controller's mode after a step (1 = goal, 2 = bypass).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Status {
    /// The agent's robot.
    pub robot: RobotId,
    /// Controller mode: 1 or 2 as in the paper.
    pub mode: u8,
    /// The step this status belongs to.
    pub step: u64,
}

/// Lockstep reply: the agent has finished `step`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TickDone {
    /// The agent's robot.
    pub robot: RobotId,
    /// The step that was completed.
    pub step: u64,
}

/// What a real robot's firmware is doing (the link's telemetry state).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum DriveState {
    /// Not enabled: motors off, speaker off.
    Idle,
    /// Enabled and commanded: the controller drives the motors.
    Driving,
    /// Enabled, but no valid command for 500 ms: motors off (failsafe).
    Failsafe,
    /// Stopped by command: motors off, speaker on (a beacon).
    Stopped,
}

/// One control period of a real robot, as its firmware measured and
/// decided it (relayed by its gateway from the robot link's telemetry).
///
/// Why f32 and the robot frame: these are the robot's own numbers, passed
/// on unchanged (the link carries f32), so a recording shows exactly what
/// the robot saw; turning the gradient into the world frame needs the
/// robot's heading, which motion capture ([`crate::msg::Pose`]) has.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    /// The robot.
    pub robot: RobotId,
    /// The robot's control period counter since its boot.
    pub period: u32,
    /// What the firmware is doing.
    pub state: DriveState,
    /// Controller mode: 1 (goal) or 2 (bypass).
    pub mode: u8,
    /// V_1..V_6: the other robots' summed tone amplitude per microphone.
    pub mics: [f32; 6],
    /// V_ave, the mean of `mics`.
    pub v_ave: f32,
    /// Gradient direction in the robot frame (rad, counter-clockwise from
    /// the heading); `None` where the firmware did not compute it.
    pub gradient: Option<f32>,
    /// Left motor command.
    pub left: f32,
    /// Right motor command.
    pub right: f32,
    /// Battery voltage, mV.
    pub battery_mv: u16,
    /// Health flags: bit 0 low battery, bit 1 microphone clipping.
    pub health: u8,
    /// Link frames the robot has refused since its boot.
    pub robot_drops: u32,
}

impl Telemetry {
    /// The bus form of one link telemetry frame of `robot`.
    pub fn from_link(robot: RobotId, t: &crate::link::Telemetry) -> Self {
        use crate::link::RobotState as S;
        let state = match t.state {
            S::Idle => DriveState::Idle,
            S::Driving => DriveState::Driving,
            S::Failsafe => DriveState::Failsafe,
            S::Stopped => DriveState::Stopped,
        };
        Self {
            robot,
            period: t.step,
            state,
            mode: t.mode,
            mics: t.mics,
            v_ave: t.v_ave,
            gradient: t.gradient,
            left: t.left,
            right: t.right,
            battery_mv: t.battery_mv,
            health: t.health.0,
            robot_drops: t.link_drops,
        }
    }
}

/// The state of a real robot's link, from its gateway: sent when the link
/// is lost (no valid robot frame for the gateway's timeout, at most 500 ms)
/// or restored, and when the count of refused frames has grown (at most
/// once a second).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkStatus {
    /// The robot.
    pub robot: RobotId,
    /// True while valid frames arrive; false once the link is lost.
    pub up: bool,
    /// Time since the last valid robot frame, ms (saturating).
    pub silent_ms: u32,
    /// Link frames the gateway has refused so far (forged, replayed,
    /// foreign, garbage: every drop reason).
    pub refused: u32,
}

/// The agent's failsafe stopped its robot: the orchestrator was gone (its
/// liveliness token, over zenoh) for longer than the agent's grace. The
/// robot stays stopped until `Shutdown`. Sent when it fires, and again each
/// time the agent hears the orchestrator afterwards (the first copy was
/// probably sent into a cut link), so the launch learns of it once the link
/// is back.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FailsafeFired {
    /// The robot.
    pub robot: RobotId,
    /// How long the orchestrator had been gone when the failsafe fired, ms
    /// (saturating).
    pub silent_ms: u32,
}

/// Lockstep: the robot will never move again (a simulated body that froze
/// in an impassable cell, or a robot told to stop), so its last pose
/// stands for every later step. The orchestrator then ticks it no more
/// (unless it still watches it): a thousand-robot launch wakes only the
/// agents whose robots can still move. Sent with the `TickDone` of every
/// tick it is sent while parked, so a lost copy costs one tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Parked {
    /// The agent's robot.
    pub robot: RobotId,
    /// The step of the pose that stands from now on.
    pub step: u64,
}

/// The agent's host clock's offset to the orchestrator's, as the agent
/// measured it (`bus::zenoh::clock`: NTP's exchange over zenoh, the
/// shortest of a few round trips). Sent before the first `Register` and
/// after each measurement again (every 10 s); over zenoh only. A launch
/// refuses an agent whose offset is past its limit
/// ([`crate::msg::Refusal::Clock`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClockOffset {
    /// The agent's robot.
    pub robot: RobotId,
    /// The agent's clock minus the orchestrator's, µs (positive: ahead).
    pub offset_us: i64,
    /// The round trip of the exchange it comes from, µs (saturating): the
    /// offset is right to within half of it.
    pub round_trip_us: u32,
}

/// The answer to `Stop`: the agent has stopped its robot (issue 34: a
/// stop asked from outside counts a robot stopped only once it says so).
/// Sent for every `Stop` taken, so the orchestrator re-sends a `Stop` until
/// this comes (a lost copy costs one re-send). A simulated robot stands
/// still from then on; a gateway says whether the robot link's stop frame
/// went out (`on_link`: false while the robot has no link session, when
/// the robot's own failsafe stops it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StopDone {
    /// The agent's robot.
    pub robot: RobotId,
    /// The stop went out on a robot link (a gateway's stop frame); false
    /// for a simulated robot, which has no link.
    pub on_link: bool,
}

/// The virtual field a ROS 2 robot's agent sensed at its trusted pose (the
/// paper's §IV g = Σ c/d² over the stopped robots it was sent).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sensed {
    /// g, m⁻² (0 with no beacon).
    pub intensity: f64,
    /// The gradient's direction in the world frame, rad; `None` with no
    /// beacon (no field, no direction).
    pub gradient: Option<f64>,
}

/// One velocity command an agent published on its robot's `cmd_vel` (a
/// ROS 2 robot's agent, issue 50): sent after each command went out, zeros
/// included, so a recording holds every command a robot was sent and
/// `record export --ros2` can put them back on their topic.
///
/// Why in the protocol and not only on the ROS 2 graph: the launch records
/// its bus, not the graph; what the agent decided, from which field, at
/// which step, belongs with the poses and the gate's decisions it came from.
/// `linear` and `angular` are the very f64 published (`geometry_msgs`
/// `linear.x`, `angular.z`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Commanded {
    /// The robot.
    pub robot: RobotId,
    /// The control step the command belongs to: the `Status` step of a
    /// command the drive law computed; for a zero, the last step driven (0
    /// before the first).
    pub step: u64,
    /// Linear velocity, m/s (`linear.x`).
    pub linear: f64,
    /// Angular velocity, rad/s (`angular.z`).
    pub angular: f64,
    /// The field the command was computed from; `None` for a zero that no
    /// field decided (a stop, no goal yet, no fresh pose).
    pub sensed: Option<Sensed>,
}

/// Everything an agent tells the orchestrator. (Not `Eq`: telemetry
/// carries floats.)
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum FromAgent {
    /// Announce the agent.
    Register(Register),
    /// Liveness.
    Heartbeat(Heartbeat),
    /// Mode report.
    Status(Status),
    /// Lockstep reply.
    TickDone(TickDone),
    /// A real robot's control period (gateways only).
    Telemetry(Telemetry),
    /// A real robot's link lost, restored, or refusing frames (gateways only).
    Link(LinkStatus),
    /// The agent's failsafe stopped its robot.
    Failsafe(FailsafeFired),
    /// Lockstep: the robot will never move again.
    Parked(Parked),
    /// The agent's host clock's offset to the orchestrator's (zenoh).
    Clock(ClockOffset),
    /// The robot is stopped: the answer to `Stop`.
    StopDone(StopDone),
    /// A velocity command the agent published on its robot's `cmd_vel`
    /// (ROS 2 robots only). Appended last: the earlier variants keep their
    /// indices.
    Commanded(Commanded),
}

impl FromAgent {
    /// The robot that sent this message.
    pub fn robot(&self) -> RobotId {
        match self {
            Self::Register(m) => m.robot,
            Self::Heartbeat(m) => m.robot,
            Self::Status(m) => m.robot,
            Self::TickDone(m) => m.robot,
            Self::Telemetry(m) => m.robot,
            Self::Link(m) => m.robot,
            Self::Failsafe(m) => m.robot,
            Self::Parked(m) => m.robot,
            Self::Clock(m) => m.robot,
            Self::StopDone(m) => m.robot,
            Self::Commanded(m) => m.robot,
        }
    }
}
