"""The ROS 2 wire format's expected values, from implementations that are not ours.

Prints one JSON object: the REP-2016 type hash (RIHS01) and the CDR bytes of
each message kind bycoms-ros2 speaks, from PyPI `rosbags` (its Jazzy type
store, `hash_rihs01`, `serialize_cdr`); the GID of rmw_zenoh liveliness
tokens, from PyPI `xxhash` (XXH3-128, laid out as rmw_zenoh lays it: the
128-bit value little-endian, low 64 bits first); the 33-byte attachment,
from eclipse-zenoh's own serializer (`zenoh.ext.z_serialize`, as rmw_zenoh's
zenoh-cpp `ext::Serializer` writes it).

protocol/ros2/tests/golden.rs pins this output and, in an `#[ignore]`d test
that `.ci/run` runs, compares it live. The fixed inputs below are the same
as that test's (`FIXED` there).
"""

import json

import xxhash
from rosbags.typesys import Stores, get_typestore
from zenoh.ext import Int64, z_serialize

TS = get_typestore(Stores.ROS2_JAZZY)
T = TS.types

STAMP = T["builtin_interfaces/msg/Time"](sec=1_700_000_000, nanosec=123_456_789)


def header(frame):
    return T["std_msgs/msg/Header"](stamp=STAMP, frame_id=frame)


def pose(x, y, z, qz, qw):
    point = T["geometry_msgs/msg/Point"](x=x, y=y, z=z)
    quat = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=qz, w=qw)
    return T["geometry_msgs/msg/Pose"](position=point, orientation=quat)


def pose_stamped(x, y):
    return T["geometry_msgs/msg/PoseStamped"](
        header=header("world"), pose=pose(x, y, 0.0, 0.3826834323650898, 0.9238795325112867)
    )


def transform(child, x, y):
    v = T["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.25)
    q = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=-0.5, w=0.8660254037844386)
    tf = T["geometry_msgs/msg/Transform"](translation=v, rotation=q)
    return T["geometry_msgs/msg/TransformStamped"](
        header=header("world"), child_frame_id=child, transform=tf
    )


MESSAGES = {
    "builtin_interfaces/msg/Time": STAMP,
    "std_msgs/msg/String": T["std_msgs/msg/String"](data="hello"),
    "std_msgs/msg/Header": header("robot_7"),
    "geometry_msgs/msg/Point": T["geometry_msgs/msg/Point"](x=1.5, y=-2.25, z=1e-3),
    "geometry_msgs/msg/Quaternion": T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
    "geometry_msgs/msg/Vector3": T["geometry_msgs/msg/Vector3"](x=-1.0, y=2.0, z=3.5),
    "geometry_msgs/msg/Pose": pose(1.5, -2.25, 0.0, 0.3826834323650898, 0.9238795325112867),
    "geometry_msgs/msg/PoseStamped": pose_stamped(1.5, -2.25),
    "geometry_msgs/msg/Transform": transform("robot1", 1.0, 2.0).transform,
    "geometry_msgs/msg/TransformStamped": transform("robot1", 1.0, 2.0),
    "tf2_msgs/msg/TFMessage": T["tf2_msgs/msg/TFMessage"](
        transforms=[transform("robot1", 1.0, 2.0), transform("robot12", -3.0, 0.5)]
    ),
    "nav_msgs/msg/Path": T["nav_msgs/msg/Path"](
        header=header("world"), poses=[pose_stamped(0.0, 0.0), pose_stamped(1.5, -2.25)]
    ),
    "rosgraph_msgs/msg/Clock": T["rosgraph_msgs/msg/Clock"](
        clock=T["builtin_interfaces/msg/Time"](sec=12, nanosec=500_000_000)
    ),
}

# Tokens as rmw_zenoh's design document (docs/design) shows them.
TOKENS = [
    "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener",
    "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/"
    "std_msgs::msg::dds_::String_/"
    "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,7:,:,:,,",
]


def gid(token):
    return xxhash.xxh3_128_intdigest(token.encode()).to_bytes(16, "little")


def main():
    out = {
        "hashes": {name: TS.hash_rihs01(name) for name in MESSAGES},
        "cdr": {name: TS.serialize_cdr(msg, name).hex() for name, msg in MESSAGES.items()},
        "gid": {token: gid(token).hex() for token in TOKENS},
        "attachment": z_serialize(
            (Int64(42), Int64(1_700_000_000_123_456_789), gid(TOKENS[1]))
        ).to_bytes().hex(),
    }
    print(json.dumps(out, indent=1, sort_keys=True))


if __name__ == "__main__":
    main()
