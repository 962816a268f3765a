//! Remote agents: started by hand on other hosts, awaited here.
//!
//! Why the orchestrator spawns nothing: in a lab the agents (simulated on
//! other machines, or robots behind their gateways) exist before and
//! independently of a launch. A remote agent is `sim-agent --transport
//! zenoh --connect tcp/ORCHESTRATOR:PORT --swarm S --robot K`: it takes the
//! run's settings (terrain, ε, noise, seed, clock, swarm size) from the
//! launch, which serves them on `bycoms/<swarm>/settings` (`launch::run`).
//! The launch starts
//! expecting every robot at once ([`AgentSource::all_at_once`]) and deploys
//! each when its turn comes: a robot whose agent has not registered by
//! then is awaited up to its registration timeout (counted from the start),
//! then skipped as absent; one that registers later takes a later turn
//! (`supervision.missing = "fail"` awaits all and names the missing).
//!
//! Liveness has two signals. The [`Watchdog`] (registration and heartbeat
//! deadlines) catches an agent that never came or hangs. zenoh liveliness
//! ([`AliveWatch`]: every agent declares `alive/robot/<id>`) catches an
//! agent whose process ended or whose link was cut, within one lease
//! (`Liveness::FAST`: 400 ms): [`AgentSource::poll`], the single place where
//! a lost agent is reported, reports a withdrawn token as
//! [`Gone::Disconnected`]. A refused duplicate agent declares the same
//! token as the accepted one; zenoh's routing merges such twin tokens (a
//! watcher sees the key go only when the last one goes), so its leaving
//! does not make the accepted agent look lost (`tests/tests/remote_agents.rs`
//! checks it). Presence is a flag per robot, not a count: a token may be
//! reported alive twice (the watch's history and the live declaration
//! racing), but it is withdrawn once.
//!
//! Partitions: a lab's link drops for a moment (WiFi, a switch). With a
//! link grace (`supervision.link_grace`, [`Remote::with_link_grace`]) a
//! withdrawn token or a silent agent is first only *unreachable*
//! ([`Reach::Lost`], reported at once by [`AgentSource::reach`]); the engine
//! holds the robot (the lockstep clock waits) and, when the agent is heard
//! again ([`Reach::Back`]), re-sends what it may have missed. Only an agent
//! unreachable for longer than the grace is reported gone
//! ([`Gone::Unreachable`]). Silence counts as well as a withdrawn token
//! because zenoh may close a dead link's transport late (seen here: one of
//! three transports closed only when the link came back), so its token
//! would go late or never: an agent not heard for [`Remote::with_quiet`]
//! (four heartbeat periods, 400 ms by default) is unreachable too, so every
//! cut is seen within 500 ms, not only those whose transport zenoh closes
//! at lease expiry. With no grace (0) a withdrawn token is
//! [`Gone::Disconnected`] at once and silence [`Gone::Silent`], as for any
//! source.
//!
//! A remote process cannot be killed from here: [`AgentSource::kill`]
//! only drops it from the launch (it was sent `Shutdown`, or it is gone),
//! and [`AgentSource::wind_down`] waits for the tokens of the agents it
//! sent `Shutdown` to go, naming only those that stay.

use super::watchdog::Watchdog;
use super::{AgentError, AgentPlan, AgentSource, Gone, Reach, Started};
use bycoms_protocol::bus::zenoh::{AliveWatch, Presence};
use bycoms_protocol::naming::Member;
use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

/// The awaited remote agents, by robot id.
pub struct Remote {
    running: BTreeSet<u32>,
    watchdog: Watchdog,
    last_poll: Instant,
    /// The swarm's liveliness tokens (none without zenoh, e.g. in tests).
    watch: Option<AliveWatch>,
    /// Robots whose token is present.
    tokens: BTreeSet<u32>,
    /// Running robots whose last token went and which were not reported yet.
    lost: BTreeSet<u32>,
    /// How long an agent may be unreachable before it is gone (zero: at once).
    grace: Duration,
    /// Unreachable robots and since when.
    unreachable: BTreeMap<u32, Instant>,
    /// With a grace: silence after which a heard agent is unreachable
    /// (zero: only the heartbeat timeout).
    quiet: Duration,
    /// Reachability changes not yet taken by [`AgentSource::reach`].
    changes: Vec<(u32, Reach)>,
}

/// Least time between two sweeps.
const POLL_EVERY: Duration = Duration::from_millis(5);

/// Heartbeat periods of silence after which a remote agent is unreachable
/// (the launch's quiet, [`Remote::with_quiet`]): at 100 ms heartbeats a cut
/// shows 300–405 ms after it happened, and a process must miss three
/// heartbeats in a row to look unreachable when it is not.
pub const QUIET_HEARTBEATS: u32 = 4;

impl Remote {
    /// A source awaiting agents with these timeouts, watching their
    /// liveliness tokens on `watch` when there is one.
    pub fn new(register_timeout: Duration, heartbeat_timeout: Duration, watch: Option<AliveWatch>) -> Self {
        Self {
            running: BTreeSet::new(),
            watchdog: Watchdog::new(register_timeout, heartbeat_timeout),
            last_poll: Instant::now(),
            watch,
            tokens: BTreeSet::new(),
            lost: BTreeSet::new(),
            grace: Duration::ZERO,
            unreachable: BTreeMap::new(),
            quiet: Duration::ZERO,
            changes: Vec::new(),
        }
    }

    /// The same source, taking an agent that was heard and is then silent
    /// for `quiet` as unreachable (with a link grace only: without one,
    /// silence is [`Gone::Silent`] at the heartbeat timeout, as for every
    /// source). [`QUIET_HEARTBEATS`] heartbeat periods is the launch's.
    pub fn with_quiet(mut self, quiet: Duration) -> Self {
        self.quiet = quiet;
        self
    }

    /// The same source, holding an unreachable agent for up to `grace`
    /// before reporting it gone (see the module docs).
    pub fn with_link_grace(mut self, grace: Duration) -> Self {
        self.grace = grace;
        self
    }

    /// Robot `id` cannot be reached from `now` on (first time only).
    fn lose(&mut self, id: u32, now: Instant) {
        if let std::collections::btree_map::Entry::Vacant(e) = self.unreachable.entry(id) {
            tracing::debug!(robot = id, "robot {id}'s agent is unreachable");
            e.insert(now);
            self.changes.push((id, Reach::Lost));
        }
    }

    /// Takes in the liveliness changes zenoh delivered so far.
    fn drain_tokens(&mut self) {
        let Some(watch) = &self.watch else { return };
        while let Some(event) = watch.try_recv() {
            let Member::Agent(robot) = event.member else { continue };
            let id = robot.0;
            match event.presence {
                Presence::Alive => {
                    self.tokens.insert(id);
                }
                Presence::Lost => {
                    self.tokens.remove(&id);
                    if self.running.contains(&id) {
                        tracing::debug!(robot = id, "robot {id}'s liveliness token is gone");
                        self.lost.insert(id);
                    }
                }
            }
        }
    }

    fn has_token(&self, id: u32) -> bool {
        self.tokens.contains(&id)
    }
}

impl AgentSource for Remote {
    fn start_hint(&self) -> &'static str {
        " (start each with `sim-agent --transport zenoh --connect ENDPOINT --swarm SWARM --robot K`)"
    }

    fn ended_by(&self) -> &'static str {
        "still alive on their hosts, dropped from the launch"
    }

    fn kind(&self) -> &'static str {
        "remote"
    }

    fn all_at_once(&self) -> bool {
        true
    }

    fn start(&mut self, id: u32, _plan: &AgentPlan<'_>) -> Result<Started, AgentError> {
        self.running.insert(id);
        self.watchdog.start(id);
        Ok(Started::Awaited)
    }

    fn heard(&mut self, id: u32) {
        self.watchdog.heard(id);
        if self.unreachable.remove(&id).is_some() {
            self.changes.push((id, Reach::Back));
        }
    }

    fn is_running(&self, id: u32) -> bool {
        self.running.contains(&id)
    }

    fn pid(&self, _id: u32) -> Option<u32> {
        None
    }

    fn poll(&mut self, force: bool) -> Vec<(u32, Gone)> {
        let now = Instant::now();
        if !force && now.duration_since(self.last_poll) < POLL_EVERY {
            return Vec::new();
        }
        self.last_poll = now;
        self.drain_tokens();
        let hold = !self.grace.is_zero();
        let mut gone: Vec<(u32, Gone)> = Vec::new();
        for id in std::mem::take(&mut self.lost) {
            if !self.running.contains(&id) {
                continue;
            }
            if hold {
                self.lose(id, now);
            } else {
                gone.push((id, Gone::Disconnected));
            }
        }
        let ids: Vec<u32> = self.running.iter().copied().collect();
        for id in ids {
            if gone.iter().any(|(g, _)| *g == id) {
                continue;
            }
            if let Some(&since) = self.unreachable.get(&id) {
                if now.duration_since(since) > self.grace {
                    let grace_ms = self.grace.as_millis() as u64;
                    gone.push((id, Gone::Unreachable { grace_ms }));
                }
                continue;
            }
            let quiet = !self.quiet.is_zero()
                && self.watchdog.silent_for(id, now).is_some_and(|silent| silent > self.quiet);
            if hold && quiet {
                self.lose(id, now);
                continue;
            }
            match self.watchdog.overdue(id, now) {
                Some(Gone::Silent) if hold => self.lose(id, now),
                Some(why) => gone.push((id, why)),
                None => {}
            }
        }
        for (id, _) in &gone {
            self.kill(*id);
        }
        gone
    }

    fn reach(&mut self) -> Vec<(u32, Reach)> {
        std::mem::take(&mut self.changes)
    }

    fn kill(&mut self, id: u32) -> bool {
        self.watchdog.forget(id);
        self.lost.remove(&id);
        self.unreachable.remove(&id);
        self.running.remove(&id)
    }

    fn wind_down(&mut self, grace: Duration) -> Vec<u32> {
        // With liveliness an agent that obeyed `Shutdown` is seen to go (its
        // token is withdrawn when its session closes); without it nothing
        // can be seen, and every agent still counted is named.
        if self.watch.is_some() {
            let deadline = Instant::now() + grace;
            loop {
                self.drain_tokens();
                if !self.running.iter().any(|&id| self.has_token(id)) || Instant::now() >= deadline {
                    break;
                }
                std::thread::sleep(POLL_EVERY);
            }
        }
        let stayed: Vec<u32> = match &self.watch {
            Some(_) => self.running.iter().copied().filter(|&id| self.has_token(id)).collect(),
            None => self.running.iter().copied().collect(),
        };
        let ids: Vec<u32> = self.running.iter().copied().collect();
        for id in ids {
            self.kill(id);
        }
        stayed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn heard_source(grace: Duration) -> Remote {
        let mut r =
            Remote::new(Duration::from_secs(10), Duration::from_millis(60), None).with_link_grace(grace);
        // What `start` does (it ignores its plan).
        r.running.insert(1);
        r.watchdog.start(1);
        r.heard(1);
        r
    }

    fn poll_for(r: &mut Remote, span: Duration) -> Vec<(u32, Gone)> {
        let end = Instant::now() + span;
        let mut gone = Vec::new();
        while Instant::now() < end {
            gone.extend(r.poll(true));
            std::thread::sleep(Duration::from_millis(5));
        }
        gone
    }

    #[test]
    fn with_a_grace_a_silent_agent_is_unreachable_then_back_and_never_gone() {
        let mut r = heard_source(Duration::from_secs(5));
        assert!(poll_for(&mut r, Duration::from_millis(150)).is_empty(), "held, not gone");
        assert_eq!(r.reach(), [(1, Reach::Lost)], "reported unreachable once");
        assert!(r.reach().is_empty());
        r.heard(1);
        assert_eq!(r.reach(), [(1, Reach::Back)]);
        assert!(r.is_running(1));
    }

    #[test]
    fn past_the_grace_an_unreachable_agent_is_gone_once() {
        let mut r = heard_source(Duration::from_millis(100));
        let gone = poll_for(&mut r, Duration::from_millis(400));
        assert_eq!(gone, [(1, Gone::Unreachable { grace_ms: 100 })]);
        assert_eq!(r.reach(), [(1, Reach::Lost)]);
        assert!(!r.is_running(1));
        assert!(Gone::Unreachable { grace_ms: 100 }.to_string().contains("within the 0.1 s link grace"));
    }

    #[test]
    fn with_a_quiet_a_silent_agent_is_unreachable_long_before_the_heartbeat_timeout() {
        // A 10 s heartbeat timeout: only the quiet can make it unreachable.
        let mut r = Remote::new(Duration::from_secs(10), Duration::from_secs(10), None)
            .with_link_grace(Duration::from_secs(5))
            .with_quiet(Duration::from_millis(40));
        r.running.insert(1);
        r.watchdog.start(1);
        r.heard(1);
        let heard = Instant::now();
        assert_eq!(wait_for_change(&mut r, Duration::from_secs(5)), [(1, Reach::Lost)]);
        assert!(heard.elapsed() >= Duration::from_millis(40), "not before the quiet");
        assert!(r.is_running(1), "held, not gone");
        r.heard(1);
        assert_eq!(r.reach(), [(1, Reach::Back)]);
    }

    /// Sweeps until a reachability change comes (or `limit`).
    fn wait_for_change(r: &mut Remote, limit: Duration) -> Vec<(u32, Reach)> {
        let end = Instant::now() + limit;
        loop {
            assert!(r.poll(true).is_empty(), "nothing is gone within the grace");
            let changes = r.reach();
            if !changes.is_empty() || Instant::now() >= end {
                return changes;
            }
            std::thread::yield_now();
        }
    }

    #[test]
    fn without_a_grace_silence_is_reported_at_once() {
        let mut r = heard_source(Duration::ZERO);
        assert_eq!(poll_for(&mut r, Duration::from_millis(200)), [(1, Gone::Silent)]);
        assert!(r.reach().is_empty(), "nothing is held without a grace");
    }
}
