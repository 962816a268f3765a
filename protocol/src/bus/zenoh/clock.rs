//! Clock offsets between hosts, measured over zenoh: the orchestrator
//! answers queries on `bycoms/<swarm>/clock` ([`Swarm::clock`]) with its
//! wall clock, and an agent (a `sim-agent`, a gateway) or `orchestrator
//! doctor --connect` asks a few times and keeps the answer of the
//! shortest round trip (NTP's exchange, [`ClockSample::from_stamps`]).
//!
//! Why it matters: zenoh drops samples stamped more than 500 ms in the
//! future, and a lab's recording mixes times of several hosts; a host
//! whose clock is off is found before its robot moves (the launch refuses
//! its agent past the limit, PROTOCOL.md "The orchestrator's clock").
//!
//! Why a queryable on the orchestrator and the asker measuring: the
//! doctor, the agents and anything else on the swarm then measure the
//! same way with one server, and a reply is one 8-byte number (no bus
//! message, no storage). The agent reports what it measured in one bus
//! message (`FromAgent::Clock`, 64 bytes at most like every message).
//!
//! Why one timestamp in the reply: the server answers from zenoh's
//! callback at once, so its receive and send times (NTP's t1 and t2) are
//! the same instant to well under the round trip.
//!
//! The asker's clock is a [`HostClock`]: the system clock plus, in tests
//! only, a skew from [`SKEW_ENV`], so a test can give one host a wrong
//! clock without root (docs/ENVIRONMENT.md).

use super::ZenohBus;
use crate::bus::BusError;
use crate::naming::Swarm;
use ::zenoh::query::{Query, Queryable};
use ::zenoh::{Session, Wait as _};
use core::time::Duration;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::time::{SystemTime, UNIX_EPOCH};

/// Tests only (the `test-clock-skew` feature): milliseconds added to this
/// host's clock as agents and the doctor read it (negative: behind).
pub const SKEW_ENV: &str = "BYCOMS_TEST_CLOCK_SKEW_MS";

/// How many exchanges one measurement makes (the shortest round trip wins).
pub const SAMPLES: usize = 4;

/// How often a [`ClockProbe`] measures again.
pub const EVERY: Duration = Duration::from_secs(10);

/// How soon a [`ClockProbe`] tries again when nobody answered (the
/// orchestrator not there yet).
pub const RETRY: Duration = Duration::from_secs(1);

/// How long one exchange waits for its answer.
pub const TIMEOUT: Duration = Duration::from_millis(500);

/// How long an agent waits for its first measurement before it registers
/// anyway (its offset then comes with a later `Register` or after it).
pub const FIRST_WAIT: Duration = Duration::from_secs(2);

/// A measurement as the agent reports it.
pub fn report(robot: crate::RobotId, sample: ClockSample) -> crate::msg::FromAgent {
    crate::msg::FromAgent::Clock(crate::msg::ClockOffset {
        robot,
        offset_us: sample.offset_us,
        round_trip_us: u32::try_from(sample.round_trip_us).unwrap_or(u32::MAX),
    })
}

pub use crate::clock_limits::{ClockLimits, ClockVerdict};

/// This host's wall clock as agents and the doctor read it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HostClock {
    /// Added to the system clock, µs (tests only, [`SKEW_ENV`]).
    pub skew_us: i64,
}

impl HostClock {
    /// The system clock, skewed by [`SKEW_ENV`] when it is set to a whole
    /// number of milliseconds (anything else is ignored, with a warning).
    /// Only a build with the `test-clock-skew` feature (what `cargo test
    /// --workspace` builds) reads it: a product binary's clock is the
    /// system's, whatever its environment says.
    pub fn from_env() -> Self {
        if !cfg!(feature = "test-clock-skew") {
            return Self::default();
        }
        let Ok(text) = std::env::var(SKEW_ENV) else { return Self::default() };
        match text.trim().parse::<i64>() {
            Ok(ms) => {
                tracing::warn!("{SKEW_ENV}={ms}: this host's clock is skewed by {ms} ms (tests only)");
                Self { skew_us: ms.saturating_mul(1000) }
            }
            Err(_) => {
                tracing::warn!("{SKEW_ENV}={text:?} is no whole number of milliseconds: ignored");
                Self::default()
            }
        }
    }

    /// Now, µs since the Unix epoch.
    pub fn now_us(&self) -> i64 {
        system_us().saturating_add(self.skew_us)
    }
}

/// The system clock, µs since the Unix epoch (negative before it).
fn system_us() -> i64 {
    match SystemTime::now().duration_since(UNIX_EPOCH) {
        Ok(d) => i64::try_from(d.as_micros()).unwrap_or(i64::MAX),
        Err(e) => -i64::try_from(e.duration().as_micros()).unwrap_or(i64::MAX),
    }
}

/// One exchange's result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClockSample {
    /// The asker's clock minus the orchestrator's, µs (positive: ahead).
    pub offset_us: i64,
    /// The exchange's round trip less the server's time, µs.
    pub round_trip_us: u64,
}

impl ClockSample {
    /// NTP's arithmetic: asked at `t0` and answered at `t3` on the asker's
    /// clock, received at `t1` and answered at `t2` on the server's. The
    /// server's offset to the asker is ((t1−t0)+(t2−t3))/2; ours is its
    /// opposite. Exact when the way out and back take as long; off by at
    /// most half the round trip otherwise.
    pub fn from_stamps(t0: i64, t1: i64, t2: i64, t3: i64) -> Self {
        let (t0, t1, t2, t3) = (i128::from(t0), i128::from(t1), i128::from(t2), i128::from(t3));
        let offset = ((t0 - t1) + (t3 - t2)) / 2;
        let round_trip = ((t3 - t0) - (t2 - t1)).max(0);
        Self {
            offset_us: i64::try_from(offset).unwrap_or(if offset < 0 { i64::MIN } else { i64::MAX }),
            round_trip_us: u64::try_from(round_trip).unwrap_or(u64::MAX),
        }
    }

    /// The sample of the shortest round trip (its offset is the least
    /// uncertain); the first of equals.
    pub fn best(samples: &[ClockSample]) -> Option<ClockSample> {
        samples.iter().copied().reduce(|a, b| if b.round_trip_us < a.round_trip_us { b } else { a })
    }
}

/// The orchestrator's clock, answered to every asker; dropping it
/// undeclares the queryable.
pub struct ClockServer {
    _queryable: Queryable<()>,
}

impl ZenohBus {
    /// Answers every query on `swarm`'s clock key with this host's system
    /// clock (µs since the Unix epoch, an `i64` little-endian), for as long
    /// as the returned value lives.
    pub fn serve_clock(&self, swarm: &Swarm) -> Result<ClockServer, BusError> {
        let key = swarm.clock();
        let queryable = self
            .session()
            .declare_queryable(key.as_str().to_owned())
            .callback(move |query: Query| {
                let now = system_us().to_le_bytes().to_vec();
                if let Err(e) = query.reply(query.key_expr().clone(), now).wait() {
                    tracing::debug!(error = %super::zenoh_error(&e), "a clock reply was not sent");
                }
            })
            .wait()
            .map_err(|e| super::text::backend("declare clock queryable", Some(key.to_string()), None, &e))?;
        tracing::debug!(key = key.as_str(), "zenoh: serving the orchestrator's clock");
        Ok(ClockServer { _queryable: queryable })
    }

    /// Measures `clock`'s offset to `swarm`'s orchestrator: [`SAMPLES`]
    /// exchanges, each waiting up to `timeout`; the best one, or `None`
    /// when none was answered.
    pub fn measure_clock(
        &self,
        swarm: &Swarm,
        clock: HostClock,
        timeout: Duration,
    ) -> Result<Option<ClockSample>, BusError> {
        measure(self.session(), swarm, clock, timeout)
    }

    /// Measures in the background, at once and then every [`EVERY`]
    /// ([`RETRY`] until answered), each exchange waiting up to [`TIMEOUT`];
    /// see [`ClockProbe`].
    pub fn clock_probe(&self, swarm: &Swarm, clock: HostClock) -> ClockProbe {
        ClockProbe::start(self.session().clone(), *swarm, clock)
    }
}

fn measure(
    session: &Session,
    swarm: &Swarm,
    clock: HostClock,
    timeout: Duration,
) -> Result<Option<ClockSample>, BusError> {
    let key = swarm.clock();
    let mut samples = Vec::with_capacity(SAMPLES);
    for _ in 0..SAMPLES {
        let t0 = clock.now_us();
        let replies = session
            .get(key.as_str())
            .timeout(timeout)
            .wait()
            .map_err(|e| super::text::backend("query clock", Some(key.to_string()), None, &e))?;
        // The channel ends (an error) when the query is complete or timed
        // out with no reply: nobody answers, so asking again is no use.
        let Ok(reply) = replies.recv() else { break };
        let t3 = clock.now_us();
        let Ok(sample) = reply.into_result() else { continue };
        let bytes = sample.payload().to_bytes();
        let Ok(stamp) = <[u8; 8]>::try_from(bytes.as_ref()) else { continue };
        let t = i64::from_le_bytes(stamp);
        samples.push(ClockSample::from_stamps(t0, t, t, t3));
    }
    Ok(ClockSample::best(&samples))
}

/// A measurement of this host's clock offset to the orchestrator at once
/// and then periodically, on its own thread so an agent's loop never
/// waits for it; the loop takes the results ([`ClockProbe::take`]).
/// Dropping it ends the thread.
pub struct ClockProbe {
    results: Receiver<ClockSample>,
    _stop: Sender<()>,
}

impl ClockProbe {
    fn start(session: Session, swarm: Swarm, clock: HostClock) -> Self {
        let (tx, results) = mpsc::channel();
        let (stop, stopped) = mpsc::channel::<()>();
        let spawned = std::thread::Builder::new().name("bycoms-clock".into()).spawn(move || loop {
            let next = match measure(&session, &swarm, clock, TIMEOUT) {
                Ok(Some(sample)) => {
                    tracing::debug!(
                        offset_us = sample.offset_us,
                        round_trip_us = sample.round_trip_us,
                        "clock offset to the orchestrator measured"
                    );
                    if tx.send(sample).is_err() {
                        return;
                    }
                    EVERY
                }
                Ok(None) => {
                    tracing::debug!("the orchestrator's clock did not answer");
                    RETRY
                }
                Err(e) => {
                    tracing::debug!("the clock offset was not measured: {e}");
                    RETRY
                }
            };
            if stopped.recv_timeout(next) != Err(RecvTimeoutError::Timeout) {
                return;
            }
        });
        if let Err(e) = spawned {
            tracing::warn!("the clock offset will not be measured: cannot start its thread: {e}");
        }
        Self { results, _stop: stop }
    }

    /// The measurements made since the last call.
    pub fn take(&self) -> Vec<ClockSample> {
        self.results.try_iter().collect()
    }

    /// Waits up to `timeout` for the next measurement.
    pub fn wait(&self, timeout: Duration) -> Option<ClockSample> {
        self.results.recv_timeout(timeout).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_are_judged_by_their_size_either_way() {
        const LIMITS: ClockLimits = ClockLimits::LAB;
        assert_eq!(LIMITS.judge(0), ClockVerdict::Fine);
        assert_eq!(LIMITS.judge(100_000), ClockVerdict::Fine, "the warning is past 100 ms");
        assert_eq!(LIMITS.judge(-100_001), ClockVerdict::Warn);
        assert_eq!(LIMITS.judge(500_000), ClockVerdict::Warn);
        assert_eq!(LIMITS.judge(500_001), ClockVerdict::Refuse);
        assert_eq!(LIMITS.judge(i64::MIN), ClockVerdict::Refuse);
        assert_eq!(ClockLimits::default().judge(i64::MAX), ClockVerdict::Fine, "off: nothing judged");
    }

    #[test]
    fn an_asker_ahead_by_a_second_on_a_symmetric_path() {
        // Asker at 10_000_000 (server then at 9_000_000 + 300), 300 µs
        // each way, 100 µs in the server.
        let s = ClockSample::from_stamps(10_000_000, 9_000_300, 9_000_400, 10_000_700);
        assert_eq!(s, ClockSample { offset_us: 1_000_000, round_trip_us: 600 });
    }

    #[test]
    fn an_asker_behind_and_an_asymmetric_path_errs_by_at_most_half_the_round_trip() {
        // Asker 250 ms behind; 100 µs out, 900 µs back, one server stamp.
        let (t0, skew) = (5_000_000_i64, -250_000_i64);
        let t1 = t0 - skew + 100;
        let t3 = t0 + 100 + 900;
        let s = ClockSample::from_stamps(t0, t1, t1, t3);
        assert_eq!(s.round_trip_us, 1000);
        assert!((s.offset_us - skew).unsigned_abs() <= s.round_trip_us / 2, "{s:?}");
        assert_eq!(s.offset_us, skew + 400, "off by half the difference of the two ways");
    }

    #[test]
    fn the_shortest_round_trip_wins() {
        let a = ClockSample { offset_us: 9, round_trip_us: 800 };
        let b = ClockSample { offset_us: 3, round_trip_us: 200 };
        let c = ClockSample { offset_us: 5, round_trip_us: 200 };
        assert_eq!(ClockSample::best(&[a, b, c]), Some(b));
        assert_eq!(ClockSample::best(&[]), None);
    }

    #[test]
    fn extreme_stamps_saturate_instead_of_overflowing() {
        let s = ClockSample::from_stamps(i64::MAX, i64::MIN, i64::MIN, i64::MAX);
        assert_eq!(s.offset_us, i64::MAX);
        let back = ClockSample::from_stamps(0, 10, 20, 5);
        assert_eq!(back.round_trip_us, 0, "a negative round trip (a stepped clock) counts as none");
    }

    #[test]
    fn the_test_skew_moves_the_hosts_clock() {
        let skewed = HostClock { skew_us: 2_000_000 };
        let d = skewed.now_us() - HostClock::default().now_us();
        assert!((1_999_000..=2_001_000).contains(&d), "{d}");
    }
}
