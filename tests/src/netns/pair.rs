//! The two-host setup the liveliness tests and the benchmark share: the
//! orchestrator's router in host `a`, agent 1's peer in host `b`, a counter
//! from the agent to the orchestrator every 20 ms.

use super::{PeerEvent, PeerProc, TwoHosts};
use std::path::Path;
use std::time::Duration;

/// Inside a private namespace no one else can hold the port.
pub const PORT: u16 = 7447;
/// How long start-up may take on a loaded machine.
pub const START: Duration = Duration::from_secs(15);

impl PeerEvent {
    /// When `member` was seen alive, if this is that event.
    pub fn alive_of(&self, member: &str) -> Option<u128> {
        match self {
            Self::Alive { member: m, mono_ns } if m == member => Some(*mono_ns),
            _ => None,
        }
    }

    /// When `member` was seen lost, if this is that event.
    pub fn lost_of(&self, member: &str) -> Option<u128> {
        match self {
            Self::Lost { member: m, mono_ns } if m == member => Some(*mono_ns),
            _ => None,
        }
    }
}

/// The counters among `events`, in arrival order.
pub fn seqs(events: &[PeerEvent]) -> Vec<u64> {
    events.iter().filter_map(|e| if let PeerEvent::Msg { seq, .. } = e { Some(*seq) } else { None }).collect()
}

/// The orchestrator and agent 1 of one swarm on two hosts.
pub struct Pair {
    /// Router in host `a`, printing the counters it receives.
    pub orchestrator: PeerProc,
    /// Peer in host `b`, publishing a counter every 20 ms.
    pub agent: PeerProc,
}

impl Pair {
    /// Starts both (`peer` is the `netns-peer` binary) and waits until each
    /// sees the other alive and the counter flows; panics otherwise.
    pub fn start(hosts: &TwoHosts, peer: &Path, swarm: &str) -> Self {
        let s = |v: &str| v.to_owned();
        let endpoint = hosts.a.endpoint(PORT);
        let mut orchestrator = PeerProc::start(
            &hosts.a,
            peer,
            &[
                s("--swarm"),
                s(swarm),
                s("--member"),
                s("orchestrator"),
                s("--mode"),
                s("router"),
                s("--listen"),
                endpoint.clone(),
                s("--subscribe"),
            ],
        );
        let ready = orchestrator.until(START, |e| matches!(e, PeerEvent::Ready { .. }).then_some(()));
        assert!(ready.is_some(), "orchestrator not ready: {:?}", orchestrator.seen);
        let args = [
            s("--swarm"),
            s(swarm),
            s("--member"),
            s("1"),
            s("--connect"),
            endpoint,
            s("--publish-every-ms"),
            s("20"),
        ];
        let mut agent = PeerProc::start(&hosts.b, peer, &args);
        let seen = orchestrator.until(START, |e| e.alive_of("1"));
        assert!(seen.is_some(), "agent never alive: {:?}", orchestrator.seen);
        let seen = agent.until(START, |e| e.alive_of("orchestrator"));
        assert!(seen.is_some(), "orchestrator never alive: {:?}", agent.seen);
        let flowing =
            orchestrator.until(START, |e| matches!(e, PeerEvent::Msg { seq, .. } if *seq >= 5).then_some(()));
        assert!(flowing.is_some(), "no counter arrived: {:?}", orchestrator.seen);
        Self { orchestrator, agent }
    }
}
