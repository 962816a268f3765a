//! One NatNet frame → the robots' trusted arena poses (sans-IO).
//!
//! Why apart from the socket: this is the whole per-frame path (names,
//! axes, tracker) and the replay of a recording needs exactly it without a
//! network; the benchmark measures it too.

use super::arena::ArenaTransform;
use super::names::BodyMap;
use super::tracker::{PoseTracker, Sighting, TrackEvent};
use bycoms_protocol::msg::Pose;
use bycoms_protocol::natnet::FrameOfData;
use bycoms_protocol::RobotId;
use std::collections::BTreeSet;

/// The trusted poses of one frame, and what went wrong.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoseBatch {
    /// Mocap frame number.
    pub step: u64,
    /// Stream time since the first frame, µs.
    pub time_us: u64,
    /// Fresh, tracked, plausible poses only; robot order.
    pub poses: Vec<Pose>,
    /// Lost / recovered bodies and rejected jumps.
    pub events: Vec<TrackEvent>,
}

/// Names, axes and tracker, applied frame by frame.
#[derive(Clone, Debug)]
pub struct FramePipeline {
    transform: ArenaTransform,
    bodies: BodyMap,
    tracker: PoseTracker,
    first_timestamp: Option<f64>,
    warned_ids: BTreeSet<i32>,
}

impl FramePipeline {
    /// A pipeline over resolved `bodies`.
    pub fn new(transform: ArenaTransform, bodies: BodyMap, tracker: PoseTracker) -> Self {
        Self { transform, bodies, tracker, first_timestamp: None, warned_ids: BTreeSet::new() }
    }

    /// The tracker (e.g. to anchor a robot placed at the start).
    pub fn tracker_mut(&mut self) -> &mut PoseTracker {
        &mut self.tracker
    }

    /// Processes one frame.
    pub fn on_frame(&mut self, frame: &FrameOfData) -> PoseBatch {
        let t0 = *self.first_timestamp.get_or_insert(frame.suffix.timestamp);
        let seconds = frame.suffix.timestamp - t0;
        let time_us = if seconds.is_finite() && seconds > 0.0 { (seconds * 1e6).round() as u64 } else { 0 };
        let step = u64::try_from(frame.frame_number).unwrap_or(0);
        let mut sightings = Vec::with_capacity(frame.rigid_bodies.len());
        for body in &frame.rigid_bodies {
            let Some(robot) = self.bodies.robot(body.id) else {
                if self.warned_ids.insert(body.id) {
                    tracing::warn!(id = body.id, "mocap frame has a body no robot is mapped to: ignored");
                }
                continue;
            };
            let sighting =
                match body.tracking_valid().then(|| self.transform.to_arena(body.position, body.orientation))
                {
                    Some(Some(pose)) => Sighting::Tracked(pose),
                    _ => Sighting::Untracked,
                };
            sightings.push((robot, sighting));
        }
        let poses = self.tracker.frame(step, time_us, &sightings);
        let events = self.tracker.drain_events();
        for event in &events {
            report(event, self.bodies.name(event.robot()));
        }
        PoseBatch { step, time_us, poses, events }
    }

    /// The rigid-body name of `robot`, as the operator knows it.
    pub fn body_name(&self, robot: RobotId) -> &str {
        self.bodies.name(robot)
    }
}

/// Says what went wrong, naming the body as the operator knows it (its
/// Motive name, or its ROS 2 topic): the one wording of every mocap source.
pub fn report(event: &TrackEvent, name: &str) {
    match *event {
        TrackEvent::Lost { robot, since_us } => {
            tracing::warn!(body = name, %robot, since_us, "mocap body {name} ({robot}) lost: no trusted pose for longer than the lost-body time");
        }
        TrackEvent::Recovered { robot, at_us } => {
            tracing::info!(body = name, %robot, at_us, "mocap body tracked again");
        }
        TrackEvent::JumpRejected { robot, distance, allowed, at_us, .. } => {
            tracing::warn!(body = name, %robot, distance, allowed, at_us, "mocap pose of {name} ({robot}) jumped farther than it can drive: rejected (identity swap?)");
        }
    }
}
