//! One emulated ESP32: the firmware core behind its own UDP socket.
//!
//! Why a real socket: the gateway must not be able to tell the emulator from
//! hardware, so the emulated robot speaks the link protocol over UDP like
//! the robot does (bound to port 0 on localhost: tests never collide). The
//! shell is the one `deploy/esp32/README.md` describes — datagrams in,
//! microphone frames in, motors, tone and datagrams out — with the lab's
//! clock as `now` instead of a hardware timer, so the lab can run faster
//! than real time. The lab clock's time since the lab started is the
//! firmware's time since boot (every robot boots with the lab), in the
//! core's [`Micros`] by [`micros`], the one conversion the lab's shells
//! make (the firmware recorder's too).

use bycoms_agent::firmware::{Firmware, FirmwareConfig, FirmwareInput, MicFrames, Motors};
use bycoms_protocol::link::LinkKey;
use bycoms_protocol::SansIo;
use core::time::Duration;
use std::io;
use std::net::{SocketAddr, UdpSocket};

/// Other tones each emulated robot listens for (the lab's robots know the
/// whole swarm's tones except their own; up to three robots).
pub const LISTENED: usize = 2;

/// The lab clock (time since the lab started) as the firmware's time since
/// boot: the runtime's one conversion (the lab's clock moves in whole
/// physics steps, 5 ms, so nothing is rounded).
pub use bycoms_runtime::epoch::micros_of as micros;

/// One emulated robot's microcontroller.
#[derive(Debug)]
pub struct EmulatedEsp32 {
    socket: UdpSocket,
    gateway: SocketAddr,
    firmware: Firmware<LISTENED>,
    /// Datagrams received (all, before any check).
    received: u64,
}

impl EmulatedEsp32 {
    /// Boots the firmware and binds `local` (port 0: any free port);
    /// frames go to `gateway`.
    pub fn bind(
        config: FirmwareConfig<LISTENED>,
        key: LinkKey,
        entropy: [u8; 32],
        local: SocketAddr,
        gateway: SocketAddr,
    ) -> io::Result<Self> {
        let firmware = Firmware::new(config, key, entropy)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e.to_string()))?;
        let socket = UdpSocket::bind(local)?;
        socket.set_nonblocking(true)?;
        Ok(Self { socket, gateway, firmware, received: 0 })
    }

    /// The robot's UDP address.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// The firmware core (state, drops, telemetry).
    pub fn firmware(&self) -> &Firmware<LISTENED> {
        &self.firmware
    }

    /// Datagrams received so far (accepted or not).
    pub fn received(&self) -> u64 {
        self.received
    }

    /// Motor commands now.
    pub fn motors(&self) -> Motors {
        self.firmware.motors()
    }

    /// The tone playing, Hz.
    pub fn tone(&self) -> Option<f64> {
        self.firmware.tone()
    }

    /// Takes every pending datagram, runs the timers, sends what is due.
    pub fn pump(&mut self, now: Duration) -> io::Result<()> {
        let now = micros(now);
        let mut buf = [0u8; 512];
        loop {
            match self.socket.recv_from(&mut buf) {
                Ok((n, _from)) => {
                    self.received += 1;
                    if let Err(reason) = self.firmware.handle(now, FirmwareInput::Datagram(&buf[..n])) {
                        tracing::debug!(%reason, "emulated robot dropped a datagram");
                    }
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                // A previous send to a closed port (ICMP unreachable): ignore.
                Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {}
                Err(e) => return Err(e),
            }
        }
        self.firmware.advance(now);
        self.transmit()
    }

    /// One control period's microphone frames.
    pub fn control(&mut self, frames: &MicFrames, now: Duration) -> io::Result<()> {
        let _ = self.firmware.handle(micros(now), FirmwareInput::Mics(frames));
        self.transmit()
    }

    /// Sends what the firmware has to send at the time of its latest call.
    fn transmit(&mut self) -> io::Result<()> {
        while let Some(frame) = self.firmware.poll() {
            match self.socket.send_to(frame, self.gateway) {
                Ok(_) => {}
                // WiFi drops datagrams too; the link protocol copes.
                Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {}
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }
}
