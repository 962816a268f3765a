//! The conformance suite (tests/conformance) against every bus backend.

use crate::conformance;

use bycoms_protocol::bus::memory::MemoryBus;
use bycoms_protocol::bus::Limits;
use std::sync::OnceLock;

/// One in-memory bus shared by all threads of this test binary (topics are
/// unique per test), so the two-thread checks meet on the same hub.
fn memory() -> MemoryBus {
    static BUS: OnceLock<MemoryBus> = OnceLock::new();
    BUS.get_or_init(|| MemoryBus::new(Limits::default()).expect("valid limits")).clone()
}

/// A small buffer, so the overflow checks cross it quickly.
fn memory_small() -> MemoryBus {
    static BUS: OnceLock<MemoryBus> = OnceLock::new();
    BUS.get_or_init(|| MemoryBus::new(Limits { max_payload: 32, buffer: 4 }).expect("valid limits")).clone()
}

crate::conformance_suite!(memory_default, crate::bus_conformance::memory);
crate::conformance_suite!(memory_small_limits, crate::bus_conformance::memory_small);

#[cfg(feature = "ipc")]
mod ipc_backends {
    use bycoms_protocol::bus::ipc::{IpcBus, IpcConfig, IpcThreadsafeBus, Wake};
    use bycoms_protocol::bus::Limits;
    use core::time::Duration;

    /// Each call opens its own node: `IpcBus` is confined to its thread.
    pub fn ipc_event() -> IpcBus {
        IpcBus::new(IpcConfig::default()).expect("iceoryx2 node")
    }

    pub fn ipc_poll() -> IpcBus {
        let wake = Wake::Poll { spin: Duration::from_micros(20), max_sleep: Duration::from_millis(1) };
        IpcBus::new(IpcConfig { wake, ..IpcConfig::default() }).expect("iceoryx2 node")
    }

    pub fn ipc_small() -> IpcBus {
        let limits = Limits { max_payload: 32, buffer: 4 };
        IpcBus::new(IpcConfig { limits, ..IpcConfig::default() }).expect("iceoryx2 node")
    }

    pub fn ipc_threadsafe() -> IpcThreadsafeBus {
        IpcThreadsafeBus::new(IpcConfig::default()).expect("iceoryx2 node")
    }

    crate::conformance_suite!(ipc_event_wake, crate::bus_conformance::ipc_backends::ipc_event);
    crate::conformance_suite!(ipc_poll_wake, crate::bus_conformance::ipc_backends::ipc_poll);
    crate::conformance_suite!(ipc_small_limits, crate::bus_conformance::ipc_backends::ipc_small);
    crate::conformance_suite!(ipc_threadsafe_service, crate::bus_conformance::ipc_backends::ipc_threadsafe);
}

#[test]
fn memory_rejects_unusable_limits() {
    use bycoms_protocol::bus::BusError;
    let zero_payload = Limits { max_payload: 0, buffer: 4 };
    let zero_buffer = Limits { max_payload: 8, buffer: 0 };
    assert!(matches!(MemoryBus::new(zero_payload), Err(BusError::InvalidConfig(_))));
    assert!(matches!(MemoryBus::new(zero_buffer), Err(BusError::InvalidConfig(_))));
}

#[cfg(feature = "ipc")]
mod ipc_config {
    use super::conformance::unique_topic;
    use bycoms_protocol::bus::ipc::{IpcBus, IpcConfig};
    use bycoms_protocol::bus::{Bus, BusError, Limits};

    #[test]
    fn rejects_unusable_limits() {
        let limits = Limits { max_payload: 0, buffer: 4 };
        let config = IpcConfig { limits, ..IpcConfig::default() };
        assert!(matches!(IpcBus::new(config), Err(BusError::InvalidConfig(_))));
        let config = IpcConfig { max_publishers: 0, ..IpcConfig::default() };
        assert!(matches!(IpcBus::new(config), Err(BusError::InvalidConfig(_))));
    }

    /// Processes must agree on the sizes: a bus asking for a larger buffer
    /// than the existing service has gets a backend error naming the topic.
    #[test]
    fn disagreeing_sizes_are_a_typed_error() {
        let topic = unique_topic("mismatch");
        let small = Limits { max_payload: 32, buffer: 4 };
        let first = IpcBus::new(IpcConfig { limits: small, ..IpcConfig::default() }).expect("node");
        let _sub = first.subscriber(&topic).expect("subscriber");
        let second = IpcBus::new(IpcConfig::default()).expect("node");
        match second.subscriber(&topic) {
            Err(BusError::Backend { topic: Some(t), .. }) => assert_eq!(t, topic.as_str()),
            Err(other) => panic!("unexpected error {other}"),
            Ok(_) => panic!("a larger buffer than the service's must be refused"),
        }
    }
}

#[cfg(feature = "zenoh")]
mod zenoh_backends {
    use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
    use bycoms_protocol::bus::Limits;
    use std::sync::OnceLock;

    /// One router-mode session without links, shared by every call: all
    /// deliveries stay inside the session (zenoh's local routing).
    pub fn one_session() -> ZenohBus {
        static BUS: OnceLock<ZenohBus> = OnceLock::new();
        let open = || ZenohBus::open(ZenohConfig { mode: Mode::Router, ..ZenohConfig::default() });
        BUS.get_or_init(|| open().expect("zenoh session")).clone()
    }

    pub fn one_session_small() -> ZenohBus {
        static BUS: OnceLock<ZenohBus> = OnceLock::new();
        let limits = Limits { max_payload: 32, buffer: 4 };
        let open = || ZenohBus::open(ZenohConfig { limits, mode: Mode::Router, ..ZenohConfig::default() });
        BUS.get_or_init(|| open().expect("zenoh session")).clone()
    }

    /// The router the client sessions below meet at: tcp on a free
    /// loopback port (asked of the kernel, retried if taken meanwhile).
    fn router_endpoint() -> &'static str {
        static ROUTER: OnceLock<(ZenohBus, String)> = OnceLock::new();
        let (_, endpoint) = ROUTER.get_or_init(|| {
            let config = |endpoint: &str| ZenohConfig {
                mode: Mode::Router,
                listen: vec![endpoint.to_owned()],
                ..ZenohConfig::default()
            };
            ZenohBus::loopback_router(config).expect("a router on a free loopback port")
        });
        endpoint
    }

    /// Each call opens a new client session of the shared router, so the
    /// two-thread check crosses a TCP link and the router.
    pub fn client_of_router() -> ZenohBus {
        let config = ZenohConfig {
            mode: Mode::Client,
            connect: vec![router_endpoint().to_owned()],
            ..ZenohConfig::default()
        };
        ZenohBus::open(config).expect("zenoh client session")
    }

    crate::conformance_suite!(zenoh_one_session, crate::bus_conformance::zenoh_backends::one_session);
    crate::conformance_suite!(zenoh_small_limits, crate::bus_conformance::zenoh_backends::one_session_small);
    crate::conformance_suite!(
        zenoh_clients_of_router,
        crate::bus_conformance::zenoh_backends::client_of_router
    );
}
