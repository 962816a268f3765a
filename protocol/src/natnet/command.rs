//! The command channel's small messages: connect, server info, responses.
//!
//! Why the 271-byte connect: the SDK's client sends `NAT_CONNECT` with a
//! 270-byte body ("Ping", zeros, the requested NatNet version at bytes
//! 265..269) plus a NUL; older clients send an empty body. Both are read.
//! The server info is the SDK's packed `sSender_Server`: a 256-byte name,
//! the application and NatNet versions, then the clock frequency, data
//! port and multicast group (279 bytes); the last 15 are optional on read,
//! since the SDK's own Python client reads only the first 264.

use super::wire::{Reader, Writer};
use super::Error;

/// Length of the application-name field of the server info.
pub const SERVER_NAME_LEN: usize = 256;
const CONNECT_BODY_LEN: usize = 270;
const CONNECT_VERSION_AT: usize = 265;

/// A client's `NAT_CONNECT`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ConnectRequest {
    /// The NatNet version the client asks for, when it says.
    pub requested_version: Option<[u8; 4]>,
}

impl ConnectRequest {
    pub(crate) fn read(payload: &[u8]) -> Self {
        let requested_version =
            payload.get(CONNECT_VERSION_AT..CONNECT_VERSION_AT + 4).and_then(|v| <[u8; 4]>::try_from(v).ok());
        Self { requested_version }
    }

    pub(crate) fn write(&self, w: &mut Writer) {
        if let Some(version) = self.requested_version {
            let mut body = [0u8; CONNECT_BODY_LEN + 1];
            body[..4].copy_from_slice(b"Ping");
            body[CONNECT_VERSION_AT..CONNECT_VERSION_AT + 4].copy_from_slice(&version);
            w.buf.extend_from_slice(&body);
        }
    }
}

/// `NAT_SERVERINFO`: who is streaming, in which NatNet version, where.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ServerInfo {
    /// Host application name (e.g. "Motive"), at most 255 bytes.
    pub app_name: String,
    /// Host application version, major.minor.build.revision.
    pub app_version: [u8; 4],
    /// NatNet bitstream version, major.minor.build.revision.
    pub natnet_version: [u8; 4],
    /// Ticks per second of the server's high-resolution clock.
    pub clock_frequency: u64,
    /// The data port frames are sent from.
    pub data_port: u16,
    /// Frames are multicast (else unicast to each connected client).
    pub multicast: bool,
    /// The multicast group, when `multicast`.
    pub multicast_group: [u8; 4],
}

impl ServerInfo {
    pub(crate) fn read(r: &mut Reader<'_>) -> Result<Self, Error> {
        let app_name = r.fixed_str(SERVER_NAME_LEN, "server name")?;
        let app_version =
            [r.u8("app version")?, r.u8("app version")?, r.u8("app version")?, r.u8("app version")?];
        let natnet_version = [
            r.u8("natnet version")?,
            r.u8("natnet version")?,
            r.u8("natnet version")?,
            r.u8("natnet version")?,
        ];
        let mut info = Self {
            app_name,
            app_version,
            natnet_version,
            clock_frequency: 0,
            data_port: 0,
            multicast: false,
            multicast_group: [0; 4],
        };
        if r.remaining() >= 15 {
            info.clock_frequency = r.u64("clock frequency")?;
            info.data_port = r.u16("data port")?;
            info.multicast = r.u8("multicast flag")? != 0;
            for byte in &mut info.multicast_group {
                *byte = r.u8("multicast group")?;
            }
        }
        Ok(info)
    }

    pub(crate) fn write(&self, w: &mut Writer) -> Result<(), Error> {
        w.fixed_str(&self.app_name, SERVER_NAME_LEN, "server name")?;
        w.buf.extend_from_slice(&self.app_version);
        w.buf.extend_from_slice(&self.natnet_version);
        w.u64(self.clock_frequency);
        w.u16(self.data_port);
        w.u8(u8::from(self.multicast));
        w.buf.extend_from_slice(&self.multicast_group);
        Ok(())
    }

    /// The bitstream version frames will be sent in.
    pub fn version(&self) -> super::Version {
        super::Version { major: self.natnet_version[0], minor: self.natnet_version[1] }
    }
}

/// `NAT_RESPONSE`: a 4-byte result code, or text (e.g. "Bitstream,4.1").
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Response {
    /// A numeric result (0: success).
    Code(i32),
    /// A text answer.
    Text(String),
}

impl Response {
    pub(crate) fn read(payload: &[u8]) -> Result<Self, Error> {
        if let Ok(code) = <[u8; 4]>::try_from(payload) {
            return Ok(Self::Code(i32::from_le_bytes(code)));
        }
        read_text(payload, "response").map(Self::Text)
    }

    pub(crate) fn write(&self, w: &mut Writer) -> Result<(), Error> {
        match self {
            Self::Code(code) => w.i32(*code),
            // A 3-byte text plus its NUL would read back as a code: it goes
            // without the NUL (3 bytes), which `read_text` reads to the end.
            // (Found by the `natnet` fuzz target: a parsed 3-byte text
            // response could not be encoded.)
            Self::Text(text) if text.len() == 3 => {
                if text.as_bytes().contains(&0) {
                    return Err(Error::InteriorNul { what: "response" });
                }
                text.bytes().for_each(|b| w.u8(b));
            }
            Self::Text(text) => w.cstr(text, "response")?,
        }
        Ok(())
    }
}

/// A text payload up to its first NUL (or the end, if none).
pub(crate) fn read_text(payload: &[u8], what: &'static str) -> Result<String, Error> {
    let end = payload.iter().position(|&b| b == 0).unwrap_or(payload.len());
    core::str::from_utf8(&payload[..end]).map(str::to_owned).map_err(|_| Error::NotUtf8 { what, at: 0 })
}
