//! The protocol crate's integration tests, as one test binary.
//!
//! Why one binary: each file here used to be its own test target, and each
//! compiled and linked its own copy of zenoh and iceoryx2; as modules of one
//! binary they build and link once. Run one file's tests with
//! `cargo test -p bycoms-protocol --test integration golden::`. A new file
//! here is added as a module below (`autotests = false`).

mod bus_conformance;
mod bus_fault;
mod codec_canonical;
mod codec_errors;
mod conformance;
mod golden;
mod ipc_cleanup;
mod link_proxy;
mod roundtrip;
mod zenoh_bus;
mod zenoh_liveliness;
mod zenoh_settings;
