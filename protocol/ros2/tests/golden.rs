//! The ROS 2 wire format against implementations that are not ours.
//!
//! The expected values come from `tests/python/ros2_golden.py` (at the
//! repository's root): PyPI `rosbags` 0.11.9 (its Jazzy type store's
//! `hash_rihs01` and `serialize_cdr`), PyPI `xxhash` 4.1.0 (XXH3-128) and
//! eclipse-zenoh 1.10.2's `zenoh.ext.z_serialize` (the attachment), for the
//! fixed inputs of [`fixed`], which that script builds the same way. They are
//! pinned here so `cargo test` checks them with no Python; the `#[ignore]`d
//! test runs the script and compares live, which `.ci/run` does (it installs
//! the three packages), so a pin that drifts from its source fails CI.
//!
//! Key expressions and tokens are pinned against rmw_zenoh's own worked
//! examples (its design document `docs/design`, commit 99a6a2bd10b9): its repository has no
//! unit test of these formats (`rmw_zenoh_cpp/test/` tests sessions and
//! nodes end to end with a ROS 2 install).

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::Command;

use bycoms_ros2::bycoms_msgs::{gate_kind, robot_state, GateEvent, RobotState};
use bycoms_ros2::display::*;
use bycoms_ros2::msgs::*;
use bycoms_ros2::rmw_zenoh::{
    gid, liveliness_token, topic_key_expr, Attachment, Endpoint, EntityKind, Node, Publisher, Qos,
};
use bycoms_ros2::types::{Field, Primitive, TypeDescription};

fn stamp() -> Time {
    Time { sec: 1_700_000_000, nanosec: 123_456_789 }
}

fn header(frame: &str) -> Header {
    Header { stamp: stamp(), frame_id: frame.into() }
}

fn pose(x: f64, y: f64) -> Pose {
    Pose {
        position: Point { x, y, z: 0.0 },
        orientation: Quaternion { x: 0.0, y: 0.0, z: 0.3826834323650898, w: 0.9238795325112867 },
    }
}

fn pose_stamped(x: f64, y: f64) -> PoseStamped {
    PoseStamped { header: header("world"), pose: pose(x, y) }
}

fn transform(child: &str, x: f64, y: f64) -> TransformStamped {
    TransformStamped {
        header: header("world"),
        child_frame_id: child.into(),
        transform: Transform {
            translation: Vector3(Point { x, y, z: 0.25 }),
            rotation: Quaternion { x: 0.0, y: 0.0, z: -0.5, w: 0.8660254037844386 },
        },
    }
}

fn entry<M: RosMessage>(m: &M) -> (&'static TypeDescription, Vec<u8>) {
    (M::DESCRIPTION, m.to_cdr())
}

/// The same inputs as `MESSAGES` in `tests/python/ros2_golden.py`: each
/// message kind's description and its CDR.
fn fixed() -> Vec<(&'static TypeDescription, Vec<u8>)> {
    vec![
        entry(&stamp()),
        entry(&StdString { data: "hello".into() }),
        entry(&header("robot_7")),
        entry(&Point { x: 1.5, y: -2.25, z: 1e-3 }),
        entry(&Quaternion::default()),
        entry(&Vector3(Point { x: -1.0, y: 2.0, z: 3.5 })),
        entry(&pose(1.5, -2.25)),
        entry(&pose_stamped(1.5, -2.25)),
        entry(&transform("robot1", 1.0, 2.0).transform),
        entry(&transform("robot1", 1.0, 2.0)),
        entry(&TfMessage {
            transforms: vec![transform("robot1", 1.0, 2.0), transform("robot12", -3.0, 0.5)],
        }),
        entry(&Path {
            header: header("world"),
            poses: vec![pose_stamped(0.0, 0.0), pose_stamped(1.5, -2.25)],
        }),
        entry(&Clock { clock: Time { sec: 12, nanosec: 500_000_000 } }),
        entry(&twist()),
        entry(&TwistStamped { header: header("base_link"), twist: Twist::planar(-0.25, 1.5) }),
        entry(&TriggerRequest),
        entry(&TriggerResponse { success: true, message: "stopped".into() }),
        entry(&ColorRgba { r: 1.0, g: 0.5, b: 0.25, a: 0.75 }),
        entry(&marker()),
        entry(&MarkerArray { markers: vec![marker(), Marker { id: 2, text: "b".into(), ..marker() }] }),
        entry(&OccupancyGrid {
            header: header("world"),
            map_load_time: Time { sec: 5, nanosec: 6 },
            resolution: 0.5,
            width: 3,
            height: 2,
            origin: pose(-1.0, 2.0),
            data: vec![0, 100, -1, 0, 0, 100],
        }),
        entry(&diagnostic_status()),
        entry(&GateEvent {
            stamp: Time { sec: 12, nanosec: 300_000_000 },
            robot: 3,
            kind: gate_kind::STOPPED,
            arrived: true,
            x: 44.5,
            y: -1.25,
            step: 123,
        }),
        entry(&RobotState {
            header: header("world"),
            robot: 2,
            state: robot_state::BEACON,
            x: 30.0,
            y: 31.5,
            heading: -0.5,
            step: 7,
            real: true,
        }),
        entry(&DiagnosticArray {
            header: header(""),
            status: vec![diagnostic_status(), DiagnosticStatus { level: level::STALE, ..Default::default() }],
        }),
    ]
}

/// Every component set and distinct, so a swapped field shows.
fn twist() -> Twist {
    Twist {
        linear: Vector3(Point { x: 0.5, y: -0.125, z: 2.0 }),
        angular: Vector3(Point { x: -1.0, y: 0.75, z: 3.25 }),
    }
}

fn marker() -> Marker {
    Marker {
        header: header("world"),
        ns: "beacons".into(),
        id: 7,
        kind: marker_type::LINE_STRIP,
        action: marker_action::ADD,
        pose: pose(3.0, 4.0),
        scale: Vector3(Point { x: 0.1, y: 0.2, z: 0.3 }),
        color: ColorRgba { r: 1.0, g: 0.5, b: 0.25, a: 0.75 },
        points: vec![Point { x: 1.0, y: 2.0, z: 0.0 }, Point { x: -1.0, y: 0.5, z: 0.25 }],
        text: "eps".into(),
    }
}

fn diagnostic_status() -> DiagnosticStatus {
    DiagnosticStatus {
        level: level::WARN,
        name: "bycoms/robot_3".into(),
        message: "battery low".into(),
        hardware_id: "cf3".into(),
        values: vec![("battery_v".into(), "3.4".into()), ("link".into(), "ok".into())],
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Ours, by type name: (hash, CDR as hex).
fn ours() -> BTreeMap<String, (String, String)> {
    fixed().into_iter().map(|(d, cdr)| (d.name.to_string(), (d.rihs01(), hex(&cdr)))).collect()
}

/// The talker's publisher of rmw_zenoh's design document (docs/design) (domain 2, depth 7).
fn talker() -> (Node, Endpoint) {
    let node = Node {
        domain_id: 2,
        zid: "8b20917502ee955ac4476e0266340d5c".into(),
        id: 0,
        enclave: "/".into(),
        namespace: "/".into(),
        name: "talker".into(),
    };
    let endpoint = Endpoint {
        id: 10,
        kind: EntityKind::Publisher,
        topic: "/chatter".into(),
        ros_type: "std_msgs/msg/String".into(),
        type_hash: STRING.rihs01(),
        qos: Qos::reliable(7),
    };
    (node, endpoint)
}

// Pinned from `python3 tests/python/ros2_golden.py` (see the module docs).
const PINNED: &[(&str, &str, &str)] = &[
    (
        "builtin_interfaces/msg/Time",
        "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
        "0001000000f1536515cd5b07",
    ),
    (
        "geometry_msgs/msg/Point",
        "RIHS01_6963084842a9b04494d6b2941d11444708d892da2f4b09843b9c43f42a7f6881",
        "00010000000000000000f83f00000000000002c0fca9f1d24d62503f",
    ),
    (
        "geometry_msgs/msg/Pose",
        "RIHS01_d501954e9476cea2996984e812054b68026ae0bfae789d9a10b23daf35cc90fa",
        "00010000000000000000f83f00000000000002c000000000000000000000000000000000000000000000000063a9aea6e27dd83f468d32cf6b90ed3f",
    ),
    (
        "geometry_msgs/msg/PoseStamped",
        "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
        "0001000000f1536515cd5b0706000000776f726c6400000000000000000000000000f83f00000000000002c000000000000000000000000000000000000000000000000063a9aea6e27dd83f468d32cf6b90ed3f",
    ),
    (
        "geometry_msgs/msg/Quaternion",
        "RIHS01_8a765f66778c8ff7c8ab94afcc590a2ed5325a1d9a076ffff38fbce36f458684",
        "00010000000000000000000000000000000000000000000000000000000000000000f03f",
    ),
    (
        "geometry_msgs/msg/Transform",
        "RIHS01_beb83fbe698636351461f6f35d1abb20010c43d55374d81bd041f1ba2581fddc",
        "00010000000000000000f03f0000000000000040000000000000d03f00000000000000000000000000000000000000000000e0bfaa4c58e87ab6eb3f",
    ),
    (
        "geometry_msgs/msg/TransformStamped",
        "RIHS01_0a241f87d04668d94099cbb5ba11691d5ad32c2f29682e4eb5653424bd275206",
        "0001000000f1536515cd5b0706000000776f726c6400000007000000726f626f74310000000000000000f03f0000000000000040000000000000d03f00000000000000000000000000000000000000000000e0bfaa4c58e87ab6eb3f",
    ),
    (
        "geometry_msgs/msg/Vector3",
        "RIHS01_cc12fe83e4c02719f1ce8070bfd14aecd40f75a96696a67a2a1f37f7dbb0765d",
        "00010000000000000000f0bf00000000000000400000000000000c40",
    ),
    (
        "geometry_msgs/msg/Twist",
        "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a",
        "00010000000000000000e03f000000000000c0bf0000000000000040000000000000f0bf000000000000e83f0000000000000a40",
    ),
    (
        "geometry_msgs/msg/TwistStamped",
        "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64",
        "0001000000f1536515cd5b070a000000626173655f6c696e6b000000000000000000d0bf0000000000000000000000000000000000000000000000000000000000000000000000000000f83f",
    ),
    (
        "nav_msgs/msg/Path",
        "RIHS01_1957a5bb3cee5da65c4e52e52b65a93df227efce4c20f8458b36e73066ca334b",
        "0001000000f1536515cd5b0706000000776f726c640000000200000000f1536515cd5b0706000000776f726c64000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000063a9aea6e27dd83f468d32cf6b90ed3f00f1536515cd5b0706000000776f726c6400000000000000000000000000f83f00000000000002c000000000000000000000000000000000000000000000000063a9aea6e27dd83f468d32cf6b90ed3f",
    ),
    (
        "rosgraph_msgs/msg/Clock",
        "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564",
        "000100000c0000000065cd1d",
    ),
    (
        "std_msgs/msg/Header",
        "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01",
        "0001000000f1536515cd5b0708000000726f626f745f3700",
    ),
    (
        "std_msgs/msg/String",
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18",
        "000100000600000068656c6c6f00",
    ),
    (
        "std_srvs/srv/Trigger_Request",
        "RIHS01_d010825374ce8918e72bfd826c82603e60f45419e932ea976f807b74a863a199",
        "0001000000",
    ),
    (
        "std_srvs/srv/Trigger_Response",
        "RIHS01_2d946c21e2fc3f1e9ca6986a8191d85fcc70097a8bb7771a053564bc47009cdf",
        "00010000010000000800000073746f7070656400",
    ),
    (
        "tf2_msgs/msg/TFMessage",
        "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
        "000100000200000000f1536515cd5b0706000000776f726c6400000007000000726f626f7431000000000000000000000000f03f0000000000000040000000000000d03f00000000000000000000000000000000000000000000e0bfaa4c58e87ab6eb3f00f1536515cd5b0706000000776f726c6400000008000000726f626f7431320000000000000008c0000000000000e03f000000000000d03f00000000000000000000000000000000000000000000e0bfaa4c58e87ab6eb3f",
    ),
    (
        "std_msgs/msg/ColorRGBA",
        "RIHS01_77a7a5b9ae477306097665106e0413ba74440245b1f3d0c6d6405fe5c7813fe8",
        "000100000000803f0000003f0000803e0000403f",
    ),
    (
        "visualization_msgs/msg/Marker",
        "RIHS01_45b13ccf791f225962bf74e746f9644518855d783a6f42ba0cc14fde2b4f3ce0",
        "0001000000f1536515cd5b0706000000776f726c6400000008000000626561636f6e7300070000000400000000000000000000000000000000000840000000000000104000000000000000000000000000000000000000000000000063a9aea6e27dd83f468d32cf6b90ed3f9a9999999999b93f9a9999999999c93f333333333333d33f0000803f0000003f0000803e0000403f00000000000000000000000002000000000000000000f03f00000000000000400000000000000000000000000000f0bf000000000000e03f000000000000d03f00000000010000000000000000000000000000000100000000000000010000000000000000000000000000000400000065707300010000000000000001000000000000000000000000",
    ),
    (
        "visualization_msgs/msg/MarkerArray",
        "RIHS01_86cb8800b6fb05b5eff1abd7a56f62a5641d3ae9a1c29e78e67e704f1d067dcf",
        "000100000200000000f1536515cd5b0706000000776f726c6400000008000000626561636f6e73000700000004000000000000000000000000000840000000000000104000000000000000000000000000000000000000000000000063a9aea6e27dd83f468d32cf6b90ed3f9a9999999999b93f9a9999999999c93f333333333333d33f0000803f0000003f0000803e0000403f00000000000000000000000002000000000000000000f03f00000000000000400000000000000000000000000000f0bf000000000000e03f000000000000d03f0000000001000000000000000000000000000000010000000000000001000000000000000000000000000000040000006570730001000000000000000100000000000000000000000000000000f1536515cd5b0706000000776f726c6400000008000000626561636f6e73000200000004000000000000000000000000000840000000000000104000000000000000000000000000000000000000000000000063a9aea6e27dd83f468d32cf6b90ed3f9a9999999999b93f9a9999999999c93f333333333333d33f0000803f0000003f0000803e0000403f00000000000000000000000002000000000000000000f03f00000000000000400000000000000000000000000000f0bf000000000000e03f000000000000d03f00000000010000000000000000000000000000000100000000000000010000000000000000000000000000000200000062000000010000000000000001000000000000000000000000",
    ),
    (
        "nav_msgs/msg/OccupancyGrid",
        "RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7",
        "0001000000f1536515cd5b0706000000776f726c6400000005000000060000000000003f0300000002000000000000000000f0bf000000000000004000000000000000000000000000000000000000000000000063a9aea6e27dd83f468d32cf6b90ed3f060000000064ff000064",
    ),
    (
        "diagnostic_msgs/msg/DiagnosticStatus",
        "RIHS01_b0e3e692ea2d54a8af2f4ef1930e81556a2db55216b771f8a7d2724ed47bf0e4",
        "00010000010000000f0000006279636f6d732f726f626f745f3300000c00000062617474657279206c6f77000400000063663300020000000a000000626174746572795f7600000004000000332e3400050000006c696e6b00000000030000006f6b00",
    ),
    (
        "diagnostic_msgs/msg/DiagnosticArray",
        "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e",
        "0001000000f1536515cd5b07010000000000000002000000010000000f0000006279636f6d732f726f626f745f3300000c00000062617474657279206c6f77000400000063663300020000000a000000626174746572795f7600000004000000332e3400050000006c696e6b00000000030000006f6b000301000000000000000100000000000000010000000000000000000000",
    ),
    (
        "bycoms_msgs/msg/GateEvent",
        "RIHS01_7990ae8bc533bca805736ef451e0bfe2ebac11211ac90c256a1ab8342b4b8d36",
        "000100000c00000000a3e11103000000010100000000000000404640000000000000f4bf7b00000000000000",
    ),
    (
        "bycoms_msgs/msg/RobotState",
        "RIHS01_dc507c82478175801fccaf58825aeff765cccb69ec966a08563e09243d3a8b3e",
        "0001000000f1536515cd5b0706000000776f726c640000000200000002000000000000000000000000003e400000000000803f40000000000000e0bf070000000000000001",
    ),
];

const PINNED_GIDS: &[(&str, &str)] = &[
    ("@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,7:,:,:,,", "ac170f31eadcd9ff0cd86d7a17907d1c"),
    ("@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener", "49877999dacb858702d11ac823785912"),
];

const PINNED_SERVICES: &[(&str, &str)] = &[
    (
        "example_interfaces/srv/AddTwoInts",
        "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a",
    ),
    ("std_srvs/srv/Trigger", "RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f"),
];

const PINNED_ATTACHMENT: &str = "2a0000000000000015cd853dfe9c971710ac170f31eadcd9ff0cd86d7a17907d1c";

#[test]
fn every_hash_and_every_cdr_message_is_rosbags_own() {
    let pinned: BTreeMap<String, (String, String)> =
        PINNED.iter().map(|(n, h, c)| (n.to_string(), (h.to_string(), c.to_string()))).collect();
    let ours = ours();
    assert_eq!(ours.keys().collect::<Vec<_>>(), pinned.keys().collect::<Vec<_>>(), "the same kinds");
    for (name, (hash, cdr)) in &ours {
        assert_eq!((hash, cdr), (&pinned[name].0, &pinned[name].1), "{name}: ours, then rosbags'");
    }
}

// rmw_zenoh's documented service example, built as rosidl builds a service.
static ADD_REQUEST: TypeDescription = TypeDescription {
    name: "example_interfaces/srv/AddTwoInts_Request",
    fields: &[Field::prim("a", Primitive::Int64), Field::prim("b", Primitive::Int64)],
};
static ADD_RESPONSE: TypeDescription = TypeDescription {
    name: "example_interfaces/srv/AddTwoInts_Response",
    fields: &[Field::prim("sum", Primitive::Int64)],
};
static ADD_EVENT: TypeDescription = TypeDescription {
    name: "example_interfaces/srv/AddTwoInts_Event",
    fields: &[
        Field::nested("info", &SERVICE_EVENT_INFO),
        Field::bounded("request", &ADD_REQUEST, 1),
        Field::bounded("response", &ADD_RESPONSE, 1),
    ],
};
static ADD_TWO_INTS: TypeDescription = TypeDescription {
    name: "example_interfaces/srv/AddTwoInts",
    fields: &[
        Field::nested("request_message", &ADD_REQUEST),
        Field::nested("response_message", &ADD_RESPONSE),
        Field::nested("event_message", &ADD_EVENT),
    ],
};

fn services() -> BTreeMap<&'static str, String> {
    [&ADD_TWO_INTS, &TRIGGER].into_iter().map(|t| (t.name, t.rihs01())).collect()
}

/// The documented example (rmw_zenoh's design document: `2/add_two_ints/…`)
/// fixes how a service is hashed; Trigger is hashed the same way.
#[test]
fn service_hashes_are_rmw_zenohs_example_and_rosbags() {
    assert_eq!(
        topic_key_expr(2, "/add_two_ints", "example_interfaces/srv/AddTwoInts", &ADD_TWO_INTS.rihs01()),
        "2/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"
    );
    let pinned: BTreeMap<&str, String> = PINNED_SERVICES.iter().map(|(n, h)| (*n, h.to_string())).collect();
    assert_eq!(services(), pinned);
}

#[test]
fn gids_are_xxh3_128_little_endian_as_pythons_xxhash_gives() {
    for (token, expected) in PINNED_GIDS {
        assert_eq!(hex(&gid(token)), *expected, "{token}");
    }
}

#[test]
fn the_attachment_is_zenoh_exts_serialization() {
    let (node, endpoint) = talker();
    let mut publisher = Publisher::new(&node, &endpoint).expect("token");
    let first = publisher.next_attachment(7);
    assert_eq!(first.sequence_number, 1, "rmw_zenoh counts from 1");
    let a = Attachment {
        sequence_number: 42,
        source_timestamp_ns: 1_700_000_000_123_456_789,
        gid: publisher.gid,
    };
    assert_eq!(hex(&a.encode()), PINNED_ATTACHMENT);
    assert_eq!(Attachment::decode(&a.encode()), Ok(a));
}

/// rmw_zenoh's design document (docs/design), "Topic and Service name mapping to Zenoh key expressions".
#[test]
fn key_expressions_are_rmw_zenohs_documented_examples() {
    let hash = STRING.rihs01();
    assert_eq!(
        topic_key_expr(0, "/chatter", "std_msgs/msg/String", &hash),
        "0/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    );
    assert_eq!(
        topic_key_expr(0, "/robot1/chatter", "std_msgs/msg/String", &hash),
        "0/robot1/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    );
}

/// rmw_zenoh's design document (docs/design), "Graph Cache": the listener node's token,
/// its subscription's and the talker's publisher's.
#[test]
fn tokens_are_rmw_zenohs_documented_examples() {
    let (talker, publisher) = talker();
    assert_eq!(
        liveliness_token(&talker, Some(&publisher)).expect("token"),
        "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,7:,:,:,,"
    );
    let listener = Node { zid: "aac3178e146ba6f1fc6e6a4085e77f21".into(), name: "listener".into(), ..talker };
    assert_eq!(
        liveliness_token(&listener, None).expect("token"),
        "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener"
    );
    let sub = Endpoint { kind: EntityKind::Subscription, qos: Qos::reliable(10), ..publisher };
    assert_eq!(
        liveliness_token(&listener, Some(&sub)).expect("token"),
        "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/10/MS/%/%/listener/%chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,10:,:,:,,"
    );
}

/// The compact QoS of what rmw_zenoh's `qos_to_keyexpr` writes for the
/// policies bycoms uses: only what differs from its default.
#[test]
fn qos_writes_only_what_differs_from_rmw_zenohs_default() {
    assert_eq!(Qos::RMW_ZENOH_DEFAULT.key_expr(), "::,:,:,:,,");
    assert_eq!(Qos::best_effort(5).key_expr(), "2::,5:,:,:,,");
    assert_eq!(Qos::transient_local(1).key_expr(), ":1:,1:,:,:,,");
    let keep_all = Qos { history: bycoms_ros2::rmw_zenoh::policy::KEEP_ALL, ..Qos::reliable(1) };
    assert_eq!(keep_all.key_expr(), "::2,1:,:,:,,");
}

fn golden_script() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/python/ros2_golden.py")
}

#[test]
#[ignore = "needs the PyPI packages rosbags==0.11.9, xxhash==4.1.0 and eclipse-zenoh==1.10.2"]
fn the_pins_are_what_rosbags_xxhash_and_zenoh_say_today() {
    let out = Command::new("python3").arg(golden_script()).output().expect("python3 runs");
    assert!(out.status.success(), "the script failed: {}", String::from_utf8_lossy(&out.stderr));
    let live: serde_json::Value = serde_json::from_slice(&out.stdout).expect("the script prints JSON");
    let ours = ours();
    assert_eq!(live["hashes"].as_object().map(|o| o.len()), Some(ours.len()), "the same kinds: {live}");
    for (name, (hash, cdr)) in &ours {
        assert_eq!(live["hashes"][name], *hash, "{name}'s hash: rosbags, then ours");
        assert_eq!(live["cdr"][name], *cdr, "{name}'s CDR: rosbags, then ours");
    }
    let gids = live["gid"].as_object().expect("gids");
    assert_eq!(gids.len(), PINNED_GIDS.len());
    for (token, expected) in gids {
        assert_eq!(hex(&gid(token)), expected.as_str().expect("hex"), "{token}");
    }
    for (name, hash) in services() {
        assert_eq!(live["services"][name], *hash, "{name}'s hash: rosbags, then ours");
    }
    assert_eq!(live["attachment"], PINNED_ATTACHMENT);
}

/// A token reads back as what it announces: the documented talker's
/// publisher, the listener's node; anything else is not a token.
#[test]
fn tokens_read_back_as_what_they_announce() {
    use bycoms_ros2::rmw_zenoh::TokenView;
    let (talker, publisher) = talker();
    let token = liveliness_token(&talker, Some(&publisher)).expect("token");
    let view = TokenView::parse(&token).expect("a token");
    assert_eq!(
        (view.domain_id, view.zid.as_str(), view.kind, view.node.as_str(), view.topic.as_str()),
        (2, "8b20917502ee955ac4476e0266340d5c", EntityKind::Publisher, "talker", "/chatter")
    );
    assert_eq!((view.dds_type.as_str(), view.type_hash), ("std_msgs::msg::dds_::String_", STRING.rihs01()));
    let node =
        TokenView::parse("@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener").expect("node");
    assert_eq!((node.kind, node.node.as_str(), node.topic.as_str()), (EntityKind::Node, "listener", ""));
    for bad in [
        "",
        "@ros2_lv/2/z/0/0/XX/%/%/n",
        "@ros2_lv/x/z/0/0/NN/%/%/n",
        "bycoms/s/alive",
        "@ros2_lv/2/z/0/1/MP/%/%/n",
    ] {
        assert_eq!(TokenView::parse(bad), None, "{bad}");
    }
}
