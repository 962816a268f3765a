//! What a recorded message means, from its channel: the one place that maps a schema name
//! (and message encoding) to a decoded message.
//!
//! Why one place: the launch decodes what it records (for the scene and `launch --svg`), and
//! `draw`, `replay` and `record recover` read recordings back. Each used to match schema names
//! on its own, with its own rules for the encoding and for bytes that do not decode; now they
//! all ask [`decode`] and keep only what they use.
//!
//! The rules: protocol messages are decoded only from `postcard` channels (an old recording's
//! JSON copy of a gate event is not a bus message); bytes that do not decode are
//! [`Content::Undecodable`] (garbage crossed the bus and was recorded as it came). The
//! launch core's log and the mocap datagrams are handed over as bytes: their codecs belong to
//! `launch::core::log` and `bycoms_mocap`, above this module.

use bycoms_protocol::msg::{Deploy, FromAgent, GateEvent, Pose, ToAgent};
use bycoms_protocol::{decode as postcard, RobotId};

use super::scene::json::RobotSlot;
use super::schema;
use bycoms_gate::view::SlotState;

/// A recorded message, decoded as far as the recording layer knows how.
#[derive(Debug, Clone, PartialEq)]
pub enum Content<'a> {
    /// The run metadata (JSON on `bycoms/<swarm>/run`); each reader takes the fields it needs.
    Run(&'a [u8]),
    /// A command to the robot its topic names.
    Command {
        /// The robot of the topic (`…/robot/<k>/to_agent`).
        robot: RobotId,
        /// The command.
        command: ToAgent,
    },
    /// An agent's report.
    Report(FromAgent),
    /// A pose (from motion capture, or the launch's relay of a dead robot's last pose).
    Pose(Pose),
    /// A pose the launch core applied (`core/moved`): one the views show.
    Moved(Pose),
    /// A change of the launch core's beacon table (`core/beacon`): robot
    /// `robot`'s beacon stands at (`x`, `y`).
    Beacon {
        /// The robot.
        robot: u32,
        /// Where, x.
        x: f64,
        /// Where, y.
        y: f64,
    },
    /// A change of a robot's state in the launch core (`core/state`).
    State {
        /// The robot.
        robot: u32,
        /// Its new state.
        state: SlotState,
    },
    /// A gate event the launch published.
    Gate(GateEvent),
    /// A placement request to the lab's operator.
    Operator(Deploy),
    /// The launch core's setup, encoded by `launch::core::log` in the
    /// version of its schema that `.0` names.
    CoreSetup(u32, &'a [u8]),
    /// Calls the launch made on its core, encoded by `launch::core::log`
    /// in the version of its schema that `.0` names.
    CoreCalls(u32, &'a [u8]),
    /// A NatNet frame's datagram, as received.
    MocapFrame(&'a [u8]),
    /// The NatNet model definitions packet, as received.
    MocapModelDef(&'a [u8]),
    /// A bus message of schema `schema` whose bytes do not decode.
    Undecodable {
        /// Its schema name (one of [`schema`]'s bus message names).
        schema: &'static str,
    },
    /// Anything else: decoded channels, JSON events, summaries, unknown schemas.
    Other,
}

/// Decodes a message of schema `schema_name`, message encoding `encoding`, on `topic`.
pub fn decode<'a>(topic: &str, schema_name: &str, encoding: &str, data: &'a [u8]) -> Content<'a> {
    let postcard_bytes = encoding == schema::POSTCARD;
    match schema_name {
        schema::RUN if schema::is_run_topic(topic) => Content::Run(data),
        schema::TO_AGENT if postcard_bytes => match (schema::robot_of_topic(topic), bus::<ToAgent>(data)) {
            (Some(robot), Some(command)) => Content::Command { robot, command },
            (None, _) => Content::Other,
            (Some(_), None) => Content::Undecodable { schema: schema::TO_AGENT },
        },
        schema::FROM_AGENT if postcard_bytes => {
            bus(data).map_or(Content::Undecodable { schema: schema::FROM_AGENT }, Content::Report)
        }
        schema::POSE if postcard_bytes => {
            bus(data).map_or(Content::Undecodable { schema: schema::POSE }, Content::Pose)
        }
        schema::MOVED if postcard_bytes => {
            bus(data).map_or(Content::Undecodable { schema: schema::MOVED }, Content::Moved)
        }
        schema::BEACON if postcard_bytes => match bus::<ToAgent>(data) {
            Some(ToAgent::Beacon(b)) => Content::Beacon { robot: b.robot.0, x: b.x, y: b.y },
            _ => Content::Undecodable { schema: schema::BEACON },
        },
        schema::CORE_STATE if encoding == schema::JSON => match serde_json::from_slice::<RobotSlot>(data) {
            Ok(RobotSlot { robot, state }) => Content::State { robot, state },
            Err(_) => Content::Undecodable { schema: schema::CORE_STATE },
        },
        schema::GATE if postcard_bytes => {
            bus(data).map_or(Content::Undecodable { schema: schema::GATE }, Content::Gate)
        }
        schema::OPERATOR if postcard_bytes => {
            bus(data).map_or(Content::Undecodable { schema: schema::OPERATOR }, Content::Operator)
        }
        schema::CORE_SETUP => Content::CoreSetup(schema::CORE_LOG_VERSION, data),
        schema::CORE_CALLS => Content::CoreCalls(schema::CORE_LOG_VERSION, data),
        schema::CORE_SETUP_V1 => Content::CoreSetup(1, data),
        schema::CORE_CALLS_V1 => Content::CoreCalls(1, data),
        schema::NATNET_FRAME => Content::MocapFrame(data),
        schema::NATNET_MODELDEF => Content::MocapModelDef(data),
        _ => Content::Other,
    }
}

/// Decodes a message of a channel read back from a recording.
pub fn decode_message<'a>(channel: &mcap::Channel<'_>, data: &'a [u8]) -> Content<'a> {
    let schema_name = channel.schema.as_ref().map_or("", |s| s.name.as_str());
    decode(&channel.topic, schema_name, &channel.message_encoding, data)
}

fn bus<M: bycoms_protocol::Message>(data: &[u8]) -> Option<M> {
    postcard::<M>(data).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::msg::{GateKind, Tick};
    use bycoms_protocol::{encode, MAX_MESSAGE_LEN};

    #[test]
    fn bus_messages_decode_from_postcard_channels_only() {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        let event = GateEvent { robot: RobotId(2), kind: GateKind::Deployed, x: 1.0, y: 2.0, step: 3 };
        let bytes = encode(&event, &mut buf).expect("encodes");
        assert_eq!(decode("bycoms/s/gate", schema::GATE, schema::POSTCARD, bytes), Content::Gate(event));
        assert_eq!(decode("bycoms/s/gate", schema::GATE, schema::JSON, bytes), Content::Other);
        let garbage = decode("bycoms/s/robot/1/pose", schema::POSE, schema::POSTCARD, &[0xff; 3]);
        assert_eq!(garbage, Content::Undecodable { schema: schema::POSE });
    }

    /// `core/beacon`: the core's beacon table changes, bit for bit; any
    /// other command on it does not decode.
    #[test]
    fn a_beacon_change_decodes_from_its_channel() {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        let at = bycoms_protocol::msg::Beacon { robot: RobotId(3), x: 0.1 + 0.2, y: -1.5, seq: 0 };
        let bytes = encode(&ToAgent::Beacon(at), &mut buf).expect("encodes");
        let got = decode("bycoms/s/core/beacon", schema::BEACON, schema::POSTCARD, bytes);
        assert_eq!(got, Content::Beacon { robot: 3, x: 0.1 + 0.2, y: -1.5 });
        let tick = encode(&ToAgent::Tick(Tick { step: 1 }), &mut buf).expect("encodes").to_vec();
        let other = decode("bycoms/s/core/beacon", schema::BEACON, schema::POSTCARD, &tick);
        assert_eq!(other, Content::Undecodable { schema: schema::BEACON });
    }

    /// `core/state`: a robot's state as the core said it (here a robot
    /// lost before its deployment); bytes that are not one do not decode,
    /// and the scene's JSON of it is not the core's channel.
    #[test]
    fn a_state_change_decodes_from_its_channel() {
        let bytes = br#"{"robot":4,"state":"lost"}"#;
        let got = decode("bycoms/s/core/state", schema::CORE_STATE, schema::JSON, bytes);
        assert_eq!(got, Content::State { robot: 4, state: SlotState::Lost });
        let written = serde_json::to_vec(&RobotSlot { robot: 2, state: SlotState::Unfinished }).unwrap();
        let back = decode("bycoms/s/core/state", schema::CORE_STATE, schema::JSON, &written);
        assert_eq!(back, Content::State { robot: 2, state: SlotState::Unfinished });
        let bad =
            decode("bycoms/s/core/state", schema::CORE_STATE, schema::JSON, br#"{"robot":4,"state":"x"}"#);
        assert_eq!(bad, Content::Undecodable { schema: schema::CORE_STATE });
        assert_eq!(decode("bycoms/s/robot/4/state", schema::ROBOT_SLOT, schema::JSON, bytes), Content::Other);
    }

    #[test]
    fn a_command_belongs_to_the_robot_of_its_topic() {
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        let tick = ToAgent::Tick(Tick { step: 7 });
        let bytes = encode(&tick, &mut buf).expect("encodes");
        let got = decode("bycoms/s/robot/4/to_agent", schema::TO_AGENT, schema::POSTCARD, bytes);
        assert_eq!(got, Content::Command { robot: RobotId(4), command: tick });
        assert_eq!(decode("bycoms/s/to_agent", schema::TO_AGENT, schema::POSTCARD, bytes), Content::Other);
    }

    #[test]
    fn the_run_metadata_is_the_run_topics_only() {
        assert_eq!(decode("bycoms/s/run", schema::RUN, schema::JSON, b"{}"), Content::Run(b"{}"));
        assert_eq!(decode("bycoms/s/other", schema::RUN, schema::JSON, b"{}"), Content::Other);
    }
}
