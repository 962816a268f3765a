//! A launch recording read back as the launch saw it, in log order.
//!
//! Why only these records: replaying the gate needs the run's settings
//! (the `run` metadata), what the orchestrator told robots (deployments,
//! ticks, bearings), every pose it received, the mocap frames it used, and
//! the gate events it published. Everything else (agent reports, JSON
//! copies, summaries) is skipped. Bytes that do not decode are skipped as
//! the launch skipped them (it counted them as bad traffic).
//!
//! The file is read with the recording's one streaming reader
//! (`record::Reader`, as `draw` and `record recover` read), its messages
//! decoded by `record::decode`, so a recording cut short by a crash replays
//! up to its last complete chunk. Only the launch core's log is decoded
//! here, by its own codec (`launch::core::log`). The log names each pose
//! the core was handed by its number on its robot's pose topic (a pose is
//! stored once), so the pose messages are also kept by topic and number
//! ([`Recorded::core_log`] puts them back).

use super::ReplayError;
use bycoms_launch::core::log::{self, Call};
use bycoms_launch::core::Setup;
use bycoms_launch::LaunchConfig;
use bycoms_protocol::msg::{GateEvent, Pose, ToAgent};
use bycoms_protocol::RobotId;
use bycoms_record::decode::{decode_message, Content};
use bycoms_record::{Item, Reader};
use bycoms_sim::Vec2;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

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
    /// The launch's whole configuration (keys that moved since carried over).
    #[serde(deserialize_with = "recorded_config")]
    pub config: LaunchConfig,
}

/// A recording's configuration, read by [`LaunchConfig::from_recorded`].
fn recorded_config<'de, D: serde::Deserializer<'de>>(d: D) -> Result<LaunchConfig, D::Error> {
    let value = serde_json::Value::deserialize(d)?;
    LaunchConfig::from_recorded(value).map_err(serde::de::Error::custom)
}

/// A recording, reduced to what the replay uses.
#[derive(Clone, Debug)]
pub struct Recorded {
    /// The run's settings.
    pub run: RunMeta,
    /// Commands, poses, frames and gate events, in log order.
    pub entries: Vec<Entry>,
    /// Every message on each robot's pose topic, in file order (none: its
    /// bytes do not decode): what the core log's pose numbers name.
    pub poses_on: BTreeMap<u32, Vec<Option<Pose>>>,
    /// Why reading stopped before the footer (a cut file), if it did.
    pub stopped_by: Option<String>,
    /// What the run lacks, when the file is a copy `record recover` wrote
    /// of a recording cut short or damaged ([`bycoms_record::End::partial`]).
    pub partial: Option<String>,
}

/// The launch core's log in a recording, its recorded poses put back.
#[derive(Clone, Debug)]
pub struct CoreLog {
    /// The core's setup.
    pub setup: Setup,
    /// Every call made on the core, in order (up to a pose not on the record).
    pub calls: Vec<Call>,
    /// A pose the log names that the recording does not hold (robot, its
    /// number on the robot's pose topic): the log is no evidence then.
    pub missing: Option<(u32, u32)>,
}

impl Recorded {
    /// The launch core's setup and every call made on it, when the
    /// recording holds them (recordings since the core's log), with the
    /// poses it names by number read back.
    pub fn core_log(&self) -> Option<CoreLog> {
        let setup = self.entries.iter().find_map(|e| match e {
            Entry::CoreSetup(s) => Some((**s).clone()),
            _ => None,
        })?;
        let logged = self
            .entries
            .iter()
            .filter_map(|e| match e {
                Entry::CoreCalls(c) => Some(c.iter()),
                _ => None,
            })
            .flatten();
        let on = |robot: u32, n: u32| *self.poses_on.get(&robot)?.get(n as usize)?;
        let (calls, missing) = log::resolve(logged, on);
        Some(CoreLog { setup, calls, missing })
    }

    /// Whether every pose the core log says the core was handed is on the
    /// record, in the same order (the log is evidence only if its inputs
    /// are the recorded traffic): the first one that is not, if any. The
    /// recorded poses may hold more (the launch's own relays, seen again
    /// on the bus); the log's must be among them, bit for bit.
    pub fn unrecorded_input(&self, calls: &[Call]) -> Option<Pose> {
        let mut recorded = self.entries.iter().filter_map(|e| match e {
            Entry::Pose(p) => Some(p),
            _ => None,
        });
        let bits = |p: &Pose| (p.robot, p.step, p.time_us, p.x.to_bits(), p.y.to_bits(), p.heading.to_bits());
        calls
            .iter()
            .filter_map(|c| match c {
                Call::Handle(_, bycoms_launch::core::Input::Pose { pose, .. }) => Some(pose),
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
    let mut run = None;
    let mut entries = Vec::new();
    let mut poses_on = BTreeMap::<u32, Vec<Option<Pose>>>::new();
    let end = Reader::open(path)?.stream(|item| {
        let Item::Message { channel, data, .. } = item else { return Ok::<_, ReplayError>(()) };
        let content = decode_message(channel, data);
        if let Some(robot) = pose_topic_robot(&channel.topic) {
            match &content {
                Content::Pose(pose) => poses_on.entry(robot).or_default().push(Some(*pose)),
                Content::Undecodable { schema: bycoms_record::schema::POSE } => {
                    poses_on.entry(robot).or_default().push(None);
                }
                _ => {}
            }
        }
        let entry = match content {
            Content::Run(json) => {
                let meta = serde_json::from_slice(json).map_err(|e| ReplayError::BadRunMeta {
                    topic: channel.topic.clone(),
                    reason: e.to_string(),
                })?;
                run = Some(meta);
                return Ok(());
            }
            Content::Command { robot, command } => Entry::Command { robot, command },
            Content::Pose(pose) => Entry::Pose(pose),
            Content::Gate(event) => Entry::Gate(event),
            // A log that does not decode is left out: the replay then
            // re-judges from the poses, and says so.
            Content::CoreSetup(version, bytes) => {
                match log::Version::of(version).map(|v| log::decode_setup(v, bytes)) {
                    Some(Ok(setup)) => Entry::CoreSetup(Box::new(setup)),
                    _ => return Ok(()),
                }
            }
            Content::CoreCalls(version, bytes) => {
                match log::Version::of(version).map(|v| log::decode_calls(v, bytes)) {
                    Some(Ok(calls)) => Entry::CoreCalls(calls),
                    _ => return Ok(()),
                }
            }
            Content::MocapFrame(bytes) => Entry::MocapFrame(bytes.to_vec()),
            Content::MocapModelDef(bytes) => Entry::MocapModelDef(bytes.to_vec()),
            // Bytes that do not decode are skipped, as the launch skipped
            // them; reports, the poses the core applied, its beacons and
            // states (its outputs, made again by the replay), decoded
            // channels and the rest are not replayed.
            Content::Report(_)
            | Content::Moved(_)
            | Content::Beacon { .. }
            | Content::State { .. }
            | Content::Operator(_)
            | Content::Undecodable { .. }
            | Content::Other => return Ok(()),
        };
        entries.push(entry);
        Ok(())
    })?;
    end.launch_recording(path)?;
    let run = run.ok_or_else(|| bycoms_record::RecordError::NotLaunch {
        path: path.to_path_buf(),
        reason: "its run metadata does not parse".into(),
    })?;
    Ok(Recorded { run, entries, poses_on, stopped_by: end.stopped_by, partial: end.partial })
}

/// Robot k of a pose topic (`bycoms/<swarm>/robot/<k>/pose`).
fn pose_topic_robot(topic: &str) -> Option<u32> {
    let robot = bycoms_record::schema::robot_of_topic(topic)?;
    topic.ends_with(&format!("/robot/{}/pose", robot.0)).then_some(robot.0)
}
