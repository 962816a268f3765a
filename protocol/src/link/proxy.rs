//! A UDP fault proxy for the robot link: it sits in front of a gateway, and
//! every datagram between the robot and the gateway passes through a seeded
//! [`FaultQueue`] per direction (drop, delay, duplicate, reorder), or is cut
//! altogether while the link is cut.
//!
//! Why a proxy and not a wrapper inside the link code: the link is sans-IO
//! and the firmware, the emulated ESP32 and the gateway each own their
//! socket. A proxy between them injects faults into any of them — the
//! emulator today, a real robot on a bench tomorrow — without a line of
//! fault code in the products, exactly as the bus's fault layer wraps any
//! bus backend; the decisions are the same ([`crate::fault`]).
//!
//! Deployment: the robot is told the proxy's [`LinkProxy::robot_side`]
//! address as its gateway; the proxy forwards to the real gateway from its
//! gateway-side socket, so the gateway sees the proxy as the robot and
//! answers it. The robot's address is learnt from its first datagram.

use crate::fault::{FaultConfig, FaultQueue, FaultStats};
use core::net::SocketAddr;
use core::sync::atomic::{AtomicBool, Ordering};
use core::time::Duration;
use std::io;
use std::net::UdpSocket;
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::Instant;

/// Longest the proxy's thread sleeps on a socket before it looks at its
/// queues and its stop flag.
const POLL: Duration = Duration::from_millis(1);

/// What the proxy did, per direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ProxyStats {
    /// Robot → gateway faults.
    pub to_gateway: FaultStats,
    /// Gateway → robot faults.
    pub to_robot: FaultStats,
    /// Datagrams lost because the link was cut (both directions).
    pub cut: u64,
}

#[derive(Default)]
struct Shared {
    stats: ProxyStats,
}

/// A running fault proxy; stops its thread when dropped.
pub struct LinkProxy {
    robot_side: SocketAddr,
    stop: Arc<AtomicBool>,
    cut: Arc<AtomicBool>,
    shared: Arc<Mutex<Shared>>,
    thread: Option<JoinHandle<()>>,
}

impl LinkProxy {
    /// Starts a proxy in front of the gateway at `gateway`, its sockets bound
    /// on `gateway`'s IP with ports chosen by the OS. Fails on a fault rate
    /// outside `0..=1` or a socket error.
    pub fn start(gateway: SocketAddr, faults: FaultConfig) -> io::Result<Self> {
        faults.validate().map_err(|why| io::Error::new(io::ErrorKind::InvalidInput, why))?;
        let robot_sock = UdpSocket::bind((gateway.ip(), 0))?;
        let gateway_sock = UdpSocket::bind((gateway.ip(), 0))?;
        robot_sock.set_nonblocking(true)?;
        gateway_sock.set_read_timeout(Some(POLL))?;
        let robot_side = robot_sock.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let cut = Arc::new(AtomicBool::new(false));
        let shared = Arc::new(Mutex::new(Shared::default()));
        let pump = Pump {
            robot_sock,
            gateway_sock,
            gateway,
            robot: None,
            to_gateway: FaultQueue::new(faults, 0),
            to_robot: FaultQueue::new(faults, 1),
            stop: Arc::clone(&stop),
            cut: Arc::clone(&cut),
            shared: Arc::clone(&shared),
        };
        let thread = std::thread::Builder::new().name("link-proxy".into()).spawn(move || pump.run())?;
        Ok(Self { robot_side, stop, cut, shared, thread: Some(thread) })
    }

    /// The address to give the robot as its gateway.
    pub fn robot_side(&self) -> SocketAddr {
        self.robot_side
    }

    /// Cuts the link (every datagram is lost) or restores it.
    pub fn set_cut(&self, cut: bool) {
        self.cut.store(cut, Ordering::SeqCst);
    }

    /// What the proxy did so far.
    pub fn stats(&self) -> ProxyStats {
        self.shared.lock().unwrap_or_else(PoisonError::into_inner).stats
    }
}

impl Drop for LinkProxy {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

struct Pump {
    robot_sock: UdpSocket,
    gateway_sock: UdpSocket,
    gateway: SocketAddr,
    robot: Option<SocketAddr>,
    to_gateway: FaultQueue,
    to_robot: FaultQueue,
    stop: Arc<AtomicBool>,
    cut: Arc<AtomicBool>,
    shared: Arc<Mutex<Shared>>,
}

impl Pump {
    fn run(mut self) {
        let mut buf = [0u8; 2048];
        while !self.stop.load(Ordering::SeqCst) {
            let now = Instant::now();
            let cut = self.cut.load(Ordering::SeqCst);
            let mut lost = 0;
            // Robot → gateway (non-blocking).
            while let Ok((n, from)) = self.robot_sock.recv_from(&mut buf) {
                self.robot = Some(from);
                match cut {
                    true => lost += 1,
                    false => self.to_gateway.admit(buf.get(..n).unwrap_or_default(), now),
                }
            }
            // Gateway → robot (waits up to POLL: the loop's pace).
            if let Ok((n, from)) = self.gateway_sock.recv_from(&mut buf) {
                if from == self.gateway {
                    match cut {
                        true => lost += 1,
                        false => self.to_robot.admit(buf.get(..n).unwrap_or_default(), Instant::now()),
                    }
                }
            }
            let now = Instant::now();
            while let Some(d) = self.to_gateway.take_due(now) {
                let _ = self.gateway_sock.send_to(&d, self.gateway);
            }
            while let Some(d) = self.to_robot.take_due(now) {
                if let Some(robot) = self.robot {
                    let _ = self.robot_sock.send_to(&d, robot);
                }
            }
            let mut shared = self.shared.lock().unwrap_or_else(PoisonError::into_inner);
            shared.stats.to_gateway = self.to_gateway.stats();
            shared.stats.to_robot = self.to_robot.stats();
            shared.stats.cut += lost;
        }
    }
}
