//! Wire types and identifiers shared by every BYCOMS process, and the bus
//! that carries them.
//!
//! Why one crate: the orchestrator, the simulated and real agents and the
//! ESP32 firmware must agree byte for byte on what travels between them, so
//! the messages ([`msg`]), their one encode/decode pair ([`codec`]) and the
//! topic names ([`naming`]) live in a single place with golden-byte tests.
//!
//! The core is `no_std` and allocation-free so the same types compile into
//! firmware. Behind features:
//!
//! The robot link ([`link`]: authenticated UDP frames between an ESP32
//! robot and its gateway) is part of the no_std core.
//!
//! * `std` (default): the transport interface [`bus`] with its in-memory
//!   backend, and `encode_vec`;
//! * `ipc`: the iceoryx2 shared-memory backend `bus::ipc`;
//! * `natnet`: the OptiTrack NatNet 4.x codec [`natnet`] (motion capture).
//!
//! Error types implement `core::error::Error` (the same trait as
//! `std::error::Error`) with or without `std`.
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![warn(clippy::std_instead_of_core, clippy::alloc_instead_of_core)]

#[cfg(feature = "std")]
pub mod capped;
pub mod clock_limits;
pub mod codec;
pub mod ids;
pub mod link;
pub mod msg;
pub mod naming;
pub mod sans_io;

#[cfg(feature = "std")]
pub mod bus;
#[cfg(feature = "std")]
pub mod fault;
#[cfg(feature = "natnet")]
pub mod natnet;

#[cfg(feature = "std")]
pub use codec::encode_vec;
pub use codec::{decode, encode, CodecError, Message, MAX_MESSAGE_LEN, PROTOCOL_VERSION};
pub use ids::RobotId;
pub use naming::{NameError, Swarm, Topic, TopicName};
pub use sans_io::{Micros, SansIo};
