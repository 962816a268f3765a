//! The seam itself: what a pose source is ([`PoseSource`]), why one fails
//! ([`PoseError`]), and where it hands its poses ([`PoseSink`]).
//!
//! Why a file of its own: every source (`bus.rs`, `mocap.rs`, `ros2.rs`)
//! implements these, and `mod.rs` opens the sources (no file cycles).

use crate::recording::Recording;
use bycoms_protocol::bus::BusError;
use bycoms_protocol::msg::Pose;
use bycoms_protocol::{encode, CodecError, RobotId, Swarm, MAX_MESSAGE_LEN};
use bycoms_record::schema;
use bycoms_runtime::Traffic;
use std::collections::BTreeMap;

/// Why a pose source failed (fatally: the launch ends).
#[derive(Debug, thiserror::Error)]
pub enum PoseError {
    /// The bus failed.
    #[error("pose source: {0}")]
    Bus(#[from] BusError),
    /// Any other failure of a source (its own typed error, boxed).
    #[error(transparent)]
    Other(Box<dyn std::error::Error + Send + Sync>),
}

/// Where the gate's poses come from; see the module docs for the contract.
pub trait PoseSource {
    /// The kind of source (`bus`, `natnet`, `replay`), for logs.
    fn kind(&self) -> &'static str;
    /// Whether the source reads the launch's bus and records the raw bytes
    /// itself ([`PoseSink::raw`]); otherwise the sink records decoded poses.
    fn on_the_bus(&self) -> bool;
    /// Starts handing over robot `id`'s poses (before its agent starts).
    fn open_robot(&mut self, id: u32) -> Result<(), PoseError>;
    /// Hands every pose that arrived since the last call to `sink`; never
    /// waits.
    fn drain(&mut self, sink: &mut PoseSink<'_>) -> Result<(), PoseError>;
    /// Robot `id` is being carried to the start by hand (`true`), or has
    /// been placed there (`false`). While it is carried any speed is
    /// plausible: a source that rejects moves faster than a robot drives
    /// (motion capture's identity-swap check) must hand them over; once it
    /// is placed, that check starts again from where it was placed. Sources
    /// without such a check ignore it (the default).
    fn carried(&mut self, _id: u32, _by_hand: bool) {}
}

/// The encoding of each robot's last pose, made once: an off-bus pose
/// (motion capture) is encoded by the sink that records it, and the launch
/// then forwards it on the robot's pose topic (`Ports::forward_pose`) and
/// records it as applied (`Ports::show_moved`) with those same bytes
/// rather than encoding it again for each. Kept per robot (the sink hands
/// a frame's poses robot by robot, the core's outputs follow each one);
/// a pose is the one encoded only if it is bit for bit (0.0 and -0.0
/// encode apart).
#[derive(Debug, Default)]
pub struct PoseBytes {
    last: BTreeMap<u32, (Pose, Vec<u8>)>,
    /// Encodings made (the tests count them).
    made: u64,
}

impl PoseBytes {
    /// `pose`'s bytes as a message: the ones kept for its robot when it is
    /// the pose they encode, else encoded now and kept.
    pub fn of(&mut self, pose: &Pose) -> Result<&[u8], CodecError> {
        let (kept, bytes) = self.last.entry(pose.robot.0).or_insert_with(|| (*pose, Vec::new()));
        if bytes.is_empty() || !same_bits(kept, pose) {
            let mut buf = [0u8; MAX_MESSAGE_LEN];
            let encoded = encode(pose, &mut buf)?;
            *kept = *pose;
            self.made += 1;
            bytes.clear();
            bytes.extend_from_slice(encoded);
        }
        Ok(bytes)
    }
}

/// Whether two poses are the same bits (what their encodings compare).
fn same_bits(a: &Pose, b: &Pose) -> bool {
    let bits = |p: &Pose| (p.robot, p.step, p.time_us, p.x.to_bits(), p.y.to_bits(), p.heading.to_bits());
    bits(a) == bits(b)
}

/// Where a source hands its poses: the engine's intake, with the recording
/// and the bad-traffic counters of the launch.
pub struct PoseSink<'a> {
    recording: &'a mut Recording,
    traffic: &'a mut Traffic,
    swarm: &'a Swarm,
    poses: &'a mut Vec<(u32, Pose)>,
    record_decoded: bool,
    recorded: u64,
    /// For each handed pose, its number on its topic in the recording's
    /// file, if it is written there ([`Recording::message`]).
    numbers: Vec<Option<u32>>,
    /// The number of the last raw message, for the pose decoded from it.
    last_raw: Option<u32>,
    /// The decoded poses' encodings (the launch's, lent by
    /// [`Self::encoding_with`]).
    bytes: PoseBytes,
}

const WHO: &str = "launch";

impl<'a> PoseSink<'a> {
    /// A sink appending to `poses`. `record_decoded`: record each handed
    /// pose (for sources that are not on the bus; see the module docs).
    pub fn new(
        recording: &'a mut Recording,
        traffic: &'a mut Traffic,
        swarm: &'a Swarm,
        poses: &'a mut Vec<(u32, Pose)>,
        record_decoded: bool,
    ) -> Self {
        Self {
            recording,
            traffic,
            swarm,
            poses,
            record_decoded,
            recorded: 0,
            numbers: Vec::new(),
            last_raw: None,
            bytes: PoseBytes::default(),
        }
    }

    /// This sink, encoding the poses it records with `bytes` (the launch's,
    /// handed back by [`Self::take_bytes`]), so what is forwarded or shown
    /// of them afterwards is not encoded again.
    pub fn encoding_with(mut self, bytes: PoseBytes) -> Self {
        self.bytes = bytes;
        self
    }

    /// The encodings made, for the launch to reuse ([`PoseBytes`]).
    pub fn take_bytes(&mut self) -> PoseBytes {
        std::mem::take(&mut self.bytes)
    }

    /// One pose of robot `robot` as the source saw it.
    pub fn pose(&mut self, robot: u32, pose: Pose) {
        let number = match self.record_decoded {
            true => self.record(robot, pose),
            false => self.last_raw.take(),
        };
        self.poses.push((robot, pose));
        self.numbers.push(number);
    }

    /// Records a decoded pose on robot `robot`'s pose topic; its number there.
    fn record(&mut self, robot: u32, pose: Pose) -> Option<u32> {
        match self.bytes.of(&pose) {
            Ok(bytes) => {
                let topic = self.swarm.pose(RobotId(robot));
                self.recorded += 1;
                self.recording.message(topic.name().as_str(), schema::POSE, bytes)
            }
            // A pose always fits one message; should it not, it is
            // still judged, and the failure shows in the log.
            Err(e) => {
                tracing::warn!(robot, "cannot record a pose: {e}");
                None
            }
        }
    }

    /// For each pose handed so far, in order, its number on its robot's
    /// pose topic in the recording's file (none: not written there).
    pub fn numbers(&self) -> &[Option<u32>] {
        &self.numbers
    }

    /// The bytes of one message as they crossed the bus on `topic`, before
    /// decoding (bus sources only; a pose they decode to is then handed
    /// over with [`Self::pose`]).
    pub fn raw(&mut self, topic: &str, bytes: &[u8]) {
        self.last_raw = self.recording.message(topic, schema::POSE, bytes);
        self.recorded += 1;
    }

    /// Something the source could not use, from `topic`: counted (and
    /// logged, thinned) if it is bad traffic, returned if it is fatal.
    pub fn bad(&mut self, topic: &str, error: BusError) -> Result<(), PoseError> {
        match self.traffic.absorb(WHO, topic, error) {
            None => Ok(()),
            Some(fatal) => Err(fatal.into()),
        }
    }

    /// Records what a source received that is not a pose — e.g. a mocap
    /// frame's datagram, so a replay can derive the poses again — on
    /// `bycoms/<swarm>/<leaf>` with `schema`. Not counted in
    /// [`PoseSink::recorded`] (which counts poses).
    pub fn record_source_bytes(&mut self, leaf: &str, schema: &str, bytes: &[u8]) {
        let topic = schema::Topics::new(self.swarm.as_str()).leaf(leaf);
        self.recording.bytes(&topic, schema, bytes);
    }

    /// Messages recorded through this sink (raw or decoded).
    pub fn recorded(&self) -> u64 {
        self.recorded
    }

    /// Poses handed to this sink so far.
    pub fn handed(&self) -> usize {
        self.numbers.len()
    }

    /// Runs `drain` of a source on the bus through this sink, whatever the
    /// sink's own mode: its messages are recorded raw
    /// ([`PoseSink::raw`]), not decoded again (a source of motion capture
    /// and of the bus at once, `merged.rs`).
    pub fn on_the_bus<R>(&mut self, drain: impl FnOnce(&mut Self) -> R) -> R {
        let decoded = std::mem::replace(&mut self.record_decoded, false);
        let result = drain(self);
        self.record_decoded = decoded;
        result
    }

    /// Puts the poses handed since the `first`-th in robot id order, each
    /// robot's in the order handed (a stable sort; each pose keeps its
    /// number in the recording).
    pub fn in_robot_order_from(&mut self, first: usize) {
        let start = self.poses.len() - (self.numbers.len() - first);
        let mut tail: Vec<_> = self.poses.drain(start..).zip(self.numbers.drain(first..)).collect();
        tail.sort_by_key(|((robot, _), _)| *robot);
        for (pose, number) in tail {
            self.poses.push(pose);
            self.numbers.push(number);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(robot: u32, x: f64) -> Pose {
        Pose { robot: RobotId(robot), x, y: 1.0, heading: 0.5, step: 3, time_us: 30_000 }
    }

    #[test]
    fn a_pose_is_encoded_once_and_its_bytes_are_the_message_s() {
        let mut bytes = PoseBytes::default();
        let mut buf = [0u8; MAX_MESSAGE_LEN];
        let a = pose(1, 2.0);
        let expected = encode(&a, &mut buf).expect("encodes").to_vec();
        for _ in 0..3 {
            assert_eq!(bytes.of(&a).expect("encodes"), expected.as_slice());
        }
        assert_eq!(bytes.made, 1, "recorded, forwarded and shown: one encoding");
        // Another robot's pose keeps robot 1's.
        bytes.of(&pose(2, 2.0)).expect("encodes");
        assert_eq!(bytes.of(&a).expect("encodes"), expected.as_slice());
        assert_eq!(bytes.made, 2);
        // The robot's next pose, and one equal by `==` but not in bits.
        let b = pose(1, 2.5);
        assert_eq!(bytes.of(&b).expect("encodes"), encode(&b, &mut buf).expect("encodes"));
        let (zero, minus_zero) = (pose(1, 0.0), pose(1, -0.0));
        bytes.of(&zero).expect("encodes");
        assert_eq!(bytes.of(&minus_zero).expect("encodes"), encode(&minus_zero, &mut buf).expect("encodes"));
        assert_eq!(bytes.made, 5);
    }
}
