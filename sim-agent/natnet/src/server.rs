//! The NatNet server's sockets: a command channel and a data stream.
//!
//! Why two threads and blocking std sockets: the emulator serves a handful
//! of clients at ~120 Hz; a command thread (connect, model definitions,
//! keep-alive) and a stream thread (one frame per period) are all it needs,
//! without pulling an async runtime into the simulator crate.
//!
//! Unicast as Motive does it: a client that sends `NAT_CONNECT` (or a
//! keep-alive) from its command socket is subscribed, and frames go to that
//! address from the server's *data* socket (libNatNet routes unicast frames
//! by their source port). A client silent for [`CLIENT_TIMEOUT`] is dropped.

use super::config::ServerConfig;
use super::frames::{model_definitions, BodyPose, FrameMaker};
use bycoms_protocol::natnet::{
    encode_packet, parse_packet, Error as NatNetError, Packet, Response, ServerInfo, Version,
};
use std::net::{IpAddr, SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A unicast client that stays silent this long is unsubscribed.
pub const CLIENT_TIMEOUT: Duration = Duration::from_secs(10);
/// The bitstream version served.
pub const SERVED_VERSION: Version = Version::V4_1;
const POLL: Duration = Duration::from_millis(20);

/// Why the server could not start.
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    /// The configuration is invalid.
    #[error("invalid NatNet server config: {0}")]
    Config(String),
    /// A socket could not be bound or configured.
    #[error("NatNet server socket: {0}")]
    Io(#[from] std::io::Error),
    /// A message could not be encoded (e.g. a name too long).
    #[error("NatNet server encoding: {0}")]
    Encode(#[from] NatNetError),
}

struct Shared {
    poses: Mutex<Vec<BodyPose>>,
    /// Per body (config order): in the cameras' view.
    seen: Mutex<Vec<bool>>,
    clients: Mutex<Vec<(SocketAddr, Instant)>>,
    last_frame: Mutex<Option<Vec<u8>>>,
    stop: AtomicBool,
}

/// A running NatNet server; stops (and joins its threads) when dropped.
pub struct NatNetServer {
    command_addr: SocketAddr,
    data_addr: SocketAddr,
    ids: Vec<i32>,
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
}

impl NatNetServer {
    /// Binds the command socket at `command` (port 0: any) and a data
    /// socket on the same address, and starts serving `config`'s bodies.
    pub fn start(config: ServerConfig, command: SocketAddr) -> Result<Self, ServerError> {
        Self::start_at_speed(config, command, 1.0)
    }

    /// [`NatNetServer::start`] for a world running `speed` times faster
    /// than real time (the emulated lab at `--speed`): frames leave every
    /// 1 / (rate × speed) s of wall time and are stamped in the world's
    /// time (frame k at k / rate s), so a client sees the world's rate and
    /// clock.
    pub fn start_at_speed(
        config: ServerConfig,
        command: SocketAddr,
        speed: f64,
    ) -> Result<Self, ServerError> {
        config.validate().map_err(ServerError::Config)?;
        if !(speed.is_finite() && speed > 0.0 && config.rate_hz * speed <= 10_000.0) {
            return Err(ServerError::Config(format!(
                "speed must be positive and rate × speed ≤ 10000, got {speed}"
            )));
        }
        let command_socket = UdpSocket::bind(command)?;
        command_socket.set_read_timeout(Some(POLL))?;
        let data_socket = UdpSocket::bind(SocketAddr::new(command.ip(), 0))?;
        if config.multicast.is_some() {
            data_socket.set_multicast_loop_v4(true)?;
        }
        let command_addr = command_socket.local_addr()?;
        let data_addr = data_socket.local_addr()?;
        let info = ServerInfo {
            app_name: config.app_name.clone(),
            app_version: [3, 1, 0, 0],
            natnet_version: [SERVED_VERSION.major, SERVED_VERSION.minor, 0, 0],
            clock_frequency: 1_000_000_000,
            data_port: data_addr.port(),
            multicast: config.multicast.is_some(),
            multicast_group: config.multicast.map_or([0; 4], |g| g.ip().octets()),
        };
        let server_info = encode_packet(&Packet::ServerInfo(info), SERVED_VERSION)?;
        let model_def = encode_packet(&Packet::ModelDef(model_definitions(&config)), SERVED_VERSION)?;
        let poses =
            config.bodies.iter().map(|b| BodyPose::yawed(b.position, b.yaw_deg.to_radians())).collect();
        let shared = Arc::new(Shared {
            seen: Mutex::new(vec![true; config.bodies.len()]),
            poses: Mutex::new(poses),
            clients: Mutex::new(Vec::new()),
            last_frame: Mutex::new(None),
            stop: AtomicBool::new(false),
        });
        let ids = config.bodies.iter().map(|b| b.id).collect();
        let command_thread = {
            let shared = Arc::clone(&shared);
            std::thread::Builder::new()
                .name("natnet-command".into())
                .spawn(move || serve_commands(&command_socket, &shared, &server_info, &model_def))?
        };
        let stream_thread = {
            let shared = Arc::clone(&shared);
            std::thread::Builder::new()
                .name("natnet-stream".into())
                .spawn(move || stream(&data_socket, &shared, config, speed))?
        };
        tracing::info!(%command_addr, %data_addr, "NatNet server started");
        Ok(Self { command_addr, data_addr, ids, shared, threads: vec![command_thread, stream_thread] })
    }

    /// Start on `ip`, any free command port.
    pub fn start_any_port(config: ServerConfig, ip: IpAddr) -> Result<Self, ServerError> {
        Self::start(config, SocketAddr::new(ip, 0))
    }

    /// Where clients send commands.
    pub fn command_addr(&self) -> SocketAddr {
        self.command_addr
    }

    /// Where frames come from.
    pub fn data_addr(&self) -> SocketAddr {
        self.data_addr
    }

    /// Moves body `id`; false if no such body.
    pub fn set_pose(&self, id: i32, pose: BodyPose) -> bool {
        let Some(k) = self.ids.iter().position(|&b| b == id) else { return false };
        let mut poses = self.shared.poses.lock().unwrap_or_else(PoisonError::into_inner);
        poses[k] = pose;
        true
    }

    /// Puts body `id` in the cameras' view or takes it out (then it is
    /// streamed untracked); false if no such body.
    pub fn set_seen(&self, id: i32, seen: bool) -> bool {
        let Some(k) = self.ids.iter().position(|&b| b == id) else { return false };
        self.shared.seen.lock().unwrap_or_else(PoisonError::into_inner)[k] = seen;
        true
    }

    /// Unicast clients subscribed now.
    pub fn client_count(&self) -> usize {
        self.shared.clients.lock().unwrap_or_else(PoisonError::into_inner).len()
    }
}

impl Drop for NatNetServer {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

fn subscribe(shared: &Shared, from: SocketAddr) {
    let mut clients = shared.clients.lock().unwrap_or_else(PoisonError::into_inner);
    let now = Instant::now();
    match clients.iter_mut().find(|(a, _)| *a == from) {
        Some(entry) => entry.1 = now,
        None => {
            tracing::info!(%from, "NatNet client subscribed");
            clients.push((from, now));
        }
    }
}

fn serve_commands(socket: &UdpSocket, shared: &Shared, server_info: &[u8], model_def: &[u8]) {
    let mut buf = vec![0u8; 65_536];
    while !shared.stop.load(Ordering::Relaxed) {
        let (n, from) = match socket.recv_from(&mut buf) {
            Ok(got) => got,
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                continue
            }
            Err(e) => {
                tracing::warn!(error = %e, "NatNet command socket");
                continue;
            }
        };
        let reply = match parse_packet(&buf[..n]) {
            Ok(Packet::Connect(_)) => {
                // Server info first: a client parses frames in the version
                // it announces, so no frame may overtake it.
                if let Err(e) = socket.send_to(server_info, from) {
                    tracing::warn!(%from, error = %e, "NatNet server info not sent");
                }
                subscribe(shared, from);
                None
            }
            Ok(Packet::KeepAlive) => {
                subscribe(shared, from);
                None
            }
            Ok(Packet::RequestModelDef) => Some(model_def.to_vec()),
            Ok(Packet::RequestFrameOfData) => {
                shared.last_frame.lock().unwrap_or_else(PoisonError::into_inner).clone()
            }
            Ok(Packet::Disconnect) => {
                shared.clients.lock().unwrap_or_else(PoisonError::into_inner).retain(|(a, _)| *a != from);
                None
            }
            Ok(Packet::Request(text)) => {
                let answer = if text.eq_ignore_ascii_case("bitstream") {
                    Response::Text(format!("Bitstream,{}.{}", SERVED_VERSION.major, SERVED_VERSION.minor))
                } else {
                    Response::Code(0)
                };
                encode_packet(&Packet::Response(answer), SERVED_VERSION).ok()
            }
            Ok(other) => {
                tracing::warn!(%from, ?other, "NatNet server got a message servers do not take");
                encode_packet(&Packet::UnrecognizedRequest, SERVED_VERSION).ok()
            }
            Err(e) => {
                tracing::warn!(%from, error = %e, "NatNet server got a bad packet");
                None
            }
        };
        if let Some(bytes) = reply {
            if let Err(e) = socket.send_to(&bytes, from) {
                tracing::warn!(%from, error = %e, "NatNet reply not sent");
            }
        }
    }
}

fn stream(socket: &UdpSocket, shared: &Shared, config: ServerConfig, speed: f64) {
    let period = Duration::from_secs_f64(1.0 / (config.rate_hz * speed));
    let group = config.multicast;
    let mut maker = FrameMaker::new(config);
    let start = Instant::now();
    let mut k: u32 = 0;
    while !shared.stop.load(Ordering::Relaxed) {
        let due = start + period * k;
        k = k.wrapping_add(1);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        let poses = shared.poses.lock().unwrap_or_else(PoisonError::into_inner).clone();
        let seen = shared.seen.lock().unwrap_or_else(PoisonError::into_inner).clone();
        let Some(frame) = maker.next_frame_seen(&poses, &seen) else { continue };
        let bytes = match encode_packet(&Packet::FrameOfData(frame), SERVED_VERSION) {
            Ok(bytes) => bytes,
            Err(e) => {
                tracing::warn!(error = %e, "NatNet frame not encodable");
                continue;
            }
        };
        let targets: Vec<SocketAddr> = {
            let mut clients = shared.clients.lock().unwrap_or_else(PoisonError::into_inner);
            clients.retain(|(_, seen)| seen.elapsed() < CLIENT_TIMEOUT);
            clients.iter().map(|(a, _)| *a).chain(group.map(SocketAddr::V4)).collect()
        };
        for to in targets {
            if let Err(e) = socket.send_to(&bytes, to) {
                tracing::debug!(%to, error = %e, "NatNet frame not sent");
            }
        }
        *shared.last_frame.lock().unwrap_or_else(PoisonError::into_inner) = Some(bytes);
    }
}
