//! A launch's run read back from its recording: the run metadata (terrain,
//! start, goal, ε, clock), every pose and gate decision, and real robots'
//! telemetry, decoded from the bus bytes — what `orchestrator draw
//! FILE.mcap` draws.
//!
//! Read with the recording's one streaming reader ([`bycoms_record::Reader`],
//! as `replay` and `record recover` read), its messages decoded by
//! [`bycoms_record::decode`], so a recording cut by a crash draws up to its
//! last complete chunk.
//!
//! Why in `draw` and not in `record`: reading a run back for its picture
//! builds the picture's [`Trace`] and [`Measurements`]; the recording knows
//! no pictures (pictures sit above it, ARCHITECTURE.md, "Layers of the
//! orchestrator").

use std::path::Path;

use serde::Deserialize;

use super::measurements::Measurements;
use super::trace::Trace;
use bycoms_record::decode::{decode_message, Content};
use bycoms_record::read::{Item, Reader};
use bycoms_record::{schema, RecordError};

/// The run metadata a launch records first.
#[derive(Debug, Clone, Deserialize)]
pub struct RunMeta {
    /// Where the terrain came from.
    pub terrain: String,
    /// The terrain in the text format (recordings since this field exists).
    pub terrain_text: Option<String>,
    /// Start position.
    pub start: bycoms_sim::Vec2,
    /// Goal position.
    pub goal: bycoms_sim::Vec2,
    /// The swarm name.
    #[serde(default)]
    pub swarm: Option<String>,
    /// The launch configuration (ε, clock, …) as recorded.
    pub config: serde_json::Value,
    /// The poses the launch core applied are recorded on their own
    /// (`core/moved`): the run is drawn from those, not from every pose
    /// motion capture delivered (refused and forged ones are on the bus's
    /// pose topics too). False in recordings older than it.
    #[serde(default)]
    pub applied_poses: bool,
    /// The changes of the launch core's beacon table are recorded
    /// (`core/beacon`): the run's beacons are shown from those, creeping as
    /// the core's ([`RunView::new`]). False in recordings older than it:
    /// the gate's decisions place them ([`RunView::without_beacons`]).
    #[serde(default)]
    pub beacons_told: bool,
    /// Every change of a robot's state in the launch core is on
    /// `core/state` (`record export --ros2` shows states from those). False
    /// in recordings older than it: the gate's decisions imply them
    /// ([`RunView::without_states`]).
    #[serde(default)]
    pub states_told: bool,
    /// Each ROS 2 robot's velocity topic and message type; empty without
    /// ROS 2 robots (and in recordings older than it).
    #[serde(default)]
    pub ros2_robots: Vec<schema::Ros2RobotTopic>,
    /// The robots with a real body (a lab's; in a mixed swarm its real
    /// members); empty when every robot was simulated (and in recordings
    /// older than it).
    #[serde(default)]
    pub real: Vec<u32>,
}

impl RunMeta {
    /// Whether a recorded message is a pose the run shows: the core's
    /// applied poses when the recording has them, else (an older
    /// recording) every pose on the bus.
    pub fn shown_pose(meta: Option<&Self>, content: &Content<'_>) -> Option<bycoms_protocol::msg::Pose> {
        let applied = meta.is_some_and(|m| m.applied_poses);
        match content {
            Content::Moved(pose) if applied => Some(*pose),
            Content::Pose(pose) if !applied => Some(*pose),
            _ => None,
        }
    }

    /// ε of the run.
    pub fn eps(&self) -> Option<f64> {
        self.config["eps"].as_f64()
    }

    /// `lockstep` or `realtime`.
    pub fn clock(&self) -> &str {
        self.config["clock"].as_str().unwrap_or("?")
    }
}

/// What a recording says about its run.
#[derive(Debug, Clone)]
pub struct RecordedRun {
    /// The run metadata, unless it does not parse.
    pub meta: Option<RunMeta>,
    /// Poses and gate decisions in recording order.
    pub trace: Trace,
    /// Poses and robot telemetry, for the measurement picture.
    pub measurements: Measurements,
    /// Bus messages on pose or gate channels that did not decode (garbage is recorded too).
    pub undecodable: u64,
    /// `None` if read to its end; otherwise why reading stopped (a cut recording).
    pub stopped_by: Option<String>,
}

/// Reads the run of the recording at `path`: a launch recording
/// ([`RecordError::NotLaunch`] otherwise), undamaged ([`RecordError::Damaged`]).
pub fn read_run(path: &Path) -> Result<RecordedRun, RecordError> {
    let mut run = RecordedRun {
        meta: None,
        trace: Trace::new(),
        measurements: Measurements::new(),
        undecodable: 0,
        stopped_by: None,
    };
    let end = Reader::open(path)?.stream(|item| {
        let Item::Message { channel, data, .. } = item else { return Ok::<_, RecordError>(()) };
        let content = decode_message(channel, data);
        if let Some(pose) = RunMeta::shown_pose(run.meta.as_ref(), &content) {
            run.trace.pose(&pose);
            run.measurements.pose(&pose);
        }
        match content {
            // The first run record is the run's.
            Content::Run(json) if run.meta.is_none() => {
                run.meta = serde_json::from_slice(json).ok();
                if run.meta.as_ref().is_some_and(|m| m.beacons_told) {
                    run.trace = Trace::with_beacons_told();
                }
            }
            Content::Beacon { robot, x, y } => run.trace.beacon(robot, bycoms_sim::Vec2::new(x, y)),
            Content::Report(report) => run.measurements.report(&report),
            Content::Gate(event) => run.trace.gate(&event),
            Content::Undecodable { schema: schema::POSE | schema::GATE } => run.undecodable += 1,
            _ => {}
        }
        Ok(())
    })?;
    end.launch_recording(path)?;
    run.stopped_by = end.stopped_by;
    Ok(run)
}
