//! A launch recording read back as the launch saw it, in log order.
//!
//! Why only these records: replaying the gate needs the run's settings
//! (the `run` metadata), what the orchestrator told robots (deployments,
//! ticks, bearings), every pose it received, the mocap frames it used, and
//! the gate events it published. Everything else (agent reports, JSON
//! copies, summaries) is skipped. Bytes that do not decode are skipped as
//! the launch skipped them (it counted them as bad traffic).
//!
//! The file is read with the `mcap` crate's linear reader (as
//! `record::recover` does), so a recording cut short by a crash replays up
//! to its last complete chunk.

use super::ReplayError;
use crate::launch::core::log::{self, Call};
use crate::launch::core::Setup;
use crate::launch::ports::schema;
use crate::launch::LaunchConfig;
use bycoms_protocol::msg::{GateEvent, Pose, ToAgent};
use bycoms_protocol::{decode, RobotId};
use bycoms_sim::Vec2;
use mcap::io::MessageReader;
use mcap::sans_io::LinearReaderOptions;
use serde::Deserialize;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// Schema name of recorded NatNet frames (the datagram's bytes, as the
/// mocap source received them).
pub const NATNET_FRAME_SCHEMA: &str = "natnet.FrameOfData";

/// Schema name of the recorded model definitions (a `NAT_MODELDEF`
/// packet: the rigid bodies' names).
pub const NATNET_MODELDEF_SCHEMA: &str = "natnet.ModelDef";

/// Schema name of the `run` metadata record.
pub const RUN_SCHEMA: &str = "bycoms.LaunchConfig";

/// One record the replay uses.
#[derive(Clone, Debug, PartialEq)]
pub enum Entry {
    /// A command sent to `robot`.
    Command {
        /// The robot the command's topic belongs to.
        robot: RobotId,
        /// The command.
        command: ToAgent,
    },
    /// A pose received (or relayed) on a robot's pose topic.
    Pose(Pose),
    /// A mocap frame's datagram, as received.
    MocapFrame(Vec<u8>),
    /// The mocap model definitions (a NatNet packet).
    MocapModelDef(Vec<u8>),
    /// A gate event the launch published.
    Gate(GateEvent),
    /// The launch core's setup (`launch::core::log`).
    CoreSetup(Box<Setup>),
    /// Calls the launch made on its core, in order.
    CoreCalls(Vec<Call>),
}

/// The `run` metadata the launch writes first.
#[derive(Clone, Debug, Deserialize)]
pub struct RunMeta {
    /// Terrain name.
    pub terrain: String,
    /// Start position.
    pub start: Vec2,
    /// Goal position.
    pub goal: Vec2,
    /// The launch's whole configuration.
    pub config: LaunchConfig,
}

/// A recording, reduced to what the replay uses.
#[derive(Clone, Debug)]
pub struct Recorded {
    /// The run's settings.
    pub run: RunMeta,
    /// Commands, poses, frames and gate events, in log order.
    pub entries: Vec<Entry>,
    /// Why reading stopped before the footer (a cut file), if it did.
    pub stopped_by: Option<String>,
}

impl Recorded {
    /// The launch core's setup and every call made on it, when the
    /// recording holds them (recordings since the core's log).
    pub fn core_log(&self) -> Option<(Setup, Vec<&Call>)> {
        let setup = self.entries.iter().find_map(|e| match e {
            Entry::CoreSetup(s) => Some((**s).clone()),
            _ => None,
        })?;
        let calls = self
            .entries
            .iter()
            .filter_map(|e| match e {
                Entry::CoreCalls(c) => Some(c.iter()),
                _ => None,
            })
            .flatten()
            .collect();
        Some((setup, calls))
    }

    /// Whether every pose the core log says the core was handed is on the
    /// record, in the same order (the log is evidence only if its inputs
    /// are the recorded traffic): the first one that is not, if any. The
    /// recorded poses may hold more (the launch's own relays, seen again
    /// on the bus); the log's must be among them, bit for bit.
    pub fn unrecorded_input(&self, calls: &[&Call]) -> Option<Pose> {
        let mut recorded = self.entries.iter().filter_map(|e| match e {
            Entry::Pose(p) => Some(p),
            _ => None,
        });
        let bits = |p: &Pose| (p.robot, p.step, p.time_us, p.x.to_bits(), p.y.to_bits(), p.heading.to_bits());
        calls
            .iter()
            .filter_map(|c| match c {
                Call::Handle(_, crate::launch::core::Input::Pose { pose, .. }) => Some(pose),
                _ => None,
            })
            .find(|input| !recorded.any(|p| bits(p) == bits(input)))
            .copied()
    }

    /// The gate events as recorded, in order.
    pub fn gate_events(&self) -> impl Iterator<Item = &GateEvent> {
        self.entries.iter().filter_map(|e| match e {
            Entry::Gate(g) => Some(g),
            _ => None,
        })
    }
}

/// Reads `path`.
pub fn read_recording(path: &Path) -> Result<Recorded, ReplayError> {
    let open = |source| ReplayError::Open { path: path.to_path_buf(), source };
    let file = File::open(path).map_err(open)?;
    let len = file.metadata().map_err(open)?.len();
    let limit = usize::try_from(len).unwrap_or(usize::MAX);
    let options = LinearReaderOptions::default().with_record_length_limit(limit);
    let mut run = None;
    let mut entries = Vec::new();
    let mut stopped_by = None;
    for item in MessageReader::new_with_options(BufReader::new(file), options) {
        let message = match item {
            Ok(m) => m,
            Err(e) if entries.is_empty() && run.is_none() => {
                return Err(ReplayError::NotMcap { path: path.to_path_buf(), reason: e.to_string() })
            }
            Err(e) => {
                stopped_by = Some(e.to_string());
                break;
            }
        };
        let schema_name = message.channel.schema.as_ref().map(|s| s.name.as_str()).unwrap_or_default();
        let topic = message.channel.topic.as_str();
        let data = message.data.as_ref();
        match schema_name {
            RUN_SCHEMA if topic.ends_with("/run") => {
                let meta = serde_json::from_slice(data).map_err(|e| ReplayError::BadRunMeta {
                    topic: topic.to_owned(),
                    reason: e.to_string(),
                })?;
                run = Some(meta);
            }
            schema::TO_AGENT => {
                if let (Some(robot), Ok(command)) = (robot_of_topic(topic), decode::<ToAgent>(data)) {
                    entries.push(Entry::Command { robot, command });
                }
            }
            schema::POSE => {
                if let Ok(pose) = decode::<Pose>(data) {
                    entries.push(Entry::Pose(pose));
                }
            }
            schema::GATE if message.channel.message_encoding == crate::record::POSTCARD => {
                if let Ok(event) = decode::<GateEvent>(data) {
                    entries.push(Entry::Gate(event));
                }
            }
            // A log that does not decode is left out: the replay then
            // re-judges from the poses, and says so.
            log::SETUP_SCHEMA => {
                if let Ok(setup) = log::decode_setup(data) {
                    entries.push(Entry::CoreSetup(Box::new(setup)));
                }
            }
            log::CALLS_SCHEMA => {
                if let Ok(calls) = log::decode_calls(data) {
                    entries.push(Entry::CoreCalls(calls));
                }
            }
            NATNET_FRAME_SCHEMA => entries.push(Entry::MocapFrame(data.to_vec())),
            NATNET_MODELDEF_SCHEMA => entries.push(Entry::MocapModelDef(data.to_vec())),
            _ => {}
        }
    }
    let run = run.ok_or_else(|| ReplayError::NoRunMeta { path: path.to_path_buf() })?;
    Ok(Recorded { run, entries, stopped_by })
}

/// The robot of a `…/robot/<k>/…` topic.
fn robot_of_topic(topic: &str) -> Option<RobotId> {
    let mut parts = topic.split('/');
    parts.by_ref().find(|p| *p == "robot")?;
    parts.next()?.parse().ok().map(RobotId)
}

#[cfg(test)]
mod tests {
    use super::robot_of_topic;
    use bycoms_protocol::RobotId;

    #[test]
    fn robot_ids_come_from_the_topic() {
        assert_eq!(robot_of_topic("bycoms/s/robot/12/to_agent"), Some(RobotId(12)));
        assert_eq!(robot_of_topic("bycoms/s/gate"), None);
        assert_eq!(robot_of_topic("bycoms/s/robot/x/pose"), None);
    }
}
