//! rmw_zenoh's names and metadata, as pure functions: the data key
//! expression of a topic, the liveliness tokens of nodes and endpoints (how
//! `ros2 node list` / `ros2 topic list` find them), the entity GID, and the
//! attachment every sample carries.
//!
//! Why sans-IO: the launch puts these on its own zenoh session, and tests
//! pin every byte without one. Nothing here was guessed; it follows
//! ros2/rmw_zenoh's sources as the newest versions in our source index hold
//! them (`rmw_zenoh_cpp/package.xml` there: 0.2.5, commit 3e3e370d4e29):
//!
//! * `rmw_zenoh_cpp/src/detail/liveliness_utils.cpp` (commit 3411fdec149f):
//!   `TopicInfo` (key expression: domain, the topic with its leading and
//!   trailing `/` stripped, the DDS type name, the type hash),
//!   `Entity::Entity` (token parts, empty parts skipped, `/` → `%` in
//!   enclave, namespace, node, topic, type and hash), `qos_to_keyexpr`
//!   (each policy written only where it differs from rmw_zenoh's default),
//!   and the GID: `simplified_XXH3_128bits(token)`, `low64` then `high64`
//!   copied in host (little-endian) order;
//! * `rmw_zenoh_cpp/src/detail/simplified_xxhash3.cpp` (commit 97aed4819677):
//!   the reference XXH3-128 with the default secret and seed 0, which
//!   `xxhash-rust`'s `xxh3_128` is;
//! * `rmw_zenoh_cpp/src/detail/qos.cpp` (commit 7efeee2b9009): the default
//!   QoS the compact form is relative to (keep last 42, reliable, volatile,
//!   infinite deadline, lifespan and lease, automatic liveliness);
//! * `rmw_zenoh_cpp/src/detail/rmw_node_data.cpp` (commit 3411fdec149f): a
//!   node's token has its node id as both node and entity id;
//! * `rmw_zenoh_cpp/src/detail/rmw_publisher_data.cpp` (commit 3e19ec730c52):
//!   sequence numbers from 1, the source timestamp from the system clock
//!   (`zenoh_utils.cpp`, commit 132254542, `get_system_time_in_ns`);
//! * `rmw_zenoh_cpp/src/detail/attachment_helpers.cpp` (commit 534747dca92a):
//!   the attachment is zenoh-ext's serialization of (`i64` sequence number,
//!   `i64` timestamp, the 16-byte GID as a sequence): 8 + 8 bytes
//!   little-endian, the LEB128 length `0x10`, the GID (33 bytes);
//! * the design document `docs/design` (commit 99a6a2bd10b9): the formats and the worked
//!   examples the tests reproduce.

use std::fmt::Write as _;

use thiserror::Error;

/// The hermetic admin space of every rmw_zenoh liveliness token.
pub const ADMIN_SPACE: &str = "@ros2_lv";

/// The length of an rmw_zenoh attachment.
pub const ATTACHMENT_LEN: usize = 33;

/// The DDS type name rmw_zenoh puts in keys and tokens:
/// `geometry_msgs/msg/PoseStamped` → `geometry_msgs::msg::dds_::PoseStamped_`.
pub fn dds_type_name(ros_type: &str) -> String {
    let (head, name) = ros_type.rsplit_once('/').unwrap_or(("", ros_type));
    let mut out = head.replace('/', "::");
    if !out.is_empty() {
        out.push_str("::");
    }
    let _ = write!(out, "dds_::{name}_");
    out
}

/// A fully qualified ROS 2 name as the launch accepts one: `/`, then
/// names of letters, digits and `_` (not starting with a digit) separated
/// by single `/`; with `allow_root`, `/` alone too (a namespace). Stricter
/// than rcl (no `~`, no substitutions): what a config names is used as is.
pub fn is_fully_qualified(name: &str, allow_root: bool) -> bool {
    name.strip_prefix('/').is_some_and(|rest| {
        (allow_root && rest.is_empty())
            || rest.split('/').all(|n| {
                n.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                    && n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            })
    })
}

/// `/` → `%`, as rmw_zenoh mangles names inside a token.
pub fn mangle(name: &str) -> String {
    name.replace('/', "%")
}

/// The name without one leading and one trailing `/` (rmw_zenoh's `strip_slashes`).
fn strip_slashes(name: &str) -> &str {
    let name = name.strip_prefix('/').unwrap_or(name);
    name.strip_suffix('/').unwrap_or(name)
}

/// The key expression a topic's samples are put on:
/// `<domain>/<topic without leading slash>/<DDS type name>/<type hash>`.
pub fn topic_key_expr(domain_id: u32, topic: &str, ros_type: &str, type_hash: &str) -> String {
    format!("{domain_id}/{}/{}/{type_hash}", strip_slashes(topic), dds_type_name(ros_type))
}

/// The key expression that subscribes to every token of a domain (the ROS 2 graph).
pub fn graph_key_expr(domain_id: u32) -> String {
    format!("{ADMIN_SPACE}/{domain_id}/**")
}

/// A QoS policy value as rmw numbers it (`rmw/types.h`).
pub mod policy {
    /// `RMW_QOS_POLICY_RELIABILITY_RELIABLE`
    pub const RELIABLE: u32 = 1;
    /// `RMW_QOS_POLICY_RELIABILITY_BEST_EFFORT`
    pub const BEST_EFFORT: u32 = 2;
    /// `RMW_QOS_POLICY_DURABILITY_TRANSIENT_LOCAL`
    pub const TRANSIENT_LOCAL: u32 = 1;
    /// `RMW_QOS_POLICY_DURABILITY_VOLATILE`
    pub const VOLATILE: u32 = 2;
    /// `RMW_QOS_POLICY_HISTORY_KEEP_LAST`
    pub const KEEP_LAST: u32 = 1;
    /// `RMW_QOS_POLICY_HISTORY_KEEP_ALL`
    pub const KEEP_ALL: u32 = 2;
    /// `RMW_QOS_POLICY_LIVELINESS_AUTOMATIC`
    pub const AUTOMATIC: u32 = 1;
}

/// `RMW_DURATION_INFINITE`: seconds and nanoseconds.
pub const DURATION_INFINITE: (u64, u64) = (9_223_372_036, 854_775_807);

/// An endpoint's QoS after rmw_zenoh's `best_available_qos` (no
/// system-default values left), as its token carries it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// [`policy::RELIABLE`] or [`policy::BEST_EFFORT`].
    pub reliability: u32,
    /// [`policy::VOLATILE`] or [`policy::TRANSIENT_LOCAL`].
    pub durability: u32,
    /// [`policy::KEEP_LAST`] or [`policy::KEEP_ALL`].
    pub history: u32,
    /// The history depth.
    pub depth: u64,
    /// Deadline (seconds, nanoseconds).
    pub deadline: (u64, u64),
    /// Lifespan (seconds, nanoseconds).
    pub lifespan: (u64, u64),
    /// [`policy::AUTOMATIC`] (the only one rmw_zenoh supports).
    pub liveliness: u32,
    /// Liveliness lease (seconds, nanoseconds).
    pub liveliness_lease: (u64, u64),
}

impl Qos {
    /// rmw_zenoh's default QoS (`qos.cpp`), which the compact form is relative to.
    pub const RMW_ZENOH_DEFAULT: Self = Self {
        reliability: policy::RELIABLE,
        durability: policy::VOLATILE,
        history: policy::KEEP_LAST,
        depth: 42,
        deadline: DURATION_INFINITE,
        lifespan: DURATION_INFINITE,
        liveliness: policy::AUTOMATIC,
        liveliness_lease: DURATION_INFINITE,
    };

    /// ROS 2's default publisher QoS (`rclcpp::QoS(depth)`): reliable,
    /// volatile, keep last `depth`.
    pub const fn reliable(depth: u64) -> Self {
        Self { depth, ..Self::RMW_ZENOH_DEFAULT }
    }

    /// ROS 2's sensor-data QoS: best effort, volatile, keep last `depth`.
    pub const fn best_effort(depth: u64) -> Self {
        Self { reliability: policy::BEST_EFFORT, depth, ..Self::RMW_ZENOH_DEFAULT }
    }

    /// Latched (`/tf_static`, maps): reliable, transient local, keep last `depth`.
    pub const fn transient_local(depth: u64) -> Self {
        Self { durability: policy::TRANSIENT_LOCAL, depth, ..Self::RMW_ZENOH_DEFAULT }
    }

    /// The compact form in a token (`qos_to_keyexpr`):
    /// `rel:dur:hist,depth:dl_s,dl_ns:ls_s,ls_ns:live,lease_s,lease_ns`,
    /// each value written only where it differs from [`Qos::RMW_ZENOH_DEFAULT`].
    pub fn key_expr(&self) -> String {
        let d = Self::RMW_ZENOH_DEFAULT;
        let v = |x: u64, default: u64| if x == default { String::new() } else { x.to_string() };
        let p = |x: u32, default: u32| v(u64::from(x), u64::from(default));
        format!(
            "{}:{}:{},{}:{},{}:{},{}:{},{},{}",
            p(self.reliability, d.reliability),
            p(self.durability, d.durability),
            p(self.history, d.history),
            v(self.depth, d.depth),
            v(self.deadline.0, d.deadline.0),
            v(self.deadline.1, d.deadline.1),
            v(self.lifespan.0, d.lifespan.0),
            v(self.lifespan.1, d.lifespan.1),
            p(self.liveliness, d.liveliness),
            v(self.liveliness_lease.0, d.liveliness_lease.0),
            v(self.liveliness_lease.1, d.liveliness_lease.1),
        )
    }
}

/// What a token announces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EntityKind {
    /// `NN`
    Node,
    /// `MP`
    Publisher,
    /// `MS`
    Subscription,
    /// `SS`
    Service,
    /// `SC`
    Client,
}

impl EntityKind {
    /// The token's two letters.
    pub const fn code(self) -> &'static str {
        match self {
            Self::Node => "NN",
            Self::Publisher => "MP",
            Self::Subscription => "MS",
            Self::Service => "SS",
            Self::Client => "SC",
        }
    }
}

/// A ROS 2 node as its token names it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Node {
    /// `ROS_DOMAIN_ID`.
    pub domain_id: u32,
    /// The zenoh session id, as zenoh prints it (lowercase hex).
    pub zid: String,
    /// The node's id within its session (its context).
    pub id: u64,
    /// The SROS enclave, `/` when none.
    pub enclave: String,
    /// The namespace, `/` for the root one.
    pub namespace: String,
    /// The node's name.
    pub name: String,
}

/// A topic (or service) endpoint's part of a token.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Endpoint {
    /// Its id within the node.
    pub id: u64,
    /// [`EntityKind::Publisher`] and so on (not a node).
    pub kind: EntityKind,
    /// The fully qualified topic or service name (`/robot_1/pose`).
    pub topic: String,
    /// The ROS type (`geometry_msgs/msg/PoseStamped`).
    pub ros_type: String,
    /// Its `RIHS01_…` hash.
    pub type_hash: String,
    /// Its QoS.
    pub qos: Qos,
}

/// Why a token could not be made (rmw_zenoh's `Entity::make` refuses the same).
#[derive(Debug, Error, PartialEq, Eq)]
pub enum TokenError {
    /// A part that must not be empty is.
    #[error("the {0} of a liveliness token must not be empty")]
    Empty(&'static str),
    /// An endpoint given the node kind.
    #[error("an endpoint's token cannot be of kind NN")]
    NodeKind,
}

/// The liveliness token of `node` (when `endpoint` is `None`) or of one of
/// its endpoints.
pub fn liveliness_token(node: &Node, endpoint: Option<&Endpoint>) -> Result<String, TokenError> {
    let named = [
        ("zid", &node.zid),
        ("enclave", &node.enclave),
        ("namespace", &node.namespace),
        ("node name", &node.name),
    ];
    for (what, part) in named {
        if part.is_empty() {
            return Err(TokenError::Empty(what));
        }
    }
    let (eid, kind) = match endpoint {
        None => (node.id, EntityKind::Node),
        Some(e) if e.kind == EntityKind::Node => return Err(TokenError::NodeKind),
        Some(e) => (e.id, e.kind),
    };
    let mut parts = vec![
        ADMIN_SPACE.to_string(),
        node.domain_id.to_string(),
        node.zid.clone(),
        node.id.to_string(),
        eid.to_string(),
        kind.code().to_string(),
        mangle(&node.enclave),
        mangle(&node.namespace),
        mangle(&node.name),
    ];
    if let Some(e) = endpoint {
        for (what, part) in [("topic", &e.topic), ("type", &e.ros_type), ("type hash", &e.type_hash)] {
            if part.is_empty() {
                return Err(TokenError::Empty(what));
            }
        }
        parts.extend([mangle(&e.topic), mangle(&dds_type_name(&e.ros_type)), mangle(&e.type_hash)]);
        parts.push(e.qos.key_expr());
    }
    Ok(parts.join("/"))
}

/// What a liveliness token of the ROS 2 graph says, read back (what
/// rmw_zenoh's graph cache reads: `ros2 topic info` lists these).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TokenView {
    /// `ROS_DOMAIN_ID`.
    pub domain_id: u32,
    /// The zenoh session id of its owner.
    pub zid: String,
    /// Node, publisher, subscription, service or client.
    pub kind: EntityKind,
    /// The node's name (unmangled).
    pub node: String,
    /// The topic or service (unmangled); empty for a node.
    pub topic: String,
    /// The DDS type name (`geometry_msgs::msg::dds_::PoseStamped_`); empty for a node.
    pub dds_type: String,
    /// The `RIHS01_…` type hash; empty for a node.
    pub type_hash: String,
}

impl TokenView {
    /// Reads a token made as [`liveliness_token`] makes them (rmw_zenoh's
    /// `Entity::make`); `None` if it is not one.
    pub fn parse(token: &str) -> Option<Self> {
        let parts: Vec<&str> = token.split('/').collect();
        if parts.first() != Some(&ADMIN_SPACE) || parts.len() < 9 {
            return None;
        }
        let kind = [
            EntityKind::Node,
            EntityKind::Publisher,
            EntityKind::Subscription,
            EntityKind::Service,
            EntityKind::Client,
        ]
        .into_iter()
        .find(|k| k.code() == parts[5])?;
        let unmangle = |s: &str| s.replace('%', "/");
        let endpoint = (kind != EntityKind::Node).then(|| parts.get(9..12)).flatten();
        let (topic, dds_type, type_hash) = match endpoint {
            Some([topic, dds_type, hash]) => (unmangle(topic), (*dds_type).to_string(), (*hash).to_string()),
            Some(_) => return None,
            None if kind == EntityKind::Node => Default::default(),
            None => return None,
        };
        Some(Self {
            domain_id: parts[1].parse().ok()?,
            zid: parts[2].to_string(),
            kind,
            node: unmangle(parts[8]),
            topic,
            dds_type,
            type_hash,
        })
    }
}

/// The entity's GID: XXH3-128 of its token, low 64 bits then high 64 bits,
/// each little-endian (the 128-bit value little-endian).
pub fn gid(token: &str) -> [u8; 16] {
    xxhash_rust::xxh3::xxh3_128(token.as_bytes()).to_le_bytes()
}

/// The metadata rmw_zenoh attaches to every sample (and request and reply).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Attachment {
    /// The publisher's sequence number, from 1.
    pub sequence_number: i64,
    /// When it was published, nanoseconds since the UNIX epoch.
    pub source_timestamp_ns: i64,
    /// The publisher's GID.
    pub gid: [u8; 16],
}

/// Why bytes are not an rmw_zenoh attachment.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum AttachmentError {
    /// Not 33 bytes.
    #[error("an rmw_zenoh attachment is 33 bytes, not {0}")]
    Length(usize),
    /// The GID's length byte is not 16.
    #[error("the GID's length is {0}, not 16")]
    GidLength(u8),
}

impl Attachment {
    /// Its 33 bytes.
    pub fn encode(&self) -> [u8; ATTACHMENT_LEN] {
        let mut out = [0u8; ATTACHMENT_LEN];
        out[..8].copy_from_slice(&self.sequence_number.to_le_bytes());
        out[8..16].copy_from_slice(&self.source_timestamp_ns.to_le_bytes());
        out[16] = 16;
        out[17..].copy_from_slice(&self.gid);
        out
    }

    /// Reads one from a sample's attachment.
    pub fn decode(bytes: &[u8]) -> Result<Self, AttachmentError> {
        let bytes: &[u8; ATTACHMENT_LEN] =
            bytes.try_into().map_err(|_| AttachmentError::Length(bytes.len()))?;
        if bytes[16] != 16 {
            return Err(AttachmentError::GidLength(bytes[16]));
        }
        let (seq, rest) = bytes.split_first_chunk::<8>().expect("33 bytes");
        let (ts, rest) = rest.split_first_chunk::<8>().expect("25 bytes");
        Ok(Self {
            sequence_number: i64::from_le_bytes(*seq),
            source_timestamp_ns: i64::from_le_bytes(*ts),
            gid: rest[1..].try_into().expect("16 bytes"),
        })
    }
}

/// One publisher's wire identity and counter, sans-IO: the key expression
/// to put on, the token to declare, and the attachment of each next sample.
#[derive(Debug, Clone)]
pub struct Publisher {
    /// Where samples go.
    pub key_expr: String,
    /// Its liveliness token.
    pub token: String,
    /// Its GID.
    pub gid: [u8; 16],
    next: i64,
}

impl Publisher {
    /// The publisher `endpoint` of `node`.
    pub fn new(node: &Node, endpoint: &Endpoint) -> Result<Self, TokenError> {
        let token = liveliness_token(node, Some(endpoint))?;
        Ok(Self {
            key_expr: topic_key_expr(
                node.domain_id,
                &endpoint.topic,
                &endpoint.ros_type,
                &endpoint.type_hash,
            ),
            gid: gid(&token),
            token,
            next: 1,
        })
    }

    /// The next sample's attachment, stamped `now_ns` (nanoseconds since the
    /// UNIX epoch, the clock rmw_zenoh stamps with).
    pub fn next_attachment(&mut self, now_ns: i64) -> Attachment {
        let sequence_number = self.next;
        self.next += 1;
        Attachment { sequence_number, source_timestamp_ns: now_ns, gid: self.gid }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_endpoint_token_says_its_kind_and_topic() {
        let sub = "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/10/MS/%/%/listener/%robot_1%pose/\
                   geometry_msgs::msg::dds_::PoseStamped_/RIHS01_10f3/::,10:,:,:,,";
        let view = TokenView::parse(sub).expect("a subscription's token");
        assert_eq!((view.kind, view.topic.as_str()), (EntityKind::Subscription, "/robot_1/pose"));
        let node = TokenView::parse("@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener");
        assert_eq!(node.map(|v| (v.kind, v.topic)), Some((EntityKind::Node, String::new())));
        assert_eq!(TokenView::parse(&sub.replace("@ros2_lv", "@other")), None);
    }
}
