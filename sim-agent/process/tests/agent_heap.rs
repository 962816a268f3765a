//! An agent's ports on the iceoryx2 bus take the same heap whatever the
//! swarm's size and however many agents came before it.
//!
//! Why this is a test and not only a bench figure: the per-agent memory of
//! a launch grew with the swarm twice over, and nothing but a 1000-robot
//! launch showed it. The doorbells' notifiers kept a slot (about 1.3 KB) per
//! possible listener, sized like the swarm (2.7 MB per agent at 1000
//! robots), and every service an agent opened read every node attached to
//! it to look for dead ones (heap churn that grew with the agents before
//! it, about 5.7 KB each, and that the allocator kept). The heap counts
//! here are deterministic (the same allocations every run), so the checks
//! are exact where the cause was, and loose only by a margin for
//! iceoryx2's small size-dependent fields.

use bycoms_protocol::bus::ipc::root::Isolated;
use bycoms_protocol::bus::ipc::IpcBus;
use bycoms_protocol::{RobotId, Swarm};
use bycoms_runtime::ipc_config;
use bycoms_sim_agent::run::AgentPorts;
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};
use std::alloc::System;
use std::sync::Mutex;

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

/// One measurement at a time (the counters are process-wide).
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// What opening robot `robots / 2`'s agent ports did to the heap, in a
/// swarm of `robots` where `before` other agents' buses have already
/// opened their ports: (bytes still held, bytes allocated in all).
fn ports_heap(robots: u32, before: u32) -> (isize, usize) {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let iso = Isolated::new("agentheap");
    let mut config = ipc_config(robots);
    config.isolation = Some(iso.tag().to_owned());
    let swarm = Swarm::new("heap").expect("swarm name");
    let others: Vec<_> = (1..=before)
        .map(|k| {
            let bus = IpcBus::new(config.clone()).expect("bus");
            let ports = AgentPorts::open(&bus, &swarm, RobotId(k)).expect("ports");
            (ports, bus)
        })
        .collect();
    let bus = IpcBus::new(config).expect("bus");
    let region = Region::new(GLOBAL);
    let ports = AgentPorts::open(&bus, &swarm, RobotId(robots / 2)).expect("ports");
    let change = region.change();
    drop(ports);
    drop(bus);
    drop(others);
    let held = change.bytes_allocated as isize - change.bytes_deallocated as isize + change.bytes_reallocated;
    (held, change.bytes_allocated)
}

#[test]
fn an_agent_s_ports_hold_the_same_heap_in_a_swarm_of_10_and_of_1000() {
    let (small, _) = ports_heap(10, 0);
    let (large, _) = ports_heap(1000, 0);
    assert!(small > 0, "the ports hold something: {small} bytes");
    // With the doorbells sized like the swarm on both sides and the
    // dead-node checks on (the code before): 0.31 MB at 10, 42.6 MB at 1000.
    assert!(large <= small + small / 20, "ports held {small} B at 10 robots and {large} B at 1000");
}

#[test]
fn opening_an_agent_s_ports_does_not_read_the_agents_before_it() {
    let (_, alone) = ports_heap(100, 0);
    let (_, after) = ports_heap(100, 40);
    assert!(alone > 0, "opening allocates: {alone} bytes");
    // When every open looked for dead nodes, the 40 agents before it added
    // their node records to every one of its opens: 0.63 MB alone, 8.3 MB
    // after 40.
    assert!(after <= alone + alone / 20, "opening allocated {alone} B alone and {after} B after 40 agents");
}
