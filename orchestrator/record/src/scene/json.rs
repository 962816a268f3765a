//! Per-robot pose, mode and telemetry, and gate decisions, as JSON with a
//! JSON schema.
//!
//! Why JSON next to the scene: Foxglove's Plot, Raw Messages and State
//! Transitions panels read any field of a JSON message whose channel has a
//! `jsonschema` schema, and so does any script (`json.loads`). The schemas
//! come from the structs themselves (`schemars`, draft-07 with inlined
//! definitions, as Foxglove wants them), so they cannot drift from what is
//! written. Each type implements [`foxglove::Encode`] (message encoding
//! `json`), so the live view can log it on a typed SDK channel.

use crate::schema;
use bycoms_gate::view::SlotState;
use bycoms_protocol::msg::{FromAgent, GateEvent, GateKind, Pose, RobotKind};
use foxglove::bytes::BufMut;
use schemars::generate::SchemaSettings;
use schemars::JsonSchema;
use serde::Serialize;
use std::borrow::Cow;

/// One robot's pose as motion capture saw it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, JsonSchema)]
pub struct RobotPose {
    /// The robot (1-based deployment order).
    pub robot: u32,
    /// Position x, grid cells (= metres in the scene).
    pub x: f64,
    /// Position y, grid cells.
    pub y: f64,
    /// Heading θ in the arena frame, rad.
    pub heading: f64,
    /// Lockstep tick or real-time frame number.
    pub step: u64,
    /// Time of the observation since the run started, s.
    pub time_s: f64,
}

impl From<&Pose> for RobotPose {
    fn from(p: &Pose) -> Self {
        Self {
            robot: p.robot.0,
            x: p.x,
            y: p.y,
            heading: p.heading,
            step: p.step,
            time_s: p.time_us as f64 * 1e-6,
        }
    }
}

/// The controller's mode (paper §IV: 1 = towards the goal, 2 = bypass along the field).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, JsonSchema)]
pub struct RobotMode {
    /// The robot.
    pub robot: u32,
    /// 1 or 2, as in the paper.
    pub mode: u8,
    /// `goal` (mode 1), `bypass` (mode 2) or `unknown`.
    pub name: &'static str,
    /// The step the mode belongs to.
    pub step: u64,
}

impl RobotMode {
    /// The mode in words.
    pub fn name_of(mode: u8) -> &'static str {
        match mode {
            1 => "goal",
            2 => "bypass",
            _ => "unknown",
        }
    }
}

/// What kind of agent report a [`Telemetry`] message is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum TelemetryKind {
    /// The agent announced itself.
    Register,
    /// Liveness.
    Heartbeat,
    /// Mode report.
    Status,
    /// Lockstep reply: the step is done.
    TickDone,
    /// A real robot's control period (from its gateway).
    RobotTelemetry,
    /// A real robot's link: lost, restored or refusing frames.
    Link,
    /// The agent's failsafe stopped its robot.
    Failsafe,
    /// Lockstep: the robot will never move again (it is ticked no more).
    Parked,
    /// The agent's host clock against the orchestrator's.
    Clock,
    /// The robot is stopped: the answer to `Stop`.
    StopDone,
    /// A velocity command a ROS 2 robot's agent published on its `cmd_vel`.
    Commanded,
}

/// One agent report (the decoded `from_agents` traffic of one robot).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, JsonSchema)]
pub struct Telemetry {
    /// The reporting robot.
    pub robot: u32,
    /// Which report.
    pub kind: TelemetryKind,
    /// The step (status, tick done).
    pub step: Option<u64>,
    /// Heartbeat sequence number.
    pub seq: Option<u64>,
    /// Controller mode (status).
    pub mode: Option<u8>,
    /// Protocol version (register).
    pub protocol_version: Option<u16>,
    /// `simulated` or `real` (register).
    pub agent: Option<&'static str>,
    /// Whether the robot's link is up (link).
    pub link_up: Option<bool>,
    /// The host clock's offset to the orchestrator's, µs (clock).
    pub clock_offset_us: Option<i64>,
}

impl From<&FromAgent> for Telemetry {
    fn from(m: &FromAgent) -> Self {
        let mut t = Telemetry {
            robot: m.robot().0,
            kind: TelemetryKind::Heartbeat,
            step: None,
            seq: None,
            mode: None,
            protocol_version: None,
            agent: None,
            link_up: None,
            clock_offset_us: None,
        };
        match m {
            FromAgent::Register(r) => {
                t.kind = TelemetryKind::Register;
                t.protocol_version = Some(r.protocol_version);
                t.agent = Some(match r.kind {
                    RobotKind::Simulated => "simulated",
                    RobotKind::Real => "real",
                });
            }
            FromAgent::Heartbeat(h) => t.seq = Some(h.seq),
            FromAgent::Status(s) => {
                t.kind = TelemetryKind::Status;
                t.mode = Some(s.mode);
                t.step = Some(s.step);
            }
            FromAgent::TickDone(d) => {
                t.kind = TelemetryKind::TickDone;
                t.step = Some(d.step);
            }
            FromAgent::Telemetry(r) => {
                t.kind = TelemetryKind::RobotTelemetry;
                t.mode = Some(r.mode);
                t.step = Some(u64::from(r.period));
            }
            FromAgent::Link(l) => {
                t.kind = TelemetryKind::Link;
                t.link_up = Some(l.up);
            }
            FromAgent::Failsafe(_) => t.kind = TelemetryKind::Failsafe,
            FromAgent::Parked(p) => {
                t.kind = TelemetryKind::Parked;
                t.step = Some(p.step);
            }
            FromAgent::Clock(c) => {
                t.kind = TelemetryKind::Clock;
                t.clock_offset_us = Some(c.offset_us);
            }
            FromAgent::StopDone(_) => t.kind = TelemetryKind::StopDone,
            FromAgent::Commanded(c) => {
                t.kind = TelemetryKind::Commanded;
                t.step = Some(c.step);
            }
        }
        t
    }
}

/// What the gate decided about a robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Decision {
    /// Deployed at its start pose.
    Deployed,
    /// Stopped away from the goal: a beacon.
    Stuck,
    /// Stopped within the goal radius: the run is won.
    Arrived,
    /// Its agent died while it moved: a beacon where last seen.
    Died,
    /// The run's time ran out while it moved.
    Timeout,
}

impl From<GateKind> for Decision {
    fn from(k: GateKind) -> Self {
        match k {
            GateKind::Deployed => Self::Deployed,
            GateKind::Stopped { arrived: true } => Self::Arrived,
            GateKind::Stopped { arrived: false } => Self::Stuck,
            GateKind::Died => Self::Died,
            GateKind::Timeout => Self::Timeout,
        }
    }
}

impl Decision {
    /// Whether the robot is a beacon from now on.
    pub fn is_beacon(self) -> bool {
        matches!(self, Self::Stuck | Self::Died)
    }
}

/// One gate decision.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, JsonSchema)]
pub struct GateDecision {
    /// The robot concerned.
    pub robot: u32,
    /// What the gate decided.
    pub decision: Decision,
    /// Whether the robot is a beacon from now on.
    pub beacon: bool,
    /// Where, x.
    pub x: f64,
    /// Where, y.
    pub y: f64,
    /// The step it was decided at.
    pub step: u64,
}

impl From<&GateEvent> for GateDecision {
    fn from(e: &GateEvent) -> Self {
        let decision = Decision::from(e.kind);
        Self { robot: e.robot.0, decision, beacon: decision.is_beacon(), x: e.x, y: e.y, step: e.step }
    }
}

/// A beacon where it stands: the launch core's beacon table changed (a
/// robot became a beacon, or its beacon crept on with it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, JsonSchema)]
pub struct BeaconAt {
    /// The robot.
    pub robot: u32,
    /// Where, x, grid cells.
    pub x: f64,
    /// Where, y, grid cells.
    pub y: f64,
}

/// A robot's state changed, as the launch core said it (its slot state,
/// `snake_case`: `waiting`, `starting`… see [`SlotState`]). Recorded as the
/// core's fact on `core/state` ([`schema::CORE_STATE`]) and as the scene's
/// `robot/<k>/state` ([`schema::ROBOT_SLOT`], for Foxglove's State
/// Transitions panel and the live view).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize, JsonSchema)]
pub struct RobotSlot {
    /// The robot.
    pub robot: u32,
    /// Its new state.
    #[schemars(with = "String")]
    pub state: SlotState,
}

/// The JSON schema of `T` as Foxglove reads it: draft-07, definitions inlined.
pub fn json_schema<T: JsonSchema>() -> Vec<u8> {
    let settings = SchemaSettings::draft07().with(|s| s.inline_subschemas = true);
    let schema = settings.into_generator().into_root_schema_for::<T>();
    // A schema is a JSON value: serializing it cannot fail.
    serde_json::to_vec(&schema).unwrap_or_default()
}

macro_rules! json_message {
    ($($t:ty => $name:expr),* $(,)?) => {$(
        impl foxglove::Encode for $t {
            type Error = serde_json::Error;

            fn get_schema() -> Option<foxglove::Schema> {
                Some(foxglove::Schema::new($name, "jsonschema", Cow::Owned(json_schema::<$t>())))
            }

            fn get_message_encoding() -> String {
                "json".to_string()
            }

            fn encode(&self, buf: &mut impl BufMut) -> Result<(), Self::Error> {
                serde_json::to_writer(buf.writer(), self)
            }
        }
    )*};
}

json_message! {
    RobotPose => schema::ROBOT_POSE,
    RobotMode => schema::ROBOT_MODE,
    Telemetry => schema::TELEMETRY,
    GateDecision => schema::GATE_DECISION,
    BeaconAt => schema::BEACON_AT,
    RobotSlot => schema::ROBOT_SLOT,
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::msg::{Heartbeat, Register, Status};
    use bycoms_protocol::RobotId;
    use foxglove::Encode;

    fn encoded<T: Encode>(v: &T) -> serde_json::Value {
        let mut buf = Vec::new();
        v.encode(&mut buf).expect("encodes");
        serde_json::from_slice(&buf).expect("JSON")
    }

    #[test]
    fn schemas_name_every_field_and_are_draft_07() {
        let schema = RobotPose::get_schema().expect("schema");
        assert_eq!((schema.name.as_str(), schema.encoding.as_str()), ("bycoms.RobotPose", "jsonschema"));
        let s: serde_json::Value = serde_json::from_slice(&schema.data).expect("schema is JSON");
        assert_eq!(s["$schema"], "http://json-schema.org/draft-07/schema#");
        for field in ["robot", "x", "y", "heading", "step", "time_s"] {
            assert!(s["properties"][field].is_object(), "{field} in {s}");
        }
        let t: serde_json::Value =
            serde_json::from_slice(&Telemetry::get_schema().expect("schema").data).expect("JSON");
        // The kind enum is inlined (Foxglove resolves no references).
        assert!(!t.to_string().contains("$ref"), "{t}");
    }

    #[test]
    fn agent_reports_become_telemetry() {
        let robot = RobotId(4);
        let reg = FromAgent::Register(Register {
            robot,
            kind: RobotKind::Simulated,
            protocol_version: 3,
            instance: 1,
            settings: 0,
            failsafe_grace_ms: 0,
        });
        let j = encoded(&Telemetry::from(&reg));
        assert_eq!((j["robot"].as_u64(), j["kind"].as_str()), (Some(4), Some("register")));
        assert_eq!((j["agent"].as_str(), j["protocol_version"].as_u64()), (Some("simulated"), Some(3)));
        let hb = Telemetry::from(&FromAgent::Heartbeat(Heartbeat { robot, seq: 9 }));
        assert_eq!((hb.kind, hb.seq), (TelemetryKind::Heartbeat, Some(9)));
        let st = Telemetry::from(&FromAgent::Status(Status { robot, mode: 2, step: 17 }));
        assert_eq!((st.kind, st.mode, st.step), (TelemetryKind::Status, Some(2), Some(17)));
    }

    #[test]
    fn gate_events_become_decisions() {
        let e = GateEvent {
            robot: RobotId(2),
            kind: GateKind::Stopped { arrived: false },
            x: 1.5,
            y: 2.5,
            step: 80,
        };
        let j = encoded(&GateDecision::from(&e));
        assert_eq!((j["decision"].as_str(), j["beacon"].as_bool()), (Some("stuck"), Some(true)));
        let won = GateDecision::from(&GateEvent { kind: GateKind::Stopped { arrived: true }, ..e });
        assert_eq!((won.decision, won.beacon), (Decision::Arrived, false));
        assert!(GateDecision::from(&GateEvent { kind: GateKind::Died, ..e }).beacon);
    }
}
