//! A run as a rosbag2 MCAP file (`orchestrator record export --ros2`): the
//! messages of [`super::publish::RunMessages`], the same the live graph
//! gets, into [`BagSink`].
//!
//! The format is rosbag2's MCAP storage (`rosbag2_storage_mcap`,
//! `mcap_storage.cpp` and `message_definition_cache.cpp`), which `ros2 bag
//! play` and PyPI `rosbags` read: profile `ros2`; messages `cdr`; one
//! schema per type, encoding `ros2msg`, holding the type's `.msg` text and
//! each type it refers to after a line of 80 `=` and `MSG: pkg/Type`; each
//! channel's metadata `offered_qos_profiles` (the YAML list rosbag2 writes
//! since Jazzy) and `topic_type_hash` (RIHS01); and one metadata record
//! `rosbag2` with `serialized_metadata` (the bag's `metadata.yaml`) and
//! `ROS_DISTRO`. Log and publish times are the run's time (ns since it
//! started), as `/clock` says it.
//!
//! Why a sink and not a converter of its own: the bag must hold exactly
//! what a live ROS 2 node would have received.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::{Seek, Write};
use std::path::Path;

use mcap::records::{MessageHeader, Metadata};
use mcap::{McapError, WriteOptions, Writer};

use super::publish::{RunMessages, Sink, Topic};
use super::Ros2Config;
use bycoms_record::decode::{decode_message, Content};
use bycoms_record::{Item, Reader, RecordError};
use bycoms_ros2::rmw_zenoh::{policy, Qos};
use bycoms_study::draw::run::RunMeta;

/// The ROS 2 distribution the bag's types are (their field lists are Jazzy's and Kilted's).
pub const ROS_DISTRO: &str = "jazzy";

/// Writes a run's ROS 2 messages into a rosbag2 MCAP file.
pub struct BagSink<W: Write + Seek> {
    writer: Writer<W>,
    topics: Vec<Topic>,
    channels: Vec<u16>,
    counts: Vec<u64>,
    times: Option<(u64, u64)>,
    sequence: u32,
    error: Option<McapError>,
}

impl<W: Write + Seek> BagSink<W> {
    /// A bag on `out` with one channel (and its type's schema) per topic.
    pub fn new(out: W, topics: &[Topic]) -> Result<Self, McapError> {
        let options = WriteOptions::new()
            .profile("ros2")
            .library(bycoms_record::library())
            .compression(Some(mcap::Compression::Zstd))
            .compression_threads(0);
        let mut writer = Writer::with_options(out, options)?;
        let mut schemas: BTreeMap<&str, u16> = BTreeMap::new();
        let mut channels = Vec::with_capacity(topics.len());
        for t in topics {
            let d = t.description;
            let schema = match schemas.get(d.name) {
                Some(&id) => id,
                None => {
                    let id = writer.add_schema(d.name, "ros2msg", d.ros2msg().as_bytes())?;
                    *schemas.entry(d.name).or_insert(id)
                }
            };
            let metadata = BTreeMap::from([
                ("offered_qos_profiles".to_string(), qos_yaml(&t.qos, "")),
                ("topic_type_hash".to_string(), d.rihs01()),
            ]);
            channels.push(writer.add_channel(schema, &t.name, "cdr", &metadata)?);
        }
        let counts = vec![0; topics.len()];
        Ok(Self { writer, topics: topics.to_vec(), channels, counts, times: None, sequence: 0, error: None })
    }

    /// Messages written per topic, in [`RunMessages::topics`] order.
    pub fn counts(&self) -> &[u64] {
        &self.counts
    }

    /// Writes the `rosbag2` metadata record, the summary and the footer;
    /// the first error of any message written is returned here.
    pub fn finish(mut self, file_name: &str) -> Result<W, McapError> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        let metadata = BTreeMap::from([
            ("serialized_metadata".to_string(), self.serialized_metadata(file_name)),
            ("ROS_DISTRO".to_string(), ROS_DISTRO.to_string()),
        ]);
        self.writer.write_metadata(&Metadata { name: "rosbag2".into(), metadata })?;
        self.writer.finish()?;
        Ok(self.writer.into_inner())
    }

    /// The bag's `metadata.yaml` as rosbag2 (version 9) writes it.
    fn serialized_metadata(&self, file_name: &str) -> String {
        let (start, end) = self.times.unwrap_or((0, 0));
        let total: u64 = self.counts.iter().sum();
        let mut y = String::from("rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n");
        let _ = write!(
            y,
            "  duration:\n    nanoseconds: {}\n  starting_time:\n    nanoseconds_since_epoch: {start}\n  \
             message_count: {total}\n  topics_with_message_count:\n",
            end - start
        );
        for (t, count) in self.topics.iter().zip(&self.counts) {
            let _ = write!(
                y,
                "    - topic_metadata:\n        name: {}\n        type: {}\n        serialization_format: cdr\n        \
                 offered_qos_profiles:\n{}\n        type_description_hash: {}\n      message_count: {count}\n",
                t.name,
                t.description.name,
                qos_yaml(&t.qos, "          "),
                t.description.rihs01()
            );
        }
        let _ = write!(
            y,
            "  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n    - {file_name}\n  \
             files:\n    - path: {file_name}\n      starting_time:\n        nanoseconds_since_epoch: {start}\n      \
             duration:\n        nanoseconds: {}\n      message_count: {total}\n  custom_data: ~\n  ros_distro: {ROS_DISTRO}\n",
            end - start
        );
        y
    }
}

impl<W: Write + Seek> Sink for BagSink<W> {
    fn send(&mut self, topic: usize, time_ns: u64, cdr: &[u8]) {
        if self.error.is_some() {
            return;
        }
        self.sequence = self.sequence.wrapping_add(1);
        let header = MessageHeader {
            channel_id: self.channels[topic],
            sequence: self.sequence,
            log_time: time_ns,
            publish_time: time_ns,
        };
        match self.writer.write_to_known_channel(&header, cdr) {
            Ok(()) => {
                self.counts[topic] += 1;
                self.times =
                    Some(self.times.map_or((time_ns, time_ns), |(a, b)| (a.min(time_ns), b.max(time_ns))));
            }
            Err(e) => self.error = Some(e),
        }
    }
}

/// A QoS as the one-element YAML list rosbag2 (Jazzy, metadata version 9)
/// writes in `offered_qos_profiles`, each line after the first indented by `indent`.
pub fn qos_yaml(q: &Qos, indent: &str) -> String {
    let name = |v: u32, names: [&'static str; 2]| if v == 1 { names[0] } else { names[1] };
    let duration = |(sec, nsec): (u64, u64)| format!("\n{indent}    sec: {sec}\n{indent}    nsec: {nsec}");
    format!(
        "{indent}- history: {}\n{indent}  depth: {}\n{indent}  reliability: {}\n{indent}  durability: {}\n\
         {indent}  deadline:{}\n{indent}  lifespan:{}\n{indent}  liveliness: {}\n\
         {indent}  liveliness_lease_duration:{}\n{indent}  avoid_ros_namespace_conventions: false",
        name(q.history, ["keep_last", "keep_all"]),
        q.depth,
        name(q.reliability, ["reliable", "best_effort"]),
        name(q.durability, ["transient_local", "volatile"]),
        duration(q.deadline),
        duration(q.lifespan),
        if q.liveliness == policy::AUTOMATIC { "automatic" } else { "manual_by_topic" },
        duration(q.liveliness_lease),
    )
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Exported {
    /// Messages per topic name.
    pub counts: BTreeMap<String, u64>,
    /// Poses exported: those the launch core applied (an older recording:
    /// every pose on the bus).
    pub poses: u64,
}

/// Why a recording could not be exported.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// Reading the recording failed (not MCAP, damaged, not a launch's).
    #[error(transparent)]
    Record(#[from] RecordError),
    /// Its run metadata does not say the terrain or the number of robots.
    #[error("{path}: the run metadata {why}", path = .0.display(), why = .1)]
    Meta(std::path::PathBuf, String),
    /// Writing the bag failed.
    #[error("cannot write the ROS 2 bag: {0}")]
    Write(#[from] McapError),
}

/// The run of `meta` as a publisher: its ROS 2 settings (the recorded
/// `[ros2]`, else the defaults), robots, terrain and its ROS 2 robots'
/// `cmd_vel` topics (the recorded `ros2_robots`).
fn run_of(meta: &RunMeta) -> Result<(RunMessages, bycoms_sim::terrain::Terrain, f64), String> {
    let cfg: Ros2Config = serde_json::from_value(meta.config["ros2"].clone()).unwrap_or_default();
    let robots =
        meta.config["robots"].as_u64().and_then(|r| u32::try_from(r).ok()).ok_or("has no robot count")?;
    let text = meta.terrain_text.as_deref().ok_or("has no terrain (a recording older than terrain_text)")?;
    let mut terrain =
        bycoms_sim::terrain::parse(text).map_err(|e| format!("has a terrain that does not parse: {e}"))?;
    terrain.set_start(meta.start);
    terrain.set_goal(meta.goal);
    let mut run = RunMessages::new(&cfg, robots).with_cmd_vel(&meta.ros2_robots);
    if !meta.beacons_told {
        run = run.without_beacons_told();
    }
    if !meta.states_told {
        run = run.without_states_told();
    }
    run.set_real(meta.real.clone());
    Ok((run, terrain, meta.eps().unwrap_or(0.0)))
}

/// Streams the recording at `input` through the run's ROS 2 messages into
/// a bag on `out` (named `file_name` in its metadata).
pub fn export<W: Write + Seek>(input: &Path, out: W, file_name: &str) -> Result<(Exported, W), ExportError> {
    let mut state: Option<(RunMessages, BagSink<W>)> = None;
    let mut meta: Option<RunMeta> = None;
    let mut out = Some(out);
    let mut poses = 0;
    let meta_error = |why: String| ExportError::Meta(input.to_path_buf(), why);
    let end = Reader::open(input)?.stream(|item| {
        let Item::Message { channel, data, .. } = item else { return Ok::<_, ExportError>(()) };
        let content = decode_message(channel, data);
        // The poses the core applied, as the live graph got them (older
        // recordings: every pose on the bus).
        if let (Some(pose), Some((run, sink))) = (RunMeta::shown_pose(meta.as_ref(), &content), &mut state) {
            poses += 1;
            run.pose(&pose, sink);
        }
        match (content, &mut state) {
            (Content::Run(json), None) => {
                let read: RunMeta = serde_json::from_slice(json).map_err(|e| meta_error(e.to_string()))?;
                let (mut run, terrain, eps) = run_of(&read).map_err(meta_error)?;
                let mut sink = BagSink::new(out.take().expect("one sink"), run.topics())?;
                run.world(&terrain, eps, &mut sink);
                state = Some((run, sink));
                meta = Some(read);
            }
            (Content::Gate(event), Some((run, sink))) => run.gate(&event, sink),
            (Content::Beacon { robot, x, y }, Some((run, sink))) => {
                run.beacon(robot, bycoms_sim::Vec2::new(x, y), sink);
            }
            (Content::State { robot, state }, Some((run, sink))) => run.state(robot, state, sink),
            (Content::Report(report), Some((run, sink))) => run.report(&report, sink),
            _ => {}
        }
        Ok(())
    })?;
    end.launch_recording(input)?;
    let (run, sink) = state.ok_or_else(|| meta_error("is missing".into()))?;
    let counts = run.topics().iter().zip(sink.counts()).map(|(t, &n)| (t.name.clone(), n)).collect();
    let w = sink.finish(file_name)?;
    Ok((Exported { counts, poses }, w))
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::msg::Pose;
    use bycoms_protocol::RobotId;
    use bycoms_record::schema;
    use bycoms_ros2::bycoms_msgs::robot_state;

    /// A bag of a few poses, read back with the `mcap` crate: what rosbag2's
    /// reader looks for is there (the Python readers check it in
    /// `tests/tests/ros2_launch.rs`).
    #[test]
    fn a_bag_is_a_ros2_profile_mcap_with_schemas_qos_hashes_and_rosbag2_metadata() {
        let mut run = RunMessages::new(&Ros2Config::default(), 2);
        let mut sink = BagSink::new(std::io::Cursor::new(Vec::new()), run.topics()).expect("bag");
        run.world(&bycoms_sim::terrain::Terrain::new(5, 4), 1.5, &mut sink);
        for step in 0..20u64 {
            let pose = Pose {
                robot: RobotId(1),
                x: step as f64 * 0.2,
                y: 1.0,
                heading: 0.0,
                step,
                time_us: step * 100_000,
            };
            run.pose(&pose, &mut sink);
        }
        let pose_topic =
            run.topics().iter().position(|t| t.name == "/robot_1/pose").expect("robot 1's pose topic");
        assert_eq!(sink.counts()[pose_topic], 20, "robot 1's poses");
        let bytes = sink.finish("bag.mcap").expect("finished").into_inner();
        let summary = mcap::Summary::read(&bytes).expect("readable").expect("a summary");
        assert_eq!(summary.channels.len(), run.topics().len());
        for channel in summary.channels.values() {
            let topic = run.topics().iter().find(|t| t.name == channel.topic).expect("one of ours");
            let schema = channel.schema.as_ref().expect("a schema");
            assert_eq!((schema.name.as_str(), schema.encoding.as_str()), (topic.description.name, "ros2msg"));
            assert_eq!(std::str::from_utf8(&schema.data), Ok(topic.description.ros2msg().as_str()));
            assert_eq!(channel.message_encoding, "cdr");
            assert_eq!(channel.metadata["topic_type_hash"], topic.description.rihs01());
            assert_eq!(channel.metadata["offered_qos_profiles"], qos_yaml(&topic.qos, ""));
        }
        let stats = summary.stats.expect("statistics");
        assert_eq!(
            stats.message_count,
            (1 + 1 + 2) + 20 * 3 + 2,
            "map, static frames, 2 states, 20 × (clock, pose, tf), 2 paths"
        );
        let mut stream = mcap::read::LinearReader::new(&bytes).expect("reader");
        let header = stream.find_map(|r| match r {
            Ok(mcap::records::Record::Header(h)) => Some(h),
            _ => None,
        });
        assert_eq!(header.map(|h| h.profile), Some("ros2".into()));
        let metadata: Vec<_> = mcap::read::LinearReader::new(&bytes)
            .expect("reader")
            .filter_map(|r| match r {
                Ok(mcap::records::Record::Metadata(m)) => Some(m),
                _ => None,
            })
            .collect();
        assert_eq!(metadata.len(), 1);
        assert_eq!(metadata[0].name, "rosbag2");
        assert_eq!(metadata[0].metadata["ROS_DISTRO"], ROS_DISTRO);
        let yaml = &metadata[0].metadata["serialized_metadata"];
        assert!(
            yaml.starts_with("rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n"),
            "{yaml}"
        );
        assert!(yaml.contains("message_count: 66\n"), "{yaml}");
    }

    /// A small launch recording at `path`: its run metadata (`extra`
    /// fields added), then `messages` (topic leaf, schema, encoding, bytes).
    fn recording(path: &Path, extra: serde_json::Value, messages: &[(&str, &str, &str, Vec<u8>)]) {
        let file = std::io::BufWriter::new(std::fs::File::create(path).expect("create"));
        let mut w = Writer::new(file).expect("writer");
        let mut meta = serde_json::json!({
            "terrain": "t", "terrain_text": "S...G\n", "start": {"x": 0.5, "y": 0.5},
            "goal": {"x": 4.5, "y": 0.5}, "config": {"robots": 2, "eps": 1.0},
        });
        meta.as_object_mut().expect("an object").extend(extra.as_object().cloned().unwrap_or_default());
        let run = ("run", schema::RUN, schema::JSON, serde_json::to_vec(&meta).expect("JSON"));
        for (i, (leaf, name, encoding, bytes)) in std::iter::once(&run).chain(messages).enumerate() {
            let schema = w.add_schema(name, "", &[]).expect("schema");
            let channel = w
                .add_channel(schema, &format!("bycoms/s/{leaf}"), encoding, &BTreeMap::new())
                .expect("channel");
            let header =
                MessageHeader { channel_id: channel, sequence: 0, log_time: i as u64, publish_time: 0 };
            w.write_to_known_channel(&header, bytes).expect("message");
        }
        w.finish().expect("finish");
    }

    /// Robot `robot`'s `RobotState.state`s in a bag, in order.
    fn states_in(bag: &[u8], robot: u32) -> Vec<u8> {
        let topic = format!("/robot_{robot}/state");
        mcap::MessageStream::new(bag)
            .expect("a bag")
            .map(|m| m.expect("a message"))
            .filter(|m| m.channel.topic == topic)
            .map(|m| super::super::messages::robot_state_in(&m.data))
            .collect()
    }

    /// `record export --ros2` shows the core's states from `core/state`
    /// (robot 2 revoked before its deployment: lost, without a gate
    /// decision), and a recording older than it as it always did: the
    /// states its gate decisions imply (robot 2 stays waiting).
    #[test]
    fn a_bag_has_the_cores_states_and_an_older_recordings_states_from_the_gate() {
        use bycoms_launch_core::view::SlotState;
        use bycoms_protocol::msg::{GateEvent, GateKind};
        let mut buf = [0u8; bycoms_protocol::MAX_MESSAGE_LEN];
        let mut gate = |kind| {
            let event = GateEvent { robot: RobotId(1), kind, x: 1.0, y: 0.5, step: 3 };
            (
                "gate",
                schema::GATE,
                schema::POSTCARD,
                bycoms_protocol::encode(&event, &mut buf).expect("encodes").to_vec(),
            )
        };
        let gates = [gate(GateKind::Deployed), gate(GateKind::Stopped { arrived: false })];
        let state = |robot, state| {
            let json =
                serde_json::to_vec(&bycoms_record::scene::json::RobotSlot { robot, state }).expect("JSON");
            ("core/state", schema::CORE_STATE, schema::JSON, json)
        };
        let told = [
            state(1, SlotState::Moving),
            gates[0].clone(),
            state(2, SlotState::Lost),
            state(1, SlotState::Stuck),
            gates[1].clone(),
        ];
        let dir = std::env::temp_dir().join(format!("bycoms-bag-states-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let export_of = |name: &str, extra, messages: &[_]| {
            let path = dir.join(name);
            recording(&path, extra, messages);
            let (_, out) = export(&path, std::io::Cursor::new(Vec::new()), "bag.mcap").expect("exports");
            out.into_inner()
        };
        let bag = export_of("told.mcap", serde_json::json!({ "states_told": true }), &told);
        assert_eq!(states_in(&bag, 1), [robot_state::WAITING, robot_state::MOVING, robot_state::BEACON]);
        assert_eq!(states_in(&bag, 2), [robot_state::WAITING, robot_state::LOST]);
        let old = export_of("old.mcap", serde_json::json!({}), &gates);
        assert_eq!(states_in(&old, 1), [robot_state::WAITING, robot_state::MOVING, robot_state::BEACON]);
        assert_eq!(states_in(&old, 2), [robot_state::WAITING]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn qos_is_the_yaml_list_rosbag2_writes() {
        let yaml = qos_yaml(&Qos::transient_local(1), "");
        assert!(
            yaml.starts_with(
                "- history: keep_last\n  depth: 1\n  reliability: reliable\n  durability: transient_local\n"
            ),
            "{yaml}"
        );
        assert!(yaml.contains("  deadline:\n    sec: 9223372036\n    nsec: 854775807\n"), "{yaml}");
        assert!(yaml.ends_with("  avoid_ros_namespace_conventions: false"), "{yaml}");
        assert!(qos_yaml(&Qos::best_effort(5), "  ").contains("\n    reliability: best_effort\n"));
    }
}
