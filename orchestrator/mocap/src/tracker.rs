//! Poses the gate can trust: occlusion held, identity swaps rejected.
//!
//! Why: the gate decides "stopped" from motion. Motion capture fails in
//! two ways that look like motion facts but are not (paper §VI):
//!
//! * **occlusion** — Motive sends the body with tracking-valid off and a
//!   zero pose, or leaves it out. Read naively, the robot "jumped to the
//!   origin and stood there", or "stopped moving". Here an untracked body
//!   simply yields no pose: the gate sees a gap, never a still robot, and
//!   a body lost longer than `lost_after_us` is reported by an event.
//! * **identity swap** — with markers detached, Motive can solve robot 1's
//!   rigid body on robot 3's markers (the paper's 3-robot run). A pose
//!   farther from the last trusted one than the robot could have driven in
//!   the elapsed time (`max_speed × Δt + jump_slack`) is rejected,
//!   recorded as [`TrackEvent::JumpRejected`] and warned about; it never
//!   reaches the gate or a bearing.
//!
//! Why a jump rule of its own beside the launch core's (`gate.max_speed`,
//! `orchestrator/launch-core/src/plausible.rs`): that one judges every
//! source's poses (a forged bus pose) against the last pose the core
//! accepted for a deployed robot, over pose time, with no slack, and its
//! default is a generous ceiling (5 units/s); this one exists with motion
//! capture only, judges every frame against the last trusted sample (a
//! body carried by hand too), in frame time, with a noise slack, and must
//! be the crawlers' real top speed to catch a swap before any agent steers
//! by it. One setting cannot be both; a pose passed here still meets the
//! core's rule. Units: arena units (after `arena.scale`: metres at scale 1)
//! per second of the capture's frame time.
//!
//! Limits, by design: two robots closer than `jump_slack` can swap
//! undetected (their poses are then nearly the same anyway); a robot truly
//! carried away stays rejected and is reported lost — a person must look.
//!
//! Sans-IO: frames (already in arena coordinates) in, trusted poses and
//! events out; time is an argument.

use super::arena::ArenaPose;
use bycoms_protocol::msg::Pose;
use bycoms_protocol::RobotId;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The tracker's limits.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TrackerConfig {
    /// Fastest a robot can drive, arena units per second of frame time
    /// (`tracker.max_speed`; not the core's `gate.max_speed`: see the
    /// module docs).
    pub max_speed: f64,
    /// Extra distance always allowed (mocap noise), arena units.
    pub jump_slack: f64,
    /// A body untracked this long is reported lost, µs.
    pub lost_after_us: u64,
}

/// What one frame says about one mapped body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sighting {
    /// Tracked: its arena pose.
    Tracked(ArenaPose),
    /// In the frame with tracking-valid off (or an unusable pose).
    Untracked,
}

/// Something the operator and the recording should know.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TrackEvent {
    /// No trusted pose for longer than `lost_after_us`.
    Lost {
        /// The robot.
        robot: RobotId,
        /// Time of its last trusted pose, µs.
        since_us: u64,
    },
    /// Trusted poses again after being reported lost.
    Recovered {
        /// The robot.
        robot: RobotId,
        /// When, µs.
        at_us: u64,
    },
    /// A pose too far from the last trusted one: taken for an id swap.
    JumpRejected {
        /// The robot the pose was streamed for.
        robot: RobotId,
        /// The rejected pose.
        pose: ArenaPose,
        /// Distance from the last trusted pose, arena units.
        distance: f64,
        /// The most it could have moved, arena units.
        allowed: f64,
        /// When, µs.
        at_us: u64,
    },
}

impl TrackEvent {
    /// The robot it is about.
    pub fn robot(&self) -> RobotId {
        match *self {
            Self::Lost { robot, .. } | Self::Recovered { robot, .. } | Self::JumpRejected { robot, .. } => {
                robot
            }
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Track {
    last: Option<(ArenaPose, u64)>,
    reported_lost: bool,
}

/// Tracks every mapped robot across frames.
#[derive(Clone, Debug)]
pub struct PoseTracker {
    config: TrackerConfig,
    tracks: BTreeMap<RobotId, Track>,
    events: Vec<TrackEvent>,
}

impl PoseTracker {
    /// Tracks `robots`, none seen yet.
    pub fn new(config: TrackerConfig, robots: impl IntoIterator<Item = RobotId>) -> Self {
        let tracks = robots.into_iter().map(|r| (r, Track { last: None, reported_lost: false })).collect();
        Self { config, tracks, events: Vec::new() }
    }

    /// Anchors a robot where it is known to be (e.g. placed at the start),
    /// so even its first streamed pose is checked for a swap.
    pub fn anchor(&mut self, robot: RobotId, pose: ArenaPose, time_us: u64) {
        if let Some(t) = self.tracks.get_mut(&robot) {
            t.last = Some((pose, time_us));
        }
    }

    /// Forgets where `robot` was: its next pose is trusted as a first
    /// sighting (while the operator carries it to the start by hand, when
    /// any speed is plausible).
    pub fn forget(&mut self, robot: RobotId) {
        if let Some(t) = self.tracks.get_mut(&robot) {
            *t = Track { last: None, reported_lost: false };
        }
    }

    /// The last trusted pose of `robot` and its time.
    pub fn last(&self, robot: RobotId) -> Option<(ArenaPose, u64)> {
        self.tracks.get(&robot).and_then(|t| t.last)
    }

    /// Events since the last call.
    pub fn drain_events(&mut self) -> Vec<TrackEvent> {
        std::mem::take(&mut self.events)
    }

    /// Takes one frame's sightings (bodies absent from the frame are simply
    /// not listed) and returns the trusted poses, robot order.
    pub fn frame(&mut self, step: u64, time_us: u64, sightings: &[(RobotId, Sighting)]) -> Vec<Pose> {
        let mut trusted = Vec::new();
        for (&robot, track) in &mut self.tracks {
            let seen = sightings.iter().find(|(r, _)| *r == robot).map(|(_, s)| *s);
            if let Some(Sighting::Tracked(pose)) = seen {
                let accepted = match track.last {
                    None => true,
                    Some((last, at)) => {
                        let dt = time_us.saturating_sub(at) as f64 * 1e-6;
                        let allowed = self.config.max_speed * dt + self.config.jump_slack;
                        let distance = (pose.x - last.x).hypot(pose.y - last.y);
                        let ok = distance <= allowed;
                        if !ok {
                            tracing::debug!(%robot, distance, allowed, "mocap pose jump rejected");
                            self.events.push(TrackEvent::JumpRejected {
                                robot,
                                pose,
                                distance,
                                allowed,
                                at_us: time_us,
                            });
                        }
                        ok
                    }
                };
                if accepted {
                    if track.reported_lost {
                        track.reported_lost = false;
                        tracing::debug!(%robot, "mocap body tracked again");
                        self.events.push(TrackEvent::Recovered { robot, at_us: time_us });
                    }
                    track.last = Some((pose, time_us));
                    trusted.push(Pose { robot, x: pose.x, y: pose.y, heading: pose.heading, step, time_us });
                    continue;
                }
            }
            // Untracked, missing or rejected: hold, maybe report.
            if let Some((_, since_us)) = track.last {
                if !track.reported_lost && time_us.saturating_sub(since_us) > self.config.lost_after_us {
                    track.reported_lost = true;
                    tracing::debug!(%robot, since_us, "mocap body lost");
                    self.events.push(TrackEvent::Lost { robot, since_us });
                }
            }
        }
        trusted
    }
}
