//! The agent's failsafe: a robot whose orchestrator is gone stops.
//!
//! Why: across hosts (zenoh), an agent can lose its orchestrator without
//! losing its parent process — a cut link, a crashed orchestrator host.
//! A robot that kept driving on its last goal bearing would leave the
//! arena or hit something no one watches any more. So each agent watches
//! the orchestrator's liveliness token; once it has been gone for longer
//! than a grace period (long enough to ride out a link that flaps for a
//! moment), the robot stops for good (its core's `Stopped` phase: no more
//! motion, the pose stays where the robot is) and the agent then exits or
//! waits for the orchestrator to come back and shut it down, by policy.
//!
//! Why latched: when the orchestrator returns, the gate has already
//! applied its dead-robot policy to the robot (its loss was seen by the
//! orchestrator too, within one lease); a robot that silently resumed
//! would contradict that. It stays stopped until `Shutdown`.
//!
//! The watch arms only once the orchestrator was seen alive: a remote agent
//! started before its orchestrator waits for it rather than giving up.
//!
//! Sans-IO: the shell feeds liveliness changes and the time in, as
//! [`Micros`] since its epoch (`crate::epoch`), and acts on the
//! [`Verdict`]; it runs inside the gateway's session core, whose time it
//! takes; the tests below drive it with made-up times.

use crate::epoch::micros_of;
use bycoms_protocol::msg::{FailsafeFired, FromAgent};
use bycoms_protocol::{Micros, RobotId};
use std::time::Duration;

/// The failsafe's flags (zenoh only: over iceoryx2 the agent's lifeline
/// already ties it to the orchestrator's process).
#[derive(Clone, Copy, Debug, PartialEq, clap::Args)]
pub struct FailsafeArgs {
    /// zenoh: how long the orchestrator's liveliness token may be gone
    /// (link cut, orchestrator host down) before the robot stops for good.
    #[arg(long = "orchestrator-grace", value_name = "SECONDS", default_value_t = DEFAULT_GRACE_S)]
    pub grace_s: f64,
    /// zenoh: what the agent does once the failsafe stopped its robot:
    /// `exit` (status 4) or `wait` for the orchestrator to return and shut
    /// it down (the robot stays stopped).
    #[arg(long = "on-orchestrator-lost", value_enum, default_value_t = OnOrchestratorLost::Exit)]
    pub on_lost: OnOrchestratorLost,
}

/// Default grace period, seconds: rides out a link that flaps for a moment.
pub const DEFAULT_GRACE_S: f64 = 2.0;

impl Default for FailsafeArgs {
    fn default() -> Self {
        Self { grace_s: DEFAULT_GRACE_S, on_lost: OnOrchestratorLost::Exit }
    }
}

impl FailsafeArgs {
    /// The grace period, if the value is usable.
    pub fn grace(&self) -> Result<Duration, String> {
        crate::seconds::check_seconds("--orchestrator-grace", self.grace_s, crate::seconds::Zero::Allowed)
    }

    /// The failsafe these flags describe.
    pub fn failsafe(&self) -> Result<Failsafe, String> {
        Ok(Failsafe::new(self.grace()?, self.on_lost))
    }

    /// The flags that reproduce these values.
    pub fn to_flags(&self) -> Vec<String> {
        let policy = match self.on_lost {
            OnOrchestratorLost::Exit => "exit",
            OnOrchestratorLost::Wait => "wait",
        };
        vec![
            "--orchestrator-grace".into(),
            format!("{:?}", self.grace_s),
            "--on-orchestrator-lost".into(),
            policy.into(),
        ]
    }
}

/// What an agent does after its robot was stopped by the failsafe.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum OnOrchestratorLost {
    /// End the agent process (exit status 4).
    #[default]
    Exit,
    /// Keep the process (robot stopped) until the orchestrator is back and
    /// shuts it down, or a signal ends it.
    Wait,
}

/// What the agent must do now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Carry on.
    Run,
    /// Stop the robot now (reported once), then keep running.
    Stop {
        /// How long the orchestrator had been gone.
        lost_for: Duration,
    },
    /// Stop the robot now (reported once), then exit.
    StopAndExit {
        /// How long the orchestrator had been gone.
        lost_for: Duration,
    },
    /// The robot was stopped by the failsafe and the orchestrator is back:
    /// tell it again (the first report went into the cut link).
    Remind {
        /// How long the orchestrator had been gone when the failsafe fired.
        lost_for: Duration,
    },
}

impl Verdict {
    /// The report an agent sends on this verdict (`None` for `Run`):
    /// [`FromAgent::Failsafe`] with the time the orchestrator had been gone.
    pub fn report(&self, robot: RobotId) -> Option<FromAgent> {
        let lost_for = match *self {
            Self::Run => return None,
            Self::Stop { lost_for } | Self::StopAndExit { lost_for } | Self::Remind { lost_for } => lost_for,
        };
        let silent_ms = u32::try_from(lost_for.as_millis()).unwrap_or(u32::MAX);
        Some(FromAgent::Failsafe(FailsafeFired { robot, silent_ms }))
    }
}

/// The failsafe state machine; see the module docs.
#[derive(Clone, Debug)]
pub struct Failsafe {
    grace: Duration,
    /// The grace in whole µs (truncated: gone for `grace_us + 1` µs is
    /// past it, as it was on `Instant`s).
    grace_us: Micros,
    policy: OnOrchestratorLost,
    armed: bool,
    lost_since: Option<Micros>,
    tripped: bool,
    /// How long the orchestrator had been gone when the failsafe fired.
    fired_after: Duration,
    /// The orchestrator came back after the failsafe fired: remind it.
    remind: bool,
}

impl Failsafe {
    /// A failsafe that trips after the orchestrator has been gone for
    /// `grace`, then follows `policy`.
    pub fn new(grace: Duration, policy: OnOrchestratorLost) -> Self {
        Self {
            grace,
            grace_us: micros_of(grace),
            policy,
            armed: false,
            lost_since: None,
            tripped: false,
            fired_after: Duration::ZERO,
            remind: false,
        }
    }

    /// The grace period in ms (saturating), as the agent's `Register`
    /// tells the orchestrator.
    pub fn grace_ms(&self) -> u32 {
        u32::try_from(self.grace.as_millis()).unwrap_or(u32::MAX)
    }

    /// The orchestrator's token appeared (or reappeared) at `at`.
    pub fn orchestrator_alive(&mut self, at: Micros) {
        if self.lost_since.is_some() && !self.tripped {
            tracing::info!(after = ?self.lost_since.map(|t| Duration::from_micros(at.saturating_sub(t))), "orchestrator back within the grace period");
        }
        self.armed = true;
        self.lost_since = None;
        self.remind |= self.tripped;
    }

    /// The orchestrator's token disappeared at `at`.
    pub fn orchestrator_lost(&mut self, at: Micros) {
        // A reminder sent now would go into the cut link: wait for the next return.
        self.remind = false;
        if self.armed && self.lost_since.is_none() {
            tracing::warn!(grace = ?self.grace, "orchestrator lost; the robot stops if it is not back within the grace period");
            self.lost_since = Some(at);
        }
    }

    /// Whether the robot was stopped by the failsafe.
    pub fn tripped(&self) -> bool {
        self.tripped
    }

    /// When [`Failsafe::check`] next has something to do on its own: the
    /// first microsecond past the grace period, while the orchestrator is
    /// gone and the failsafe has not fired (none otherwise).
    pub fn deadline(&self) -> Option<Micros> {
        let since = self.lost_since.filter(|_| !self.tripped)?;
        Some(since.saturating_add(self.grace_us).saturating_add(1))
    }

    /// What to do at `now`. `Stop` / `StopAndExit` is returned once, when
    /// the grace period has run out; `Remind` once each time the
    /// orchestrator came back after that; `Run` otherwise.
    pub fn check(&mut self, now: Micros) -> Verdict {
        if self.remind {
            self.remind = false;
            return Verdict::Remind { lost_for: self.fired_after };
        }
        let Some(since) = self.lost_since else { return Verdict::Run };
        let lost_us = now.saturating_sub(since);
        if self.tripped || lost_us <= self.grace_us {
            return Verdict::Run;
        }
        let lost_for = Duration::from_micros(lost_us);
        self.tripped = true;
        self.fired_after = lost_for;
        match self.policy {
            OnOrchestratorLost::Exit => Verdict::StopAndExit { lost_for },
            OnOrchestratorLost::Wait => Verdict::Stop { lost_for },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GRACE: Duration = Duration::from_millis(1000);

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    /// `n` ms after the start, in µs.
    fn at(n: u64) -> Micros {
        n * 1000
    }

    #[test]
    fn trips_once_after_the_grace_period() {
        let t0: Micros = 0;
        let mut f = Failsafe::new(GRACE, OnOrchestratorLost::Wait);
        f.orchestrator_alive(t0);
        f.orchestrator_lost(at(100));
        assert_eq!(f.check(at(1100)), Verdict::Run, "exactly the grace period is still fine");
        assert_eq!(f.check(at(1101)), Verdict::Stop { lost_for: ms(1001) });
        assert!(f.tripped());
        assert_eq!(f.check(at(5000)), Verdict::Run, "reported once");
    }

    #[test]
    fn exit_policy_says_exit() {
        let t0: Micros = 0;
        let mut f = Failsafe::new(GRACE, OnOrchestratorLost::Exit);
        f.orchestrator_alive(t0);
        f.orchestrator_lost(t0);
        assert_eq!(f.check(at(1500)), Verdict::StopAndExit { lost_for: ms(1500) });
    }

    #[test]
    fn a_return_within_the_grace_period_cancels() {
        let t0: Micros = 0;
        let mut f = Failsafe::new(GRACE, OnOrchestratorLost::Exit);
        f.orchestrator_alive(t0);
        f.orchestrator_lost(at(10));
        f.orchestrator_alive(at(900));
        assert_eq!(f.check(at(3000)), Verdict::Run);
        // A second loss starts a new grace period.
        f.orchestrator_lost(at(3000));
        assert_eq!(f.check(at(3900)), Verdict::Run);
        assert_eq!(f.check(at(4100)), Verdict::StopAndExit { lost_for: ms(1100) });
    }

    #[test]
    fn a_return_after_tripping_does_not_resume() {
        let t0: Micros = 0;
        let mut f = Failsafe::new(GRACE, OnOrchestratorLost::Wait);
        f.orchestrator_alive(t0);
        f.orchestrator_lost(t0);
        assert!(matches!(f.check(at(2000)), Verdict::Stop { .. }));
        f.orchestrator_alive(at(2500));
        assert!(f.tripped(), "latched");
        assert_eq!(f.check(at(2600)), Verdict::Remind { lost_for: ms(2000) }, "told again once back");
        assert_eq!(f.check(at(2700)), Verdict::Run, "once per return");
        f.orchestrator_lost(at(3000));
        assert_eq!(f.check(at(9000)), Verdict::Run, "never stopped twice");
        // Back and gone again before the shell looked: no reminder into the cut.
        f.orchestrator_alive(at(9100));
        f.orchestrator_lost(at(9200));
        assert_eq!(f.check(at(9300)), Verdict::Run);
        f.orchestrator_alive(at(9400));
        let remind = f.check(at(9500));
        assert_eq!(remind, Verdict::Remind { lost_for: ms(2000) });
        let report = remind.report(RobotId(4));
        assert_eq!(report, Some(FromAgent::Failsafe(FailsafeFired { robot: RobotId(4), silent_ms: 2000 })));
        assert_eq!(Verdict::Run.report(RobotId(4)), None);
    }

    #[test]
    fn the_grace_in_ms_saturates() {
        assert_eq!(Failsafe::new(ms(2500), OnOrchestratorLost::Exit).grace_ms(), 2500);
        let long = Duration::from_secs(u64::MAX / 1000);
        assert_eq!(Failsafe::new(long, OnOrchestratorLost::Exit).grace_ms(), u32::MAX);
    }

    #[test]
    fn unarmed_until_the_orchestrator_was_seen() {
        let t0: Micros = 0;
        let mut f = Failsafe::new(GRACE, OnOrchestratorLost::Exit);
        f.orchestrator_lost(t0);
        assert_eq!(f.check(at(60_000)), Verdict::Run);
        f.orchestrator_alive(at(60_000));
        f.orchestrator_lost(at(60_001));
        assert!(matches!(f.check(at(61_002)), Verdict::StopAndExit { .. }));
    }
}
