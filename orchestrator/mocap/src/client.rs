//! A NatNet client: command channel and data stream over UDP.
//!
//! Why blocking std sockets with timeouts: one client, one server, ~120
//! frames a second; the caller (the pose source) polls with a timeout.
//! Unicast as Motive does it: the client's command socket connects, frames
//! arrive on it, and a keep-alive every second keeps the subscription.
//! Multicast: frames arrive on a data socket joined to the group.

use bycoms_protocol::natnet::{
    encode_packet, parse_packet_versioned, ConnectRequest, Error as NatNetError, FrameOfData,
    ModelDefinitions, Packet, ServerInfo, Version,
};
use serde::{Deserialize, Serialize};
use std::net::{IpAddr, Ipv4Addr, SocketAddr, SocketAddrV4, UdpSocket};
use std::time::{Duration, Instant};

const KEEPALIVE_EVERY: Duration = Duration::from_secs(1);
/// Largest NatNet datagram (the u16 length plus header).
const MAX_DATAGRAM: usize = 65_540;

/// Where and how to reach the NatNet server.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ClientConfig {
    /// The server's command channel (Motive: port 1510).
    pub server: SocketAddr,
    /// Local address to bind (default 0.0.0.0).
    #[serde(default = "any_ip")]
    pub local: IpAddr,
    /// Receive frames from this multicast group instead of by unicast
    /// (Motive's default "239.255.42.99:1511").
    #[serde(default)]
    pub multicast: Option<SocketAddrV4>,
    /// How long to wait for each command reply, ms.
    #[serde(default = "reply_ms")]
    pub reply_timeout_ms: u64,
}

fn any_ip() -> IpAddr {
    IpAddr::V4(Ipv4Addr::UNSPECIFIED)
}

fn reply_ms() -> u64 {
    1000
}

/// Why the client failed.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// A socket operation failed.
    #[error("NatNet socket: {0}")]
    Io(#[from] std::io::Error),
    /// The server did not answer in time.
    #[error("NatNet server at {server} did not answer {what} within {timeout:?}")]
    Timeout {
        /// The request.
        what: &'static str,
        /// The server.
        server: SocketAddr,
        /// How long we waited.
        timeout: Duration,
    },
    /// A request could not be encoded.
    #[error("NatNet: {0}")]
    Encode(#[from] NatNetError),
}

/// A connected NatNet client.
pub struct NatNetClient {
    command: UdpSocket,
    data: Option<UdpSocket>,
    server: SocketAddr,
    info: ServerInfo,
    reply_timeout: Duration,
    last_keepalive: Instant,
    inbox: Inbox,
}

/// The receive buffer, what the last datagram was and when it came.
struct Inbox {
    buf: Vec<u8>,
    /// Length of the last datagram that parsed.
    len: usize,
    /// When it was received (before parsing).
    at: Instant,
    bad_packets: u64,
}

impl Inbox {
    fn recv(
        &mut self,
        socket: &UdpSocket,
        timeout: Duration,
        version: Version,
    ) -> Result<Option<Packet>, ClientError> {
        // Zero: only what has already arrived (a read timeout of zero
        // would mean "forever").
        socket.set_nonblocking(timeout.is_zero())?;
        if !timeout.is_zero() {
            socket.set_read_timeout(Some(timeout))?;
        }
        match socket.recv_from(&mut self.buf) {
            Ok((n, _)) => {
                let at = Instant::now();
                match parse_packet_versioned(&self.buf[..n], version) {
                    Ok(p) => {
                        (self.len, self.at) = (n, at);
                        Ok(Some(p))
                    }
                    Err(e) => {
                        self.bad_packets += 1;
                        tracing::warn!(error = %e, "bad NatNet packet ignored");
                        Ok(None)
                    }
                }
            }
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                Ok(None)
            }
            Err(e) => Err(e.into()),
        }
    }
}

impl NatNetClient {
    /// Connects: sends `NAT_CONNECT` and waits for the server info.
    pub fn connect(config: &ClientConfig) -> Result<Self, ClientError> {
        let command = UdpSocket::bind(SocketAddr::new(config.local, 0))?;
        let data = match config.multicast {
            Some(group) => {
                let s = UdpSocket::bind(SocketAddr::new(config.local, group.port()))?;
                let iface = match config.local {
                    IpAddr::V4(v4) => v4,
                    IpAddr::V6(_) => Ipv4Addr::UNSPECIFIED,
                };
                s.join_multicast_v4(group.ip(), &iface)?;
                Some(s)
            }
            None => None,
        };
        let reply_timeout = Duration::from_millis(config.reply_timeout_ms);
        let placeholder = ServerInfo {
            app_name: String::new(),
            app_version: [0; 4],
            natnet_version: [4, 1, 0, 0],
            clock_frequency: 0,
            data_port: 0,
            multicast: false,
            multicast_group: [0; 4],
        };
        let mut client = Self {
            command,
            data,
            server: config.server,
            info: placeholder,
            reply_timeout,
            last_keepalive: Instant::now(),
            inbox: Inbox { buf: vec![0; MAX_DATAGRAM], len: 0, at: Instant::now(), bad_packets: 0 },
        };
        let request = ConnectRequest { requested_version: Some([4, 1, 0, 0]) };
        let info = client.ask(&Packet::Connect(request), "NAT_CONNECT", |p| match p {
            Packet::ServerInfo(info) => Some(info),
            _ => None,
        })?;
        tracing::info!(app = %info.app_name, version = ?info.natnet_version, "NatNet server connected");
        client.info = info;
        Ok(client)
    }

    /// The server's info (application, NatNet version, data port).
    pub fn server_info(&self) -> &ServerInfo {
        &self.info
    }

    /// The bitstream version frames are parsed in.
    pub fn version(&self) -> Version {
        self.info.version()
    }

    /// Packets that failed to parse so far.
    pub fn bad_packets(&self) -> u64 {
        self.inbox.bad_packets
    }

    /// The datagram of the frame [`NatNetClient::next_frame`] returned
    /// last, byte for byte (to record it), and when it was received —
    /// before parsing, so latencies measured from it include the parse.
    pub fn last_frame(&self) -> (&[u8], Instant) {
        (&self.inbox.buf[..self.inbox.len], self.inbox.at)
    }

    /// Asks for and returns the model definitions (names of the bodies).
    pub fn model_definitions(&mut self) -> Result<ModelDefinitions, ClientError> {
        self.ask(&Packet::RequestModelDef, "NAT_REQUEST_MODELDEF", |p| match p {
            Packet::ModelDef(defs) => Some(defs),
            _ => None,
        })
    }

    fn send(&self, packet: &Packet) -> Result<(), ClientError> {
        let bytes = encode_packet(packet, self.version())?;
        self.command.send_to(&bytes, self.server)?;
        Ok(())
    }

    /// Sends `packet` (three tries) and waits for the reply `pick` accepts.
    fn ask<T>(
        &mut self,
        packet: &Packet,
        what: &'static str,
        pick: impl Fn(Packet) -> Option<T>,
    ) -> Result<T, ClientError> {
        for _ in 0..3 {
            self.send(packet)?;
            let deadline = Instant::now() + self.reply_timeout;
            while let Some(left) = deadline.checked_duration_since(Instant::now()) {
                if let Some(p) = self.recv_on_command(left)? {
                    if let Some(found) = pick(p) {
                        return Ok(found);
                    }
                }
            }
        }
        Err(ClientError::Timeout { what, server: self.server, timeout: self.reply_timeout })
    }

    fn recv_on_command(&mut self, timeout: Duration) -> Result<Option<Packet>, ClientError> {
        self.inbox.recv(&self.command, timeout, self.info.version())
    }

    /// The next frame of data, or `None` if none came within `timeout`.
    pub fn next_frame(&mut self, timeout: Duration) -> Result<Option<FrameOfData>, ClientError> {
        let deadline = Instant::now() + timeout;
        loop {
            if self.data.is_none() && self.last_keepalive.elapsed() >= KEEPALIVE_EVERY {
                self.send(&Packet::KeepAlive)?;
                self.last_keepalive = Instant::now();
            }
            let left = deadline.saturating_duration_since(Instant::now()).min(KEEPALIVE_EVERY);
            let version = self.info.version();
            let socket = self.data.as_ref().unwrap_or(&self.command);
            match self.inbox.recv(socket, left, version)? {
                Some(Packet::FrameOfData(frame)) => return Ok(Some(frame)),
                // Another packet: look again (within the deadline).
                Some(_) => {}
                None if Instant::now() >= deadline => return Ok(None),
                None => {}
            }
        }
    }
}

impl Drop for NatNetClient {
    fn drop(&mut self) {
        let _ = self.send(&Packet::Disconnect);
    }
}
