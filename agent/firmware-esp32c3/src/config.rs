//! The robot's flashed configuration: its id, its link key, its tones, the
//! WiFi network and the gateway's address. Never in the source or the
//! image: a text file written to the `bycoms` data partition
//! (`partitions.csv`) with `espflash write-bin`, one `name = value` per
//! line, `#` starts a comment (so no `#` in a password), erased flash
//! (0xFF) or a NUL ends it:
//!
//! ```text
//! robot = 3
//! key = 7a773216fd2653b61a0269248815e73f2a925de326b72386fa856f25b6abaf29
//! tone = 512
//! others = 224, 320
//! ssid = lab
//! password = correct horse battery staple
//! gateway = 192.168.4.10:47003
//! port = 47003
//! ```
//!
//! `key` is the robot's key file (`openssl rand -hex 32`, the same file the
//! gateway's `--key-file` reads); `gateway` is the address the gateway's
//! `--bind` listens on; `port` the robot's own UDP port (default 47000).

use alloc::string::String;
use bycoms_agent::firmware::FirmwareConfig;
use bycoms_protocol::RobotId;
use core::net::{Ipv4Addr, SocketAddrV4};
use esp_bootloader_esp_idf::partitions::{self, PARTITION_TABLE_MAX_LEN};
use esp_storage::FlashStorage;

/// The partition's label in `partitions.csv`.
pub const PARTITION: &str = "bycoms";

/// Other tones the robot listens for (the emulated lab's robots: two).
pub const LISTENED: usize = 2;

/// What the robot is configured with.
pub struct Config {
    /// Robot id.
    pub robot: u32,
    /// The link key.
    pub key: [u8; 32],
    /// Own tone, Hz.
    pub tone: u32,
    /// The other robots' tones, Hz.
    pub others: [u32; LISTENED],
    /// WiFi network.
    pub ssid: String,
    /// WiFi password (WPA2-Personal; empty = open network).
    pub password: String,
    /// The gateway's UDP address.
    pub gateway: SocketAddrV4,
    /// The robot's own UDP port.
    pub port: u16,
}

impl Config {
    /// The core's configuration: the paper robot with this id and these tones.
    pub fn firmware(&self) -> FirmwareConfig<LISTENED> {
        FirmwareConfig::paper(RobotId(self.robot), f64::from(self.tone), self.others.map(f64::from))
    }
}

/// Why there is no configuration.
#[derive(Debug)]
pub enum ConfigError {
    /// The partition table or the partition could not be read.
    Flash(partitions::Error),
    /// No partition labelled [`PARTITION`].
    NoPartition,
    /// A line is not `name = value`, or a value is malformed: the line number.
    Line(usize),
    /// A required name is missing.
    Missing(&'static str),
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Flash(e) => write!(f, "flash: {e:?}"),
            Self::NoPartition => write!(f, "no partition labelled '{PARTITION}'"),
            Self::Line(n) => write!(f, "line {n} is not a known `name = value`"),
            Self::Missing(name) => write!(f, "'{name}' is missing"),
        }
    }
}

/// Reads and parses the configuration partition.
pub fn read(flash: esp_hal::peripherals::FLASH<'static>) -> Result<Config, ConfigError> {
    let mut flash = FlashStorage::new(flash);
    let mut table = [0u8; PARTITION_TABLE_MAX_LEN];
    let table = partitions::read_partition_table(&mut flash, &mut table).map_err(ConfigError::Flash)?;
    let entry = table.iter().find(|e| e.label_as_str() == PARTITION).ok_or(ConfigError::NoPartition)?;
    let mut text = [0u8; 1024];
    entry.as_flash_region(&mut flash).read(0, &mut text).map_err(ConfigError::Flash)?;
    parse(&text)
}

/// Parses the configuration text (up to the first 0xFF or NUL).
pub fn parse(bytes: &[u8]) -> Result<Config, ConfigError> {
    let end = bytes.iter().position(|&b| b == 0xFF || b == 0).unwrap_or(bytes.len());
    let text = core::str::from_utf8(&bytes[..end]).map_err(|_| ConfigError::Line(0))?;
    let (mut robot, mut key, mut tone, mut others) = (None, None, None, None);
    let (mut ssid, mut password, mut gateway, mut port) = (None, String::new(), None, 47000u16);
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let bad = ConfigError::Line(n + 1);
        let (name, value) = line.split_once('=').ok_or(ConfigError::Line(n + 1))?;
        let value = value.trim();
        match name.trim() {
            "robot" => robot = Some(value.parse::<u32>().map_err(|_| bad)?),
            "key" => key = Some(hex_key(value).ok_or(bad)?),
            "tone" => tone = Some(value.parse::<u32>().map_err(|_| bad)?),
            "others" => {
                let mut it = value.split(',').map(|t| t.trim().parse::<u32>());
                match (it.next(), it.next(), it.next()) {
                    (Some(Ok(a)), Some(Ok(b)), None) => others = Some([a, b]),
                    _ => return Err(bad),
                }
            }
            "ssid" => ssid = Some(String::from(value)),
            "password" => password = String::from(value),
            "gateway" => {
                let (ip, p) = value.rsplit_once(':').ok_or(ConfigError::Line(n + 1))?;
                let ip: Ipv4Addr = ip.parse().map_err(|_| ConfigError::Line(n + 1))?;
                gateway = Some(SocketAddrV4::new(ip, p.parse().map_err(|_| ConfigError::Line(n + 1))?));
            }
            "port" => port = value.parse().map_err(|_| bad)?,
            _ => return Err(bad),
        }
    }
    Ok(Config {
        robot: robot.ok_or(ConfigError::Missing("robot"))?,
        key: key.ok_or(ConfigError::Missing("key"))?,
        tone: tone.ok_or(ConfigError::Missing("tone"))?,
        others: others.ok_or(ConfigError::Missing("others"))?,
        ssid: ssid.ok_or(ConfigError::Missing("ssid"))?,
        password,
        gateway: gateway.ok_or(ConfigError::Missing("gateway"))?,
        port,
    })
}

/// 64 hex digits → 32 bytes.
fn hex_key(s: &str) -> Option<[u8; 32]> {
    let s = s.as_bytes();
    if s.len() != 64 {
        return None;
    }
    let digit = |c: u8| (c as char).to_digit(16).map(|d| d as u8);
    let mut key = [0u8; 32];
    for (i, k) in key.iter_mut().enumerate() {
        *k = digit(s[2 * i])? << 4 | digit(s[2 * i + 1])?;
    }
    Some(key)
}
