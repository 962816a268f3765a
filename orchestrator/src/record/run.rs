//! A launch's run read back from its recording: the run metadata (terrain,
//! start, goal, ε, clock), every pose and gate decision, and real robots'
//! telemetry, decoded from the bus bytes — what `orchestrator draw
//! FILE.mcap` draws.
//!
//! Streamed like [`super::recover`], so a recording cut by a crash draws
//! up to its last complete chunk.

use std::io::BufReader;
use std::path::Path;

use bycoms_protocol::decode;
use bycoms_protocol::msg::{FromAgent, GateEvent, Pose};
use mcap::io::MessageReader;
use mcap::sans_io::LinearReaderOptions;
use serde::Deserialize;

use super::RecordError;
use crate::draw::measurements::Measurements;
use crate::draw::trace::Trace;

/// Schema name of the run metadata channel (`bycoms/<swarm>/run`).
pub const RUN_SCHEMA: &str = "bycoms.LaunchConfig";
/// Schema name of recorded poses (postcard bytes).
pub const POSE_SCHEMA: &str = "bycoms.Pose";
/// Schema name of recorded gate events (postcard bytes).
pub const GATE_SCHEMA: &str = "bycoms.GateEvent";
/// Schema name of recorded agent reports (postcard bytes).
pub const FROM_AGENT_SCHEMA: &str = "bycoms.FromAgent";

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
}

impl RunMeta {
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
    /// The run metadata, if the recording has it.
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

/// Reads the run of the recording at `path`.
pub fn read_run(path: &Path) -> Result<RecordedRun, RecordError> {
    let (file, len) = super::open_recording(path)?;
    let limit = usize::try_from(len).unwrap_or(usize::MAX);
    let options = LinearReaderOptions::default().with_record_length_limit(limit);
    let mut run = RecordedRun {
        meta: None,
        trace: Trace::new(),
        measurements: Measurements::new(),
        undecodable: 0,
        stopped_by: None,
    };
    for (seen, item) in MessageReader::new_with_options(BufReader::new(file), options).enumerate() {
        let message = match item {
            Ok(message) => message,
            Err(error @ mcap::McapError::BadMagic) if seen == 0 => {
                return Err(super::read::not_mcap(path, &error))
            }
            Err(error) => {
                run.stopped_by = Some(error.to_string());
                break;
            }
        };
        let schema = message.channel.schema.as_ref().map_or("", |s| s.name.as_str());
        let postcard = message.channel.message_encoding == super::POSTCARD;
        match schema {
            RUN_SCHEMA if run.meta.is_none() => {
                run.meta = serde_json::from_slice(&message.data).ok();
            }
            POSE_SCHEMA if postcard => match decode::<Pose>(&message.data) {
                Ok(pose) => {
                    run.trace.pose(&pose);
                    run.measurements.pose(&pose);
                }
                Err(_) => run.undecodable += 1,
            },
            FROM_AGENT_SCHEMA if postcard => {
                if let Ok(report) = decode::<FromAgent>(&message.data) {
                    run.measurements.report(&report);
                }
            }
            GATE_SCHEMA if postcard => match decode::<GateEvent>(&message.data) {
                Ok(event) => run.trace.gate(&event),
                Err(_) => run.undecodable += 1,
            },
            _ => {}
        }
    }
    Ok(run)
}
