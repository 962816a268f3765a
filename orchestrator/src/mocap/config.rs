//! `[mocap]` of a launch config: where the gate's poses come from.
//!
//! Why a section of its own: in simulation the agents are their own motion
//! capture (`source = "bus"`, the default: nothing else to set); in a lab
//! the orchestrator reads OptiTrack (`source = "natnet"`), and then needs
//! the server's address, which rigid body is which robot, the axis
//! convention and how long a body may be unseen before it is reported
//! lost, plus how the operator places each robot at the start. Every key
//! is documented in `deploy/launch.toml` (commented out: not the default).

use super::{ArenaTransform, ClientConfig, TrackerConfig};
use bycoms_protocol::RobotId;
use bycoms_runtime::seconds::{check_seconds, Zero, MAX_SECONDS};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Which pose source a launch uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MocapSource {
    /// The simulated agents publish their own poses on the bus.
    #[default]
    Bus,
    /// OptiTrack NatNet (a real lab, or the emulated lab's `natnet-serve`).
    Natnet,
}

/// `[mocap]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MocapConfig {
    /// `bus` or `natnet`.
    pub source: MocapSource,
    /// `[mocap.natnet]`: required with `source = "natnet"`.
    pub natnet: Option<NatNetSourceConfig>,
}

/// `[mocap.natnet]`: the NatNet source.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NatNetSourceConfig {
    /// How to reach the server.
    pub client: ClientConfig,
    /// Mocap → arena: up axis, origin, scale.
    #[serde(default)]
    pub arena: ArenaTransform,
    /// Rigid-body name (as in Motive) → robot id.
    pub bodies: BTreeMap<String, RobotId>,
    /// Plausible motion and the lost-body time.
    pub tracker: TrackerConfig,
    /// The operator's placement of each robot at the start.
    #[serde(default)]
    pub placement: PlacementConfig,
}

/// How a robot's placement at the start is confirmed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlacementConfig {
    /// The robot counts as placed within this distance of the start, arena units.
    pub radius: f64,
    /// ...seen there, tracked, for this long (s): not just carried past it.
    pub hold: f64,
    /// The operator gets this long (s) before the launch ends with an error.
    pub timeout: f64,
}

impl Default for PlacementConfig {
    fn default() -> Self {
        Self { radius: 0.5, hold: 1.0, timeout: 600.0 }
    }
}

impl MocapConfig {
    /// Checks the section against a launch of `robots` robots; the message
    /// names the key.
    pub fn validate(&self, robots: u32) -> Result<(), String> {
        let Some(natnet) = &self.natnet else {
            return match self.source {
                MocapSource::Bus => Ok(()),
                MocapSource::Natnet => Err("mocap.source = \"natnet\" needs a [mocap.natnet] section".into()),
            };
        };
        if self.source == MocapSource::Bus {
            return Err("[mocap.natnet] is set but mocap.source is \"bus\"".into());
        }
        natnet.validate(robots)
    }
}

impl NatNetSourceConfig {
    /// The settings for a launch of `robots` robots: bodies mapped to later
    /// robots are left out (one lab file names every robot of the lab; a
    /// scenario uses the first ones, as with the robots file).
    pub fn for_robots(&self, robots: u32) -> Self {
        let mut cfg = self.clone();
        cfg.bodies.retain(|_, robot| robot.0 <= robots);
        cfg
    }

    /// Checks the NatNet settings against a launch of `robots` robots
    /// (bodies of later robots are allowed: see [`Self::for_robots`]).
    pub fn validate(&self, robots: u32) -> Result<(), String> {
        let mut seen = BTreeMap::new();
        for (name, robot) in &self.bodies {
            if robot.0 == 0 {
                return Err(format!("mocap.natnet.bodies.{name} = 0 is not a robot (ids start at 1)"));
            }
            if let Some(other) = seen.insert(*robot, name) {
                return Err(format!("mocap.natnet.bodies: {other} and {name} are both robot {}", robot.0));
            }
        }
        if let Some(missing) = (1..=robots).find(|k| !seen.contains_key(&RobotId(*k))) {
            return Err(format!("mocap.natnet.bodies: no rigid body is robot {missing}"));
        }
        let t = &self.tracker;
        let s = &self.arena;
        let p = &self.placement;
        for (key, value) in [
            ("mocap.natnet.tracker.max_speed", t.max_speed),
            ("mocap.natnet.arena.scale", s.scale),
            ("mocap.natnet.placement.radius", p.radius),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(format!("{key} must be a positive number, got {value}"));
            }
        }
        if !(t.jump_slack.is_finite() && t.jump_slack >= 0.0) {
            return Err(format!(
                "mocap.natnet.tracker.jump_slack must be a non-negative number, got {}",
                t.jump_slack
            ));
        }
        check_seconds("mocap.natnet.placement.timeout", p.timeout, Zero::Refused)?;
        check_seconds("mocap.natnet.placement.hold", p.hold, Zero::Allowed)?;
        if t.lost_after_us == 0 {
            return Err("mocap.natnet.tracker.lost_after_us must be at least 1".into());
        }
        // Added to an `Instant` for every command: near u64::MAX it
        // overflowed (a panic); 0 is no socket timeout at all.
        let reply_ms = self.client.reply_timeout_ms;
        let max_ms = (MAX_SECONDS * 1000.0) as u64;
        if !(1..=max_ms).contains(&reply_ms) {
            return Err(format!(
                "mocap.natnet.client.reply_timeout_ms must be a number of milliseconds in [1, {max_ms}], got {reply_ms}"
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LAB: &str = r#"
        source = "natnet"
        [natnet.client]
        server = "127.0.0.1:1510"
        [natnet.arena]
        up = "y"
        scale = 10.0
        [natnet.bodies]
        robot1 = 1
        robot2 = 2
        [natnet.tracker]
        max_speed = 1.5
        jump_slack = 0.2
        lost_after_us = 500000
    "#;

    #[test]
    fn a_lab_section_parses_validates_and_round_trips() {
        let cfg: MocapConfig = toml::from_str(LAB).unwrap();
        assert_eq!(cfg.source, MocapSource::Natnet);
        let natnet = cfg.natnet.as_ref().unwrap();
        assert_eq!(natnet.bodies["robot2"], RobotId(2));
        assert_eq!(natnet.placement, PlacementConfig::default());
        cfg.validate(2).unwrap();
        let again: MocapConfig = toml::from_str(&toml::to_string(&cfg).unwrap()).unwrap();
        assert_eq!(again, cfg);
    }

    #[test]
    fn every_mistake_is_named() {
        let cfg: MocapConfig = toml::from_str(LAB).unwrap();
        let err = cfg.validate(3).unwrap_err();
        assert!(err.contains("robot 3"), "{err}");
        // A lab file names every robot; a launch of fewer uses the first.
        cfg.validate(1).expect("robot 2's body is left out of a 1-robot launch");
        let one = cfg.natnet.as_ref().expect("natnet").for_robots(1);
        assert_eq!(one.bodies.keys().collect::<Vec<_>>(), ["robot1"]);
        let zero = LAB.replace("robot2 = 2", "robot2 = 0");
        let err = toml::from_str::<MocapConfig>(&zero).unwrap().validate(2).unwrap_err();
        assert!(err.contains("bodies.robot2"), "{err}");
        let natnet_off = MocapConfig { source: MocapSource::Natnet, natnet: None };
        assert!(natnet_off.validate(1).unwrap_err().contains("[mocap.natnet]"));
        let err = toml::from_str::<MocapConfig>(&LAB.replace("jump_slack", "jump_slak")).unwrap_err();
        assert!(err.to_string().contains("jump_slak"), "{err}");
        let twice = LAB.replace("robot2 = 2", "robot2 = 1");
        let err = toml::from_str::<MocapConfig>(&twice).unwrap().validate(2).unwrap_err();
        assert!(err.contains("both robot 1"), "{err}");
        assert_eq!(MocapConfig::default().validate(5), Ok(()));
    }

    #[test]
    fn a_reply_timeout_past_any_run_or_of_zero_is_named() {
        let with = |ms: u64| {
            let text = LAB.replace(
                "server = \"127.0.0.1:1510\"",
                &format!("server = \"127.0.0.1:1510\"\nreply_timeout_ms = {ms}"),
            );
            toml::from_str::<MocapConfig>(&text).expect("parses").validate(2)
        };
        for ms in [u64::MAX, 100_000_000_001, 0] {
            let err = with(ms).unwrap_err();
            let says = format!("mocap.natnet.client.reply_timeout_ms must be a number of milliseconds in [1, 100000000000], got {ms}");
            assert_eq!(err, says);
        }
        assert_eq!(with(100_000_000_000), Ok(()));
        assert_eq!(with(1), Ok(()));
    }
}
