//! The robot link: authenticated UDP datagrams between one real robot
//! (ESP32 firmware) and its gateway (the `gateway` binary).
//!
//! Why a protocol of its own and not the bus format: the bus runs between
//! trusted processes on a trusted network; the robot link crosses a WiFi
//! that anyone in the room can sniff, replay into or spoof, and the robot at
//! its end has motors. So every frame carries the robot id, a session id, a
//! sequence number and an authentication tag made with the robot's
//! pre-shared key, and a frame that fails any check is dropped and counted
//! ([`DropReason`], [`DropCounters`]), never acted on. The byte layout is in
//! `protocol/LINK.md`; golden-byte tests pin it.
//!
//! * [`frame`] — the stateless part: [`encode`] and [`decode`] (version,
//!   kind, length, robot id, direction, tag, field validity);
//! * [`session`] — the stateful part: the hello/welcome handshake with fresh
//!   nonces, session ids and replay windows, one state machine per side
//!   ([`RobotLink`], [`GatewayLink`]), sans-IO (time is an argument);
//! * [`drop`] — the typed drop reasons and their counters;
//! * `proxy` (std) — a UDP fault proxy between a robot and its gateway:
//!   seeded drop/delay/duplicate/reorder and cuts, for tests and soak runs;
//! * `key_file` (std) — a robot's key file (`LinkKey::read_file`), read by
//!   the gateway and the lab alike.
//!
//! # Why HMAC-SHA256 (RustCrypto `hmac` + `sha2`)
//!
//! The link needs *authentication*, not secrecy: nothing on it (goal
//! bearings, microphone levels) is confidential, and readable frames make
//! a packet capture debuggable. A MAC is therefore enough, and HMAC-SHA256
//! was chosen over an AEAD (ChaCha20-Poly1305, AES-GCM) because:
//!
//! * it has no nonce to misuse: an AEAD leaks its key stream and allows
//!   forgeries if a (key, nonce) pair ever repeats, which a robot that
//!   reboots with a weak or reset counter could do; HMAC's security does not
//!   depend on any per-frame uniqueness, and freshness is carried separately
//!   by the session id and sequence number, which are authenticated;
//! * it runs everywhere with no allocation: `hmac`/`sha2` are `no_std`,
//!   RustCrypto-maintained, constant-time in the comparison
//!   ([`hmac::Mac::verify_truncated_left`] uses `subtle`), and the ESP32 has
//!   a SHA-256 accelerator should the software speed ever matter (it does
//!   not: a frame costs two to three SHA-256 blocks, see the `link` bench);
//! * the keyed state is computed once per key ([`LinkKey`]) and cloned per
//!   frame, saving two of the four compression calls.
//!
//! The tag is the HMAC truncated to its leftmost [`TAG_LEN`] = 16 bytes
//! (128 bits; RFC 2104 §5 allows truncation to half the output).
//!
//! # Why hand-written byte layout
//!
//! Every frame kind has a fixed size, fields are little-endian at fixed
//! offsets, and the tag covers the exact bytes on the wire. Writing the
//! layout by hand (instead of postcard's varints) keeps it documentable as a
//! table, lets a C or MicroPython peer be written from `LINK.md` alone, and
//! makes "wrong length" a cheap, precise garbage check.

pub mod drop;
pub mod frame;
#[cfg(feature = "std")]
pub mod key_file;
#[cfg(feature = "std")]
pub mod proxy;
pub mod session;

pub use drop::{DropCounters, DropReason};
pub use frame::{
    decode, encode, Direction, EncodeError, Frame, Header, Health, LinkKey, Payload, RobotState, SessionId,
    Telemetry, HEADER_LEN, KEY_LEN, LINK_VERSION, MAX_FRAME_LEN, NONCE_LEN, TAG_LEN,
};
#[cfg(feature = "std")]
pub use key_file::KeyFileError;
pub use session::{Accepted, GatewayEvent, GatewayLink, RobotEvent, RobotLink, SendError};

#[cfg(test)]
mod tests;
