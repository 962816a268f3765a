//! OptiTrack NatNet 4.x: the binary UDP protocol Motive streams rigid
//! bodies in (paper §VI: five markers per robot, poses sent to the PC).
//!
//! Why here, in `protocol`: the orchestrator reads NatNet (client) and the
//! emulated lab serves it (server, `bycoms-sim`); both must agree byte for
//! byte, as with every other wire format of the project. Behind the
//! `natnet` feature (std: strings and vectors) so the no_std core is
//! untouched.
//!
//! The layout follows the NatNet SDK's reference depacketizer
//! (`NatNetClient.py`, NatNet 4.1, shipped in the PyPI package
//! `natnetsdk` 4.1.1) and the SDK's `sSender_Server` struct: every packet is
//! `[message id: u16][payload length: u16][payload]`, little-endian; a frame
//! of data is prefix (frame number), marker sets, legacy unlabeled markers,
//! rigid bodies, skeletons, assets (4.1+), labeled markers, force plates,
//! devices, then the suffix (timecode, timestamps, params). From 4.1 on each
//! section's count is followed by its byte size. The version is not in the
//! packets: the client learns it from [`ServerInfo`] and must parse with it
//! ([`parse_packet_versioned`]); [`parse_packet`] assumes [`Version::V4_1`].
//!
//! Every parse is bounds-checked and returns a typed [`Error`]; no input can
//! make it panic (a fuzz target drives [`parse_packet`]).

mod command;
mod error;
mod frame;
mod modeldef;
mod version;
mod wire;

pub use command::{ConnectRequest, Response, ServerInfo, SERVER_NAME_LEN};
pub use error::Error;
pub use frame::{
    Asset, Channels, FrameOfData, LabeledMarker, MarkerSet, RigidBody, Skeleton, Suffix, TRACKING_VALID,
};
pub use modeldef::{
    AssetDescription, CameraDescription, DataDescription, MarkerDescription, MarkerSetDescription,
    ModelDefinitions, RigidBodyDescription, RigidBodyMarkerDescription, SkeletonDescription,
};
pub use version::Version;

use wire::{Reader, Writer};

/// Message ids of the NatNet command and data channels.
pub mod message_id {
    /// Client → server: connect, asking for the server info.
    pub const CONNECT: u16 = 0;
    /// Server → client: application name and versions.
    pub const SERVER_INFO: u16 = 1;
    /// Client → server: a text command.
    pub const REQUEST: u16 = 2;
    /// Server → client: the answer to a text command.
    pub const RESPONSE: u16 = 3;
    /// Client → server: send the model definitions.
    pub const REQUEST_MODELDEF: u16 = 4;
    /// Server → client: the model definitions (names of the rigid bodies).
    pub const MODELDEF: u16 = 5;
    /// Client → server: send one frame of data now.
    pub const REQUEST_FRAMEOFDATA: u16 = 6;
    /// Server → client: one frame of motion-capture data.
    pub const FRAMEOFDATA: u16 = 7;
    /// Server → client: a free-text message.
    pub const MESSAGESTRING: u16 = 8;
    /// Client → server: the client leaves.
    pub const DISCONNECT: u16 = 9;
    /// Client → server: keep a unicast subscription alive.
    pub const KEEPALIVE: u16 = 10;
    /// Server → client: the request was not understood.
    pub const UNRECOGNIZED_REQUEST: u16 = 100;
}

/// One NatNet message, either direction.
// A frame is most of the traffic; boxing it would add an allocation per
// datagram to save stack on the rare small messages.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Packet {
    /// `NAT_CONNECT`.
    Connect(ConnectRequest),
    /// `NAT_SERVERINFO`.
    ServerInfo(ServerInfo),
    /// `NAT_REQUEST`: a text command (e.g. `Bitstream`).
    Request(String),
    /// `NAT_RESPONSE`.
    Response(Response),
    /// `NAT_REQUEST_MODELDEF`.
    RequestModelDef,
    /// `NAT_MODELDEF`.
    ModelDef(ModelDefinitions),
    /// `NAT_REQUEST_FRAMEOFDATA`.
    RequestFrameOfData,
    /// `NAT_FRAMEOFDATA`.
    FrameOfData(FrameOfData),
    /// `NAT_MESSAGESTRING`.
    MessageString(String),
    /// `NAT_DISCONNECT`.
    Disconnect,
    /// `NAT_KEEPALIVE`.
    KeepAlive,
    /// `NAT_UNRECOGNIZED_REQUEST`.
    UnrecognizedRequest,
}

/// Parses one datagram as NatNet 4.1 (see [`parse_packet_versioned`]).
pub fn parse_packet(bytes: &[u8]) -> Result<Packet, Error> {
    parse_packet_versioned(bytes, Version::V4_1)
}

/// Parses one datagram; frames and model definitions are read in the
/// layout of `version` (the one the server announced).
pub fn parse_packet_versioned(bytes: &[u8], version: Version) -> Result<Packet, Error> {
    let mut header = Reader::new(bytes);
    let id = header.u16("message id")?;
    let announced = usize::from(header.u16("payload length")?);
    let available = header.remaining();
    if announced > available {
        return Err(Error::LengthMismatch { announced, available });
    }
    // Senders may pad (the SDK's client appends a NUL to empty requests).
    let payload = header.take(announced, "payload")?;
    let mut r = Reader::new(payload);
    let packet = match id {
        message_id::CONNECT => Packet::Connect(ConnectRequest::read(payload)),
        message_id::SERVER_INFO => Packet::ServerInfo(ServerInfo::read(&mut r)?),
        message_id::REQUEST => Packet::Request(command::read_text(payload, "request")?),
        message_id::RESPONSE => Packet::Response(Response::read(payload)?),
        message_id::REQUEST_MODELDEF => Packet::RequestModelDef,
        message_id::MODELDEF => Packet::ModelDef(ModelDefinitions::read(&mut r, version)?),
        message_id::REQUEST_FRAMEOFDATA => Packet::RequestFrameOfData,
        message_id::FRAMEOFDATA => Packet::FrameOfData(FrameOfData::read(&mut r, version)?),
        message_id::MESSAGESTRING => Packet::MessageString(command::read_text(payload, "message string")?),
        message_id::DISCONNECT => Packet::Disconnect,
        message_id::KEEPALIVE => Packet::KeepAlive,
        message_id::UNRECOGNIZED_REQUEST => Packet::UnrecognizedRequest,
        other => return Err(Error::UnknownMessage(other)),
    };
    Ok(packet)
}

/// Encodes one packet (header included) in the layout of `version`.
pub fn encode_packet(packet: &Packet, version: Version) -> Result<Vec<u8>, Error> {
    let mut w = Writer::default();
    w.u16(0);
    w.u16(0);
    let id = match packet {
        Packet::Connect(c) => {
            c.write(&mut w);
            message_id::CONNECT
        }
        Packet::ServerInfo(s) => {
            s.write(&mut w)?;
            message_id::SERVER_INFO
        }
        Packet::Request(text) => {
            w.cstr(text, "request")?;
            message_id::REQUEST
        }
        Packet::Response(resp) => {
            resp.write(&mut w)?;
            message_id::RESPONSE
        }
        Packet::RequestModelDef => message_id::REQUEST_MODELDEF,
        Packet::ModelDef(defs) => {
            defs.write(&mut w, version)?;
            message_id::MODELDEF
        }
        Packet::RequestFrameOfData => message_id::REQUEST_FRAMEOFDATA,
        Packet::FrameOfData(frame) => {
            frame.write(&mut w, version)?;
            message_id::FRAMEOFDATA
        }
        Packet::MessageString(text) => {
            w.cstr(text, "message string")?;
            message_id::MESSAGESTRING
        }
        Packet::Disconnect => message_id::DISCONNECT,
        Packet::KeepAlive => message_id::KEEPALIVE,
        Packet::UnrecognizedRequest => message_id::UNRECOGNIZED_REQUEST,
    };
    let len = u16::try_from(w.buf.len() - 4).map_err(|_| Error::TooLarge { what: "packet" })?;
    w.buf[0..2].copy_from_slice(&id.to_le_bytes());
    w.buf[2..4].copy_from_slice(&len.to_le_bytes());
    Ok(w.buf)
}

#[cfg(test)]
mod tests;
